// Sub-sample jump localisation: a jump detected in (t−δt, t] happened at an unknown s inside it.
//
// The jump map's known rows (state components outside ModelSpec::jump_rows, whose ψ row carries only
// known parameters — for impact-msd ξ1+ = ξ1) tie the pre-jump and post-jump states together. With
// the estimated flow f̂(ξ) = φ(ξ)α̂, flow forward from ξ(t−δt) to s (x_f(s)) and backward from ξ(t)
// to s (x_b(s)) and find s where, on a known row i, x_b,i(s) = (ψ(x_f(s))β)_i. Then x_f(s) is the
// state just before the jump and x_b(s) just after: the jump regression uses ξ_r(s+) on ψ(ξ(s−))
// instead of ξ_r(t) on ψ(ξ(t−δt)), which removes its O(δt) bias.
//
// Integration: RK4 with kSubsteps equal steps from the interval's end to s (local error
// O((δt·‖∂f/∂ξ‖)^5/kSubsteps^4)). Root: the Illinois variant of regula falsi on the known row whose
// residual changes most across the interval, stopped when the bracket is below 1e-14·δt.
// Not located (the caller falls back to the unlocalised pair) when the model has no known jump row,
// the residual does not change sign across the interval, or a state becomes non-finite.
#pragma once

#include "core/model/model.hpp"

namespace hysid {

struct JumpLocation {
  double fraction = 0.0;  // (s − (t−δt)) / δt ∈ [0, 1]
  Vec pre;                // x_f(s): the state just before the jump
  Vec post;               // x_b(s): the state just after
  int iterations = 0;
};

class JumpLocalizer {
 public:
  static constexpr int kSubsteps = 4;

  explicit JumpLocalizer(const Model& model);
  // True when located; `alpha` is the full α̂ used for the flow.
  bool Locate(ConstVecRef prev, ConstVecRef cur, double dt, ConstVecRef alpha, JumpLocation* out);
  bool has_known_rows() const { return !known_rows_.empty(); }

 private:
  // x(τ) from x(0) = x0 by the flow over time `span` (may be negative).
  void Flow(ConstVecRef x0, double span, ConstVecRef alpha, VecRef out);
  // Residual of every known row at fraction θ; writes pre/post.
  void Residual(double theta, VecRef residual);

  Model model_;
  std::vector<int> known_rows_;
  Vec beta_known_;  // β with unknown entries zeroed: exact on the known rows
  // Scratch for one Locate call.
  Vec prev_, cur_, alpha_;
  double dt_ = 0.0;
  Vec k1_, k2_, k3_, k4_, tmp_, pre_, post_, jump_;
};

}  // namespace hysid
