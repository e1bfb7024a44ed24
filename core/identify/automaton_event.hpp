// What the recursive pass finds of a hybrid automaton's discrete part: its events (jumps in ξ and mode
// switches that leave ξ continuous), each assigned to a jump map (core/model/automaton.hpp), and the
// settings of the switch (kink) detector (core/identify/events.hpp).
#pragma once

namespace hysid {

struct AutomatonEvent {
  long sample = 0;     // the first sample after the event (in the new mode)
  double time = 0.0;   // a jump: t of that sample; a switch: the located instant in (t_{k−1}, t_k]
  bool jump = true;    // a jump in ξ (the jump detector) or a mode switch (a kink, an identity map)
  int map = -1;        // the assigned jump map; −1: none of the event's kind is armed or exists
  int guard = -1;      // that map's guard
  bool armed = true;   // false: no map of the event's kind is armed in mode_before (nearest of all)
  int mode_before = 0, mode_after = 0;
  // |h|/‖∇ₓh‖ of the assigned guard, least over the flow step from the pre-event sample (0: the guard
  // changes sign within it); NaN when it could not be evaluated.
  double guard_distance = 0.0;
  // A switch: its slope-change statistic (standard deviations); a jump: 0.
  double statistic = 0.0;
};

// Mode switches without a jump are kinks of ξ: the slope of a degree-2 fit to the `window` samples
// before a candidate instant against that of the `window` after, over its standard deviation (from
// the noise σ the data give, EstimateNoiseSigma), above `threshold` and the largest within ±window.
// `window` is the least: DetectKinks widens it (up to a quarter of the longest segment, 256 at most)
// until a slope change the size of the data's median |slope| would stand at 1.5 × threshold.
struct KinkSettings {
  double threshold = 8.0;
  int window = 16;  // ≥ 4; fits near a segment's end use what the segment has (≥ 4 samples)
};

}  // namespace hysid
