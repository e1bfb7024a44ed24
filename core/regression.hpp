// The two linear regressions of the method, on the rows that carry unknown parameters (§4.3).
//
// Flow (eq. 7, trapezoid rule): Δξ_r(t) = Φ_r(t) α_u + Φ_{r,known}(t) α_k,
//   Φ(t) = (δt/2)(φ(ξ(t)) + φ(ξ(t−δt))),  r = the model's flow_rows, u/k = unknown/known columns.
//   Regressed: y = Δξ_r − Φ_{r,k} α_k  on  Φ_{r,u}.
// Jump (eq. 5): ξ_r(t) = ψ_r(ξ(t−δt)) β, regressed the same way on the unknown columns of β.
#pragma once

#include <vector>

#include "core/model.hpp"

namespace hysid {

// Which rows and columns of φ (or ψ) are regressed.
struct RegressionLayout {
  std::vector<int> rows;     // identified state components
  std::vector<int> unknown;  // parameter indices estimated
  std::vector<int> known;    // parameter indices held at their known value
  int state_size = 0;
  int parameter_size = 0;

  static RegressionLayout Flow(const Model& model);
  static RegressionLayout Jump(const Model& model);
  // The full parameter vector from the known values and an estimate of the unknown ones.
  Vec Assemble(const Vec& known_values, const Vec& estimate) const;
  // The unknown entries of a full parameter vector.
  Vec Unknown(const Vec& full) const;
};

// Builds regressions for one model without allocating per sample.
class RegressionBuilder {
 public:
  explicit RegressionBuilder(const Model& model);

  const RegressionLayout& flow_layout() const { return flow_; }
  const RegressionLayout& jump_layout() const { return jump_; }

  // Flow regression of the pair (ξ(t−δt), ξ(t)): writes Φ_{r,u} (rows × |u|) and y (rows).
  void Flow(const ConstVecRef& prev, const ConstVecRef& cur, double dt, MatRef phi, VecRef y);
  // Jump regression: ξ_r(t) on ψ_{r,u}(ξ(t−δt)).
  void Jump(const ConstVecRef& prev, const ConstVecRef& cur, MatRef psi, VecRef y);

 private:
  Model model_;
  RegressionLayout flow_, jump_;
  Vec alpha_, beta_;  // true values (only the known entries are used)
  Mat phi_prev_, phi_cur_, psi_;
  Vec last_cur_;          // the state phi_cur_ was evaluated at
  bool have_last_ = false;
};

}  // namespace hysid
