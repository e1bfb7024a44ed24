// The discrete part of a hybrid automaton read from a ModelSpec: modes, jump maps, which guards are
// armed in a mode and which map a guard's crossing applies. A spec without modes and maps is the
// paper's class: one mode, one map that every guard triggers, ψ over all of β.
#pragma once

#include <vector>

#include "core/model/model.hpp"

namespace hysid {

// max(1, |modes|).
int ModeCount(const ModelSpec& spec);
// spec.jumps, or the one implicit map (name "jump", every guard: guard = −1, all of β, jump_rows).
std::vector<JumpMap> JumpMaps(const ModelSpec& spec);
// The map that a crossing of guard `guard` applies in mode `mode`, or −1 when the guard is not armed
// there. The implicit map (spec.jumps empty) is armed for every guard in every mode.
int ArmedMap(const ModelSpec& spec, int mode, int guard);
// The mode after map `map` fires in mode `mode` (JumpMap::to, or `mode` when it is −1).
int ModeAfter(const ModelSpec& spec, int mode, int map);
// True when the spec has several modes or explicit jump maps (beyond the paper's class).
bool IsAutomaton(const ModelSpec& spec);

}  // namespace hysid
