#include "core/regression.hpp"

namespace hysid {
namespace {

RegressionLayout MakeLayout(const std::vector<Parameter>& params, const std::vector<int>& rows,
                            int n) {
  RegressionLayout layout;
  layout.rows = rows;
  layout.state_size = n;
  layout.parameter_size = static_cast<int>(params.size());
  for (int i = 0; i < static_cast<int>(params.size()); ++i) {
    (params[static_cast<std::size_t>(i)].known ? layout.known : layout.unknown).push_back(i);
  }
  return layout;
}

}  // namespace

RegressionLayout RegressionLayout::Flow(const Model& model) {
  return MakeLayout(model.spec().alpha, model.spec().flow_rows, model.state_size());
}

RegressionLayout RegressionLayout::Jump(const Model& model) {
  return MakeLayout(model.spec().beta, model.spec().jump_rows, model.state_size());
}

Vec RegressionLayout::Assemble(const Vec& known_values, const Vec& estimate) const {
  Vec full = known_values;
  for (std::size_t i = 0; i < unknown.size(); ++i) full[unknown[i]] = estimate[Eigen::Index(i)];
  return full;
}

Vec RegressionLayout::Unknown(const Vec& full) const {
  Vec u(static_cast<Eigen::Index>(unknown.size()));
  for (std::size_t i = 0; i < unknown.size(); ++i) u[Eigen::Index(i)] = full[unknown[i]];
  return u;
}

RegressionBuilder::RegressionBuilder(const Model& model)
    : model_(model),
      flow_(RegressionLayout::Flow(model)),
      jump_(RegressionLayout::Jump(model)),
      alpha_(model.alpha()),
      beta_(model.beta()),
      phi_prev_(model.state_size(), model.alpha_size()),
      phi_cur_(model.state_size(), model.alpha_size()),
      psi_(model.state_size(), model.beta_size()),
      last_cur_(model.state_size()) {}

void RegressionBuilder::Flow(const ConstVecRef& prev, const ConstVecRef& cur, double dt, MatRef phi,
                             VecRef y) {
  // Consecutive pairs share a sample: φ(ξ(t−δt)) is the previous call's φ(ξ(t)).
  const Eigen::Index n = cur.size();
  bool consecutive = have_last_ && n == last_cur_.size();
  for (Eigen::Index i = 0; consecutive && i < n; ++i) consecutive = prev[i] == last_cur_[i];
  if (consecutive) {
    phi_prev_.swap(phi_cur_);
  } else {
    model_.Phi(prev, phi_prev_);
  }
  model_.Phi(cur, phi_cur_);
  if (last_cur_.size() != n) last_cur_.resize(n);
  for (Eigen::Index i = 0; i < n; ++i) last_cur_[i] = cur[i];
  have_last_ = true;
  const double h = 0.5 * dt;
  for (std::size_t i = 0; i < flow_.rows.size(); ++i) {
    const int r = flow_.rows[i];
    double yi = cur[r] - prev[r];
    for (int c : flow_.known) yi -= h * (phi_prev_(r, c) + phi_cur_(r, c)) * alpha_[c];
    y[Eigen::Index(i)] = yi;
    for (std::size_t j = 0; j < flow_.unknown.size(); ++j) {
      const int c = flow_.unknown[j];
      phi(Eigen::Index(i), Eigen::Index(j)) = h * (phi_prev_(r, c) + phi_cur_(r, c));
    }
  }
}

void RegressionBuilder::Jump(const ConstVecRef& prev, const ConstVecRef& cur, MatRef psi, VecRef y) {
  model_.Psi(prev, psi_);
  for (std::size_t i = 0; i < jump_.rows.size(); ++i) {
    const int r = jump_.rows[i];
    double yi = cur[r];
    for (int c : jump_.known) yi -= psi_(r, c) * beta_[c];
    y[Eigen::Index(i)] = yi;
    for (std::size_t j = 0; j < jump_.unknown.size(); ++j) {
      psi(Eigen::Index(i), Eigen::Index(j)) = psi_(r, jump_.unknown[j]);
    }
  }
}

}  // namespace hysid
