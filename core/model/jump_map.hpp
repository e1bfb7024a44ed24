// One jump map of a hybrid automaton: which guard triggers it, in which mode, into which mode, and its
// slice of the one β vector (docs/architecture.md "Systems as measured and hybrid automata").
#pragma once

#include <string>
#include <vector>

namespace hysid {

// ξ+ = ψ_m(ξ)β on the map's slice [beta_first, beta_first + beta_count) of β: a model's ψ(ξ) with
// Context::map = m is n × |β| with zeros outside that slice, so ψ(ξ)β = ψ_m(ξ)β_m and one regression
// over β keeps every map's parameters apart. A map without ψ (`identity`) is ξ+ = ξ: a mode switch.
struct JumpMap {
  std::string name;
  int guard = 0;        // index into ModelSpec::guards: the guard whose crossing triggers this map
  int from = -1;        // mode the map leaves (−1: any mode)
  int to = -1;          // mode it enters (−1: the mode it left)
  int beta_first = 0;   // its slice of β
  int beta_count = 0;
  std::vector<int> rows = {};  // state components its ψ changes with unknown β (reduced order, §4.3)
  bool identity = false;       // no ψ: ξ+ = ξ (beta_count 0, rows empty)
};

}  // namespace hysid
