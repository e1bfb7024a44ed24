// libFuzzer harness: the sweep-file parser (toml++ and hysid's checks). Any input must give a
// configuration or std::invalid_argument; an accepted configuration is small enough to enumerate.
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string_view>

#include "core/builtin/builtin.hpp"
#include "core/model/registry.hpp"
#include "experiments/sweep/config.hpp"
#include "experiments/sweep/plan.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const hysid::ModelRegistry registry = [] {
    hysid::ModelRegistry r;
    hysid::RegisterBuiltinModels(r);
    return r;
  }();
  try {
    const hysid::SweepConfig c = hysid::ParseSweepText(
        std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.toml", registry);
    if (c.trials < 1 || c.models.empty() || c.grid.dt.empty() || c.grid.sigma.empty()) __builtin_trap();
    std::size_t size = c.grid.dt.size() * c.grid.sigma.size() * c.grid.estimator.size() *
                       c.grid.detector.size() * c.grid.refine.size();
    for (const hysid::OptionAxis& axis : c.grid.options) size *= axis.values.size();
    if (size <= 10000 && hysid::EnumerateCells(c).empty()) __builtin_trap();
    (void)c.Hash();
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
