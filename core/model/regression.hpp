// The two linear regressions of the method, on the rows that carry unknown parameters (§4.3).
//
// Flow (eq. 7, trapezoid rule): Δξ_r(t) = Φ_r(t) α_u + Φ_{r,known}(t) α_k,
//   Φ(t) = (δt/2)(φ(ξ(t)) + φ(ξ(t−δt))),  r = the model's flow_rows, u/k = unknown/known columns.
//   Regressed: y = Δξ_r − Φ_{r,k} α_k  on  Φ_{r,u}.
// Jump (eq. 5): ξ_r(t) = ψ_r(ξ(t−δt)) β, regressed the same way on the unknown columns of β.
#pragma once

#include <vector>

#include "core/model/model.hpp"

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
  // The same with each sample's context (its time and measured inputs u): the trapezoid takes φ at
  // both ends with their own u, Φ(t) = (δt/2)(φ(ξ(t−δt), u(t−δt)) + φ(ξ(t), u(t))). For models with
  // inputs (the x-only forms are for models without).
  void Flow(const ConstVecRef& prev, const ConstVecRef& cur, double dt, MatRef phi, VecRef y,
            const Context& at_prev, const Context& at_cur);
  // The same for a layout with one identified row (flow_layout().rows.size() == 1 is required, the
  // common case): prev and cur hold n states, phi receives the |u| entries of Φ_{r,u}, y one value.
  // No Eigen::Ref, index lists resolved in advance. Flow() calls it for such layouts, so the two
  // agree bit for bit.
  void FlowRow(const double* prev, const double* cur, double dt, double* phi, double* y);
  // FlowRow for the `count` consecutive pairs (prev, x_0), (x_0, x_1), …, (x_{count−2}, x_{count−1})
  // with x_k = xs[k·n .. k·n + n): row k of Φ at phi + k·|u|, y_k at y[k]. Row r of φ is evaluated
  // for blocks of samples with one call (Model::PhiRowColumns: a model file evaluates that row's
  // expressions alone) and at each state once. Same values as FlowRow on each pair.
  void FlowRows(const double* prev, const double* xs, Eigen::Index count, double dt, double* phi, double* y);
  // Jump regression: ξ_r(t) on ψ_{r,u}(ξ(t−δt)), ψ at the pre-jump sample's context when given.
  void Jump(const ConstVecRef& prev, const ConstVecRef& cur, MatRef psi, VecRef y);
  void Jump(const ConstVecRef& prev, const ConstVecRef& cur, MatRef psi, VecRef y, const Context& at_prev);

 private:
  void EvaluatePhi(const double* prev, const double* cur, Eigen::Index n);
  // Rows from phi_prev_ and phi_cur_ (the several-row form of Flow).
  void FlowFromPhi(const ConstVecRef& prev, const ConstVecRef& cur, double dt, MatRef phi, VecRef y);
  void JumpFromPsi(const ConstVecRef& cur, MatRef psi, VecRef y);
  template <int U, int K>
  void FlowRowsFor(const double* prev, const double* xs, Eigen::Index count, double dt, double* phi,
                   double* y);
  static constexpr Eigen::Index kBlock = 64;  // states per PhiColumns call

  Model model_;
  RegressionLayout flow_, jump_;
  Vec alpha_, beta_;  // true values (only the known entries are used)
  Mat phi_prev_, phi_cur_, psi_;
  // The last state of the previous call. One-row layouts (FlowRow, FlowRows) keep their row of φ
  // there in row_last_, others (Flow) all of φ in phi_cur_; a builder only ever takes one of the two.
  Vec last_cur_;
  bool have_last_ = false;
  // One identified row r: offsets c·n + r of φ(r, c) in the column-major φ for the unknown and the
  // known columns c, and the known α_c.
  std::vector<Eigen::Index> row_unknown_, row_known_;
  std::vector<double> row_known_alpha_;
  double row_last_[Model::kMaxAlpha] = {};  // row r of φ at last_cur_ (one-row layouts)
  std::vector<double> phi_block_;                // φ of up to kBlock states
};

}  // namespace hysid
