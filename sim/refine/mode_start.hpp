// A start for the flow parameters α of a hybrid automaton whose mode is not measured, from the data
// alone (docs/method.md "A start from the modes the data show"). Internal to sim/refine.
//
// Where the start's α is far, the modes' flows at the start may all bend the same way (a heater
// whose "on" flow still cools), so every segment's best mode is the same one, and a fit on those
// modes collapses onto the data's mean (the modes then indistinguishable). Here the chains are cut
// into windows of `window` steps; per window w and mode q the trapezoid-integrated model
// Δx_w = G_wq α (G_wq = Σ ½ δt (φ_q(x_{k−1}) + φ_q(x_k)) over the window's steps, the data as the
// state) is linear in α. Hard expectation–maximisation: each window takes the mode of least weighted
// residual, α is the least-squares solution over the windows with their modes (known entries fixed,
// each within its bounds), until the modes stop changing. Two first assignments: each window's
// best mode at the start's α, and the best one after each mode's cost is centred on its mean over
// the windows (which removes a bias all windows share); the assignment of lower cost wins. Windows
// whose cost exceeds 25 × the median (a jump inside, an outlier) are left out of α's solve.
#pragma once

#include <optional>
#include <vector>

#include "sim/refine/refine.hpp"
#include "sim/sensitivity/sensitivity.hpp"

namespace hysid {

// α (every entry, known ones as in `start`) from the windows' modes, or nullopt when the model is not
// an automaton with at least two modes, some state is not measured (`rows`), no α entry is unknown,
// or fewer windows than unknowns hold finite samples.
std::optional<Vec> ModeClusteredAlpha(const Model& model, const std::vector<RefineChain>& chains,
                                      const std::vector<int>& rows, const HybridParameters& start,
                                      const Unknowns& unknowns, long window);

}  // namespace hysid
