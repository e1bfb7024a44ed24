#include "core/model/regression.hpp"

#include <algorithm>

namespace hysid {
namespace {

RegressionLayout MakeLayout(const std::vector<Parameter>& params, const std::vector<int>& rows, int n) {
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
      last_cur_(model.state_size()),
      phi_block_(std::size_t(kBlock) * std::size_t(model.state_size()) * std::size_t(model.alpha_size())) {
  if (flow_.rows.size() == 1) {
    const Eigen::Index n = model.state_size(), r = flow_.rows[0];
    for (int c : flow_.unknown) row_unknown_.push_back(c * n + r);
    for (int c : flow_.known) {
      row_known_.push_back(c * n + r);
      row_known_alpha_.push_back(alpha_[c]);
    }
  }
}

void RegressionBuilder::Flow(const ConstVecRef& prev, const ConstVecRef& cur, double dt, MatRef phi,
                             VecRef y) {
  if (flow_.rows.size() == 1) {
    double row[Model::kMaxAlpha];
    FlowRow(prev.data(), cur.data(), dt, row, y.data());
    for (std::size_t j = 0; j < flow_.unknown.size(); ++j) phi(0, Eigen::Index(j)) = row[j];
    return;
  }
  EvaluatePhi(prev.data(), cur.data(), last_cur_.size());
  FlowFromPhi(prev, cur, dt, phi, y);
}

void RegressionBuilder::Flow(const ConstVecRef& prev, const ConstVecRef& cur, double dt, MatRef phi, VecRef y,
                             const Context& at_prev, const Context& at_cur) {
  model_.Phi(prev, phi_prev_, at_prev);
  model_.Phi(cur, phi_cur_, at_cur);
  have_last_ = false;  // the x-only paths' φ at their last state no longer holds
  FlowFromPhi(prev, cur, dt, phi, y);
}

void RegressionBuilder::FlowFromPhi(const ConstVecRef& prev, const ConstVecRef& cur, double dt, MatRef phi,
                                    VecRef y) {
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

void RegressionBuilder::FlowRow(const double* prev, const double* cur, double dt, double* phi, double* y) {
  FlowRows(prev, cur, 1, dt, phi, y);
}

void RegressionBuilder::FlowRows(const double* prev, const double* xs, Eigen::Index count, double dt,
                                 double* phi, double* y) {
  // Compile-time sizes for the common layouts (the loops unroll, the rows stay in registers).
  const std::size_t u = row_unknown_.size(), k = row_known_.size();
  if (u == 2 && k == 1) return FlowRowsFor<2, 1>(prev, xs, count, dt, phi, y);
  if (u == 2 && k == 0) return FlowRowsFor<2, 0>(prev, xs, count, dt, phi, y);
  if (u == 1 && k == 0) return FlowRowsFor<1, 0>(prev, xs, count, dt, phi, y);
  if (u == 1 && k == 1) return FlowRowsFor<1, 1>(prev, xs, count, dt, phi, y);
  FlowRowsFor<0, 0>(prev, xs, count, dt, phi, y);
}

// U, K: the number of unknown and known columns when known at compile time (else 0, 0).
template <int U, int K>
void RegressionBuilder::FlowRowsFor(const double* prev, const double* xs, Eigen::Index count, double dt,
                                    double* phi, double* y) {
  const Eigen::Index n = last_cur_.size(), m = alpha_.size();
  const std::size_t u = U + K > 0 ? std::size_t(U) : row_unknown_.size();
  const std::size_t k = U + K > 0 ? std::size_t(K) : row_known_.size();
  // Row r of φ at ξ(t−δt): the previous call's row at its last state when that is `prev`.
  bool consecutive = have_last_;
  for (Eigen::Index i = 0; consecutive && i < n; ++i) consecutive = prev[i] == last_cur_[i];
  const Eigen::Index* unknown = row_unknown_.data();
  const Eigen::Index* known = row_known_.data();
  // Row r of an n × |α| column-major φ: the unknown columns, then the known ones.
  auto gather = [&](const double* phi_nm, double* out) {
    for (std::size_t c = 0; c < u; ++c) out[c] = phi_nm[unknown[c]];
    for (std::size_t c = 0; c < k; ++c) out[u + c] = phi_nm[known[c]];
  };
  const int r = flow_.rows[0];
  double row_prev[Model::kMaxAlpha], row_cur[Model::kMaxAlpha];
  if (consecutive) {
    for (std::size_t j = 0; j < u + k; ++j) row_prev[j] = row_last_[j];
  } else {
    model_.PhiRowColumns(r, prev, 1, phi_block_.data());
    gather(phi_block_.data(), row_prev);
  }
  const double h = 0.5 * dt;
  const double* known_alpha = row_known_alpha_.data();
  for (Eigen::Index start = 0; start < count; start += kBlock) {
    const Eigen::Index len = std::min(kBlock, count - start);
    model_.PhiRowColumns(r, xs + start * n, len, phi_block_.data());
    for (Eigen::Index j = 0; j < len; ++j) {
      const Eigen::Index s = start + j;
      const double* cur = xs + s * n;
      const double* before = s == 0 ? prev : cur - n;
      gather(phi_block_.data() + j * n * m, row_cur);
      double yi = cur[r] - before[r];
      for (std::size_t c = 0; c < k; ++c) yi -= h * (row_prev[u + c] + row_cur[u + c]) * known_alpha[c];
      y[s] = yi;
      for (std::size_t c = 0; c < u; ++c)
        phi[s * Eigen::Index(u) + Eigen::Index(c)] = h * (row_prev[c] + row_cur[c]);
      for (std::size_t c = 0; c < u + k; ++c) row_prev[c] = row_cur[c];
    }
  }
  if (count > 0) {
    for (std::size_t c = 0; c < u + k; ++c) row_last_[c] = row_prev[c];
    for (Eigen::Index i = 0; i < n; ++i) last_cur_[i] = xs[(count - 1) * n + i];
    have_last_ = true;
  }
}

// φ(ξ(t−δt)) into phi_prev_ and φ(ξ(t)) into phi_cur_. Consecutive pairs share a sample: φ(ξ(t−δt))
// is then the previous call's φ(ξ(t)).
void RegressionBuilder::EvaluatePhi(const double* prev, const double* cur, Eigen::Index n) {
  bool consecutive = have_last_;
  for (Eigen::Index i = 0; consecutive && i < n; ++i) consecutive = prev[i] == last_cur_[i];
  if (consecutive) {
    phi_prev_.swap(phi_cur_);
  } else {
    model_.Phi(Eigen::Map<const Vec>(prev, n), phi_prev_);
  }
  model_.Phi(Eigen::Map<const Vec>(cur, n), phi_cur_);
  for (Eigen::Index i = 0; i < n; ++i) last_cur_[i] = cur[i];
  have_last_ = true;
}

// Inlined into both Jump overloads (as one function called from two, it cost a call per jump sample).
[[gnu::always_inline]] inline void RegressionBuilder::JumpFromPsi(const ConstVecRef& cur, MatRef psi,
                                                                  VecRef y) {
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

void RegressionBuilder::Jump(const ConstVecRef& prev, const ConstVecRef& cur, MatRef psi, VecRef y) {
  model_.Psi(prev, psi_);
  JumpFromPsi(cur, psi, y);
}

void RegressionBuilder::Jump(const ConstVecRef& prev, const ConstVecRef& cur, MatRef psi, VecRef y,
                             const Context& at_prev) {
  model_.Psi(prev, psi_, at_prev);
  JumpFromPsi(cur, psi, y);
}

}  // namespace hysid
