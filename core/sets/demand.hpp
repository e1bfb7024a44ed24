// Internal invariants of the set code (style tier b): always on; a failed one prints what broke and
// aborts. Not installed: included by the .cpp files of core/sets only.
#pragma once

#include <cstdio>
#include <cstdlib>

namespace hysid::sets_internal {

// `where` names the component ("SampleSet", "SampleSet (n >= 3)").
inline void Demand(bool ok, const char* where, const char* what) {
  if (!ok) {
    std::fprintf(stderr, "hysid: internal error in %s: %s\n", where, what);
    std::abort();
  }
}

}  // namespace hysid::sets_internal
