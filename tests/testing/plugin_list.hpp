// A check of a plugin family (core/model/plugin.hpp): the descriptor at each kind's place in the
// list is that kind's, by name both ways, and the factory builds the class of that name.
#pragma once

#include <catch2/catch.hpp>

#include <string>
#include <utility>
#include <vector>

#include "core/model/plugin.hpp"

namespace hysid::testing {

// `kinds`: every enumerator with its plugin's name; `make(kind)` builds that plugin.
template <class Kind, class Make>
void CheckPluginList(const std::vector<std::pair<Kind, std::string>>& kinds, Make make) {
  REQUIRE(AllPlugins<Kind>().size() == kinds.size());
  for (const auto& [kind, name] : kinds) {
    INFO(name);
    CHECK(ToString(kind) == name);
    CHECK(ParseKind<Kind>(name) == kind);
    CHECK(make(kind)->name() == name);
  }
  const std::string family(Plugins(Kind{}).family);
  CHECK_THROWS_WITH(DescriptorOf(static_cast<Kind>(kinds.size())), Catch::Contains("no such " + family));
}

}  // namespace hysid::testing
