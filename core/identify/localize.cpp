#include "core/identify/localize.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace hysid {

JumpLocalizer::JumpLocalizer(const Model& model) : model_(model) {
  const int n = model.state_size();
  const auto& rows = model.spec().jump_rows;
  for (int i = 0; i < n; ++i) {
    if (std::find(rows.begin(), rows.end(), i) == rows.end()) known_rows_.push_back(i);
  }
  beta_known_ = model.beta();
  for (int i = 0; i < model.beta_size(); ++i) {
    if (!model.spec().beta[static_cast<std::size_t>(i)].known) beta_known_[i] = 0.0;
  }
  for (Vec* v : {&k1_, &k2_, &k3_, &k4_, &tmp_, &pre_, &post_, &jump_, &prev_, &cur_}) v->resize(n);
}

void JumpLocalizer::Flow(ConstVecRef x0, double span, ConstVecRef alpha, VecRef out) {
  const double h = span / kSubsteps;
  out = x0;
  for (int s = 0; s < kSubsteps; ++s) {
    model_.Flow(out, alpha, k1_);
    tmp_ = out + 0.5 * h * k1_;
    model_.Flow(tmp_, alpha, k2_);
    tmp_ = out + 0.5 * h * k2_;
    model_.Flow(tmp_, alpha, k3_);
    tmp_ = out + h * k3_;
    model_.Flow(tmp_, alpha, k4_);
    out += (h / 6.0) * (k1_ + 2.0 * k2_ + 2.0 * k3_ + k4_);
  }
}

void JumpLocalizer::Residual(double theta, VecRef residual) {
  Flow(prev_, theta * dt_, alpha_, pre_);
  Flow(cur_, (theta - 1.0) * dt_, alpha_, post_);
  model_.Jump(pre_, beta_known_, jump_);
  for (std::size_t i = 0; i < known_rows_.size(); ++i) {
    residual[Eigen::Index(i)] = post_[known_rows_[i]] - jump_[known_rows_[i]];
  }
}

bool JumpLocalizer::Locate(ConstVecRef prev, ConstVecRef cur, double dt, ConstVecRef alpha,
                           JumpLocation* out) {
  if (known_rows_.empty()) return false;
  prev_ = prev;
  cur_ = cur;
  alpha_ = alpha;
  dt_ = dt;
  const auto nk = static_cast<Eigen::Index>(known_rows_.size());
  Vec r0(nk), r1(nk), r(nk);
  Residual(0.0, r0);
  Residual(1.0, r1);
  if (!r0.allFinite() || !r1.allFinite()) return false;
  // The known row whose residual changes most across the interval, with a sign change.
  Eigen::Index row = -1;
  double best = 0.0;
  for (Eigen::Index i = 0; i < nk; ++i) {
    if (r0[i] * r1[i] <= 0.0 && std::abs(r1[i] - r0[i]) > best) {
      best = std::abs(r1[i] - r0[i]);
      row = i;
    }
  }
  if (row < 0) return false;
  double a = 0.0, b = 1.0, fa = r0[row], fb = r1[row];
  double theta = fa == 0.0 ? 0.0 : 1.0;
  int side = 0, it = 0;
  if (fa != 0.0 && fb != 0.0) {
    for (; it < 200 && b - a > 1e-14; ++it) {
      theta = (a * fb - b * fa) / (fb - fa);
      if (!(theta > a && theta < b)) theta = 0.5 * (a + b);
      Residual(theta, r);
      const double f = r[row];
      if (!std::isfinite(f)) return false;
      if (f == 0.0) {
        a = b = theta;
        break;
      }
      if ((f < 0.0) == (fb < 0.0)) {
        b = theta, fb = f;
        if (side == -1) fa *= 0.5;  // Illinois: halve the stale end
        side = -1;
      } else {
        a = theta, fa = f;
        if (side == 1) fb *= 0.5;
        side = 1;
      }
      // Regula falsi converges from one side; also stop on a tiny step.
      if (std::abs(f) <= 4.0 * std::numeric_limits<double>::epsilon() *
                             (std::abs(post_[known_rows_[std::size_t(row)]]) +
                              std::abs(jump_[known_rows_[std::size_t(row)]]))) {
        a = b = theta;
        break;
      }
    }
  }
  Residual(theta, r);
  if (!pre_.allFinite() || !post_.allFinite()) return false;
  out->fraction = theta;
  out->pre = pre_;
  out->post = post_;
  out->iterations = it;
  return true;
}

}  // namespace hysid
