#include "core/model/automaton.hpp"

namespace hysid {

int ModeCount(const ModelSpec& spec) { return spec.modes.empty() ? 1 : static_cast<int>(spec.modes.size()); }

std::vector<JumpMap> JumpMaps(const ModelSpec& spec) {
  if (!spec.jumps.empty()) return spec.jumps;
  return {JumpMap{.name = "jump",
                  .guard = -1,
                  .from = -1,
                  .to = -1,
                  .beta_first = 0,
                  .beta_count = static_cast<int>(spec.beta.size()),
                  .rows = spec.jump_rows,
                  .identity = false}};
}

int ArmedMap(const ModelSpec& spec, int mode, int guard) {
  if (spec.jumps.empty()) return 0;
  for (std::size_t m = 0; m < spec.jumps.size(); ++m) {
    const JumpMap& map = spec.jumps[m];
    if (map.guard == guard && (map.from < 0 || map.from == mode)) return static_cast<int>(m);
  }
  return -1;
}

int ModeAfter(const ModelSpec& spec, int mode, int map) {
  if (map < 0 || map >= static_cast<int>(spec.jumps.size())) return mode;
  const int to = spec.jumps[static_cast<std::size_t>(map)].to;
  return to < 0 ? mode : to;
}

bool IsAutomaton(const ModelSpec& spec) { return spec.modes.size() > 1 || !spec.jumps.empty(); }

}  // namespace hysid
