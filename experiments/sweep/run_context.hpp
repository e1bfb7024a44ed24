// The context block every result carries: what built it and how (git revision, build type,
// library versions), in the spirit of Google Benchmark's JSON "context".
#pragma once

#include <nlohmann/json.hpp>

namespace hysid {

nlohmann::json BuildContext();

}  // namespace hysid
