#include "core/detectors/residual.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include "core/model/regression.hpp"
#include "core/stats/quantiles.hpp"

namespace hysid {
namespace {

// StudentUpperQuantile(tail, ν), remembered per thread: the runs of a sweep ask for the same few
// dozen (tail, ν) pairs, and each costs a Newton solve with incomplete beta functions. A pure
// function of its arguments, so the cache changes no result.
double CachedStudentUpperQuantile(double tail, long nu) {
  struct Entry {
    double tail;
    long nu;
    double q;
  };
  thread_local std::vector<Entry> cache;
  for (const Entry& e : cache) {
    if (e.tail == tail && e.nu == nu) return e.q;
  }
  constexpr std::size_t kMaxEntries = 1024;
  if (cache.size() >= kMaxEntries) cache.clear();
  const double q = StudentUpperQuantile(tail, static_cast<double>(nu));
  cache.push_back(Entry{tail, nu, q});
  return q;
}

}  // namespace

namespace {

// E[min(Z², c²)] for Z ~ N(0, 1): P(|Z| < c) − 2cφ(c) + c²·P(|Z| > c).
double ClippedSecondMoment(double c) {
  const double inside = std::erf(c / std::sqrt(2.0));
  const double density = std::exp(-0.5 * c * c) / std::sqrt(2.0 * std::numbers::pi);
  return inside - 2.0 * c * density + c * c * (1.0 - inside);
}

}  // namespace

ResidualDetector::ResidualDetector(const DetectorSettings& settings, const Model& model)
    : model_(model), settings_(settings), kappa_(ClippedSecondMoment(kClip)) {
  const RegressionLayout layout = RegressionLayout::Flow(model);
  rows_ = layout.rows;
  unknown_ = layout.unknown;
  unknowns_ = static_cast<int>(unknown_.size());
  jacobian_constant_ = model.spec().flow_jacobian_constant;
  for (long g = 1; g <= 10; ++g) grid_.push_back(g);
  for (long g = 13; g < kMemory; g = static_cast<long>(std::ceil(1.25 * static_cast<double>(g)))) {
    grid_.push_back(g);
  }
  grid_.push_back(kMemory);
  grid_q_.assign(grid_.size(), -1.0);
  const int n = model.state_size();
  jac_prev_.resize(n, n);
  jac_cur_.resize(n, n);
  jac_at_.resize(n);
  const std::size_t nr = rows_.size();
  rho2_.assign(nr, 0.0);
  lev_.assign(nr, 0.0);
  noise_.assign(nr, 0.0);
  round2_.assign(nr, 0.0);
  Reset();
}

void ResidualDetector::Reset() {
  excess_.assign(rows_.size(), 0.0);
  scale_samples_ = 0;
  cached_nu_ = -1;
  active_ = false;
  have_jac_ = false;
}

std::unique_ptr<JumpDetector> ResidualDetector::CloneWith(const DetectorSettings& settings) const {
  auto copy = std::make_unique<ResidualDetector>(*this);
  copy->settings_ = settings;
  copy->grid_q_.assign(grid_.size(), -1.0);  // the quantiles of its own false_alarm
  copy->cached_nu_ = -1;
  return copy;
}

// The decision was taken at ν = min(scale samples before its update, kMemory), with a scale (it
// flagged).
bool ResidualDetector::FlagsWith(ResidualDetector& twin) const {
  twin.QuantileAt(std::min(scale_samples_ - 1, kMemory));
  return twin.Exceeds(last_z2_);
}

bool ResidualDetector::ThresholdsBelow(ResidualDetector& twin) {
  for (const long nu : grid_) {
    const double q = QuantileAt(nu);
    if (!(q <= twin.QuantileAt(nu))) return false;
  }
  return true;
}

double ResidualDetector::QuantileAt(long nu) {
  // Largest grid point ≤ ν.
  const auto it = std::upper_bound(grid_.begin(), grid_.end(), nu);
  const auto idx = static_cast<std::size_t>(std::distance(grid_.begin(), it) - 1);
  if (grid_q_[idx] < 0.0) {
    const double tail = settings_.false_alarm / (2.0 * static_cast<double>(rows_.size()));
    grid_q_[idx] = CachedStudentUpperQuantile(tail, grid_[idx]);
  }
  cached_nu_ = nu;
  cached_q_ = grid_q_[idx];
  cached_q2_ = cached_q_ * cached_q_;
  return cached_q_;
}

void ResidualDetector::NoiseVariance(const SampleContext& c) {
  NoiseVariance(c.prev.data(), c.cur.data(), c.cur.size(), c.dt, c.alpha_hat, c.version, c.sigma, c.data_rtol,
                c.data_atol, &c.at_prev, &c.at_cur);
}

// V_i = Σ_j (σ_j² + d_j(t)²) a_ij² + (σ_j² + d_j(t−δt)²) b_ij², a = e_i − (δt/2)J_i(ξ(t)),
// b = e_i + (δt/2)J_i(ξ(t−δt)) (PropagateInputs).
// Null contexts: the Jacobian's x-only form (the same values: Model resolves an empty context
// either way), which spares building and copying a Context per call.
void ResidualDetector::NoiseVariance(const double* prev_data, const double* cur_data, Eigen::Index n,
                                     double dt, const ConstVecRef& alpha_hat, long version, const Vec* sigma,
                                     double data_rtol, double data_atol, const Context* at_prev,
                                     const Context* at_cur) {
  const ConstVecMap prev(prev_data, n), cur(cur_data, n);
  bool same_jacobian = false;  // jac_cur_ at both samples
  if (jacobian_constant_) {
    // Depends on α̂ only: evaluated when α̂ changes (SampleContext::version); the same at both
    // samples.
    if (!have_jac_ || version != jac_version_) ConstantJacobian(cur_data, n, alpha_hat, version, at_cur);
    same_jacobian = true;
  } else {
    // φ(ξ(t−δt)) was ξ(t) of the previous call: reuse its Jacobian (α̂ moved by one update since,
    // a negligible change in an O(δt) correction of the variance).
    // With inputs the previous Jacobian was at another u only if the samples are not consecutive,
    // which the state comparison detects as well.
    if (have_jac_ && jac_at_ == prev) {
      jac_prev_.swap(jac_cur_);
    } else {
      Jacobian(prev, alpha_hat, jac_prev_, at_prev);
    }
    Jacobian(cur, alpha_hat, jac_cur_, at_cur);
    jac_at_ = cur;
    have_jac_ = true;
  }
  if (n == 2) {
    same_jacobian ? PropagateInputs<2, true>(prev_data, cur_data, n, dt, sigma, data_rtol, data_atol)
                  : PropagateInputs<2, false>(prev_data, cur_data, n, dt, sigma, data_rtol, data_atol);
  } else {
    same_jacobian ? PropagateInputs<0, true>(prev_data, cur_data, n, dt, sigma, data_rtol, data_atol)
                  : PropagateInputs<0, false>(prev_data, cur_data, n, dt, sigma, data_rtol, data_atol);
  }
}

void ResidualDetector::ConstantJacobian(const double* cur, Eigen::Index n, const ConstVecRef& alpha_hat,
                                        long version, const Context* at_cur) {
  Jacobian(ConstVecMap(cur, n), alpha_hat, jac_cur_, at_cur);
  jac_version_ = version;
  have_jac_ = true;
}

Decision ResidualDetector::Classify(const SampleContext& c) {
  if (!Activate(c.flow_updates)) return {};
  const bool known_noise = ResidualNoise::Make(c.sigma, c.cur.size(), c.data_rtol, c.data_atol).known;
  if (known_noise) NoiseVariance(c);
  const Mat* p = c.alpha_covariance;
  double z2max = 0.0;
  for (std::size_t i = 0; i < rows_.size(); ++i) {
    const auto ii = static_cast<Eigen::Index>(i);
    const RowFit fit = FitRow<0>(
        c.flow_phi.cols(), [&](Eigen::Index j) { return c.flow_phi(ii, j); },
        [&](Eigen::Index j) { return c.alpha_hat[unknown_[static_cast<std::size_t>(j)]]; },
        [&](Eigen::Index a, Eigen::Index b) { return (*p)(a, b); }, p != nullptr);
    RowTerms terms;
    const double z2 = RowStatistic(i, c.flow_y[ii] - fit.pred, fit.lev, fit.magnitude, c.prev.data(),
                                   c.cur.data(), c.flow_y[ii], known_noise, &terms);
    rho2_[i] = terms.rho2;  // for Observe (noise_[i] is set)
    lev_[i] = terms.lev;
    round2_[i] = terms.round2;
    z2max = std::max(z2max, z2);
  }
  return Decide(z2max);
}

// Robust scale update (every classified sample, jumps included, clipped at kClip² × prediction).
void ResidualDetector::Observe(const SampleContext& /*context*/, const Decision& /*decision*/) {
  if (!active_) return;
  UpdateScale();
}

DetectorDescriptor ResidualDetectorDescriptor() {
  return {.name = "residual",
          .help = "tuning-free: one-step prediction residual of the flow model, tested at false_alarm",
          .options = {"false_alarm"},
          .traits = {.statistic = "z", .threshold = "q"},
          .make = [](const DetectorSettings& s, const Model& m) -> std::unique_ptr<JumpDetector> {
            return std::make_unique<ResidualDetector>(s, m);
          }};
}

}  // namespace hysid
