#include "core/identify/metrics.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <stdexcept>

#include <fmt/format.h>

#include "core/detectors/paper.hpp"
#include "core/model/regression.hpp"

namespace hysid {

double Confusion::misclassification() const {
  const long n = total();
  return n == 0 ? 0.0 : static_cast<double>(fp + fn) / static_cast<double>(n);
}
double Confusion::precision() const {
  return tp + fp == 0 ? 1.0 : static_cast<double>(tp) / static_cast<double>(tp + fp);
}
double Confusion::recall() const {
  return tp + fn == 0 ? 1.0 : static_cast<double>(tp) / static_cast<double>(tp + fn);
}

Confusion CompareJumps(const std::vector<int>& j_true, const std::vector<std::uint8_t>& gamma) {
  if (j_true.size() != gamma.size()) {
    throw std::invalid_argument(
        fmt::format("CompareJumps: {} truth labels for {} decisions", j_true.size(), gamma.size()));
  }
  Confusion c;
  // Two passes that stay cheap whatever the flags: the flags counted in one vectorised pass, and
  // the true jumps (rare, so their branch is predicted) checked against them.
  long flagged = 0, jumps = 0, both = 0;
  for (std::size_t k = 1; k < gamma.size(); ++k) flagged += gamma[k] != 0 ? 1 : 0;
  for (std::size_t k = 1; k < gamma.size(); ++k) {
    if (j_true[k] != j_true[k - 1]) {
      ++jumps;
      both += gamma[k] != 0 ? 1 : 0;
    }
  }
  c.tp = both;
  c.fp = flagged - both;
  c.fn = jumps - both;
  c.tn = static_cast<long>(gamma.size() > 0 ? gamma.size() - 1 : 0) - flagged - jumps + both;
  return c;
}

ParameterErrors CompareParameters(const Model& truth, const Vec& alpha_hat, const Vec& beta_hat) {
  if (alpha_hat.size() != truth.alpha_size() || beta_hat.size() != truth.beta_size()) {
    throw std::invalid_argument("CompareParameters: parameter vectors do not match the model");
  }
  ParameterErrors e;
  e.e_alpha = (truth.alpha() - alpha_hat).norm();
  e.e_beta = (truth.beta() - beta_hat).norm();
  const RegressionLayout fl = RegressionLayout::Flow(truth), jl = RegressionLayout::Jump(truth);
  const Vec au = fl.Unknown(truth.alpha()), bu = jl.Unknown(truth.beta());
  const double na = au.norm(), nb = bu.norm();
  e.rel_alpha = (au - fl.Unknown(alpha_hat)).norm() / (na > 0 ? na : 1.0);
  e.rel_beta = (bu - jl.Unknown(beta_hat)).norm() / (nb > 0 ? nb : 1.0);
  return e;
}

std::vector<double> TrueSmoothnessBound(const Model& model, const Mat& x_true,
                                        const DetectorSettings& settings) {
  const BoundMode mode = ResolveBoundMode(settings.bound, model);
  std::vector<double> tau(static_cast<std::size_t>(x_true.cols()), 0.0);
  if (x_true.cols() == 0) return tau;
  // L over every true state (one evaluation when the Jacobian is constant).
  const double l = SupJacobianNorm(model, model.alpha(), mode, x_true);
  for (Eigen::Index k = 1; k < x_true.cols(); ++k) {
    tau[static_cast<std::size_t>(k)] =
        0.5 * l * (BoundNorm(x_true.col(k), mode) + BoundNorm(x_true.col(k - 1), mode));
  }
  return tau;
}

namespace {

// The unused detected event nearest to sample k within one sample, or −1.
long NearestEvent(long k, const std::vector<AutomatonEvent>& events, const std::vector<bool>& used) {
  long best = -1;
  for (std::size_t i = 0; i < events.size(); ++i) {
    const long d = std::labs(events[i].sample - k);
    if (used[i] || d > 1) continue;
    if (best < 0 || d < std::labs(events[static_cast<std::size_t>(best)].sample - k)) best = static_cast<long>(i);
  }
  return best;
}

}  // namespace

EventComparison CompareEvents(int maps, const std::vector<TrueEvent>& truth,
                              const std::vector<AutomatonEvent>& events) {
  const auto m = static_cast<std::size_t>(maps);
  EventComparison c;
  c.counts.assign(m + 1, std::vector<long>(m + 1, 0));
  auto bin = [m](int map) { return map >= 0 && static_cast<std::size_t>(map) < m ? static_cast<std::size_t>(map) : m; };
  std::vector<bool> used(events.size(), false);
  for (const TrueEvent& e : truth) {
    const long best = NearestEvent(e.sample, events, used);
    if (best < 0) {
      ++c.counts[bin(e.map)][m];
      ++c.missed;
      continue;
    }
    const AutomatonEvent& hit = events[static_cast<std::size_t>(best)];
    used[static_cast<std::size_t>(best)] = true;
    ++c.counts[bin(e.map)][bin(hit.map)];
    c.right += hit.map == e.map ? 1 : 0;
    c.max_time_error = std::max(c.max_time_error, std::abs(hit.time - e.time));
  }
  for (std::size_t i = 0; i < events.size(); ++i) {
    if (used[i]) continue;
    ++c.counts[m][bin(events[i].map)];
    ++c.spurious;
  }
  c.true_events = static_cast<long>(truth.size());
  c.detected = static_cast<long>(events.size());
  return c;
}

double LargestNearestTimeError(const std::vector<TrueEvent>& truth, const std::vector<TrueEvent>& fitted) {
  double largest = 0.0;
  for (const TrueEvent& e : truth) {
    if (fitted.empty()) return std::numeric_limits<double>::quiet_NaN();
    double same = std::numeric_limits<double>::infinity(), any = same;
    for (const TrueEvent& f : fitted) {
      const double d = std::abs(f.time - e.time);
      any = std::min(any, d);
      if (f.map == e.map) same = std::min(same, d);
    }
    largest = std::max(largest, std::isfinite(same) ? same : any);
  }
  return largest;
}

}  // namespace hysid
