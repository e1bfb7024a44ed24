// A tuning-free jump detector: the one-step prediction residual of the current flow model, tested
// against its predicted distribution under flow. Its one input is the false-alarm probability
// p = DetectorSettings::false_alarm (default 1e-8 per sample).
//
// Residual. On each identified row i (the model's flow_rows) of the trapezoid regression
// (core/model/regression.hpp), ρ_i = y_i − Φ_i α̂_u = Δξ_i − (δt/2)(f̂_i(ξ(t)) + f̂_i(ξ(t−δt))).
//
// Its predicted variance under flow, v_i = (1 + h_i)(V_i + s²_i) + ε²_i:
//   V_i  measurement noise propagated through the integrated model, when σ is known
//        (IdentifierSettings::sigma): to first order in the noise e,
//          ρ_i ≈ (e_i(t) − (δt/2) J_i(ξ(t)) e(t)) − (e_i(t−δt) + (δt/2) J_i(ξ(t−δt)) e(t−δt)) + ...,
//        J_i the i-th row of ∂(φ(ξ)α̂)/∂ξ, so V_i = Σ_j σ_j² (a_ij² + b_ij²) with
//        a = e_i − (δt/2)J_i(ξ(t)), b = e_i + (δt/2)J_i(ξ(t−δt)). V_i = 0 when σ is not given.
//        The data's own accuracy, d_j = data_rtol·|ξ_j| + data_atol (IdentifierSettings; for
//        simulated data the integrator's tolerances), is added to σ_j² at each of the two samples.
//        It matters for noise-free data only: an estimator that fits the flow to the last digits
//        (gtls) leaves residuals at the level of the simulator's step-to-step error, which jumps
//        after every re-initialisation at a jump; the robust scale, learned where that error was
//        smaller, then flags it (§5 noise-free, gtls: 567 false jumps without d, 0 with it).
//   s²_i what V_i does not explain, estimated online and robustly from the residuals themselves:
//        the unknown measurement noise, the O(δt³) trapezoid truncation, the simulator's or the
//        data's own error, the bias of α̂. An exponentially weighted mean of the standardised squared
//        residuals ρ²/(1 + h), each clipped at kClip² = 9 times the current predicted variance (a
//        Huber-type scale: one sample moves it by a bounded amount), corrected so that Gaussian
//        residuals give an unbiased estimate. Weight 1/n for the first kMemory = 1000 samples, then
//        1/kMemory: a statistical memory in samples, the same for every system and δt.
//        Every sample updates it, jumps included (clipped): if α̂ is wrong and every residual is
//        large, the scale grows until the model can learn again instead of locking up.
//   h_i  parameter uncertainty: Φ_i P Φ_iᵀ with P the estimator's covariance (RLS: Cov(α̂) ≈
//        (V + s²)·P), so (1 + h_i)(V_i + s²_i) is the variance of a one-step prediction error.
//   ε²_i a floor for noise-free data: the rounding error of computing ρ_i,
//        (4u·(|ξ_i(t)| + |ξ_i(t−δt)| + Σ_j |Φ_ij α̂_j| + |y_i|))², u = 2^-53. Nothing tuned.
//
// Test. z_i = ρ_i / √v_i; γ = 1 when max_i |z_i| > q, q the two-sided Student-t quantile at
// p / (2·rows) (Bonferroni over the identified rows) with ν = the number of samples in the scale
// estimate (capped at kMemory: conservative, the effective size of the exponential window is
// ≈ 2·kMemory). ν is read on a grid (1..10, then ×1.25), rounded down, so q is only recomputed a
// few dozen times per run. statistic = max |z_i|, threshold = q (both dimensionless).
//
// Start. Before α̂ is determined (the α estimator has seen fewer flow samples than α has unknowns)
// every sample is flow and the scale is not updated. Then the test runs at once, but with the few
// samples of the scale estimate the Student-t quantile is huge (ν = 1: q ≈ 6.4e5 at p = 1e-6; ν = 10:
// ≈ 10; ν = 100: ≈ 5.4), and h is large while α̂ is poorly determined, so the detector is
// conservative exactly while α̂ and the scale are not trustworthy. The first kUnclipped = 10
// residuals enter the scale unclipped (a plain mean): the clipping bounds what one misclassified
// jump does to an established scale, but on a scale started from the first residuals (those of the
// least determined α̂, divided by a large 1 + h) it kept the scale from growing to the residuals' level,
// the following samples were flagged, α̂ was not updated on them and stayed poor, and they kept
// being flagged (robustness map, σ = 0.02, δt = 1 ms, p = 1e-8: one run with 15 false jumps in
// samples 6–25; tests/core/detectors/residual_test.cpp "warm-up"). A jump inside the first
// |α_u| + 1 samples is classified as flow; IdentifierSettings::second_pass catches it afterwards.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "core/detectors/detector.hpp"

namespace hysid {

// Reads false_alarm; reports max |z| and the quantile q.
DetectorDescriptor ResidualDetectorDescriptor();

// The measurement-noise inputs of the direct path (SampleContext's sigma, data_rtol, data_atol), with
// `known`: whether they give a noise variance to propagate (Make; fixed for a run, so a caller
// decides it once per block of samples).
struct ResidualNoise {
  const Vec* sigma = nullptr;
  double data_rtol = 0.0, data_atol = 0.0;
  bool known = false;

  // sigma may be null; n = the state size.
  static ResidualNoise Make(const Vec* sigma, Eigen::Index n, double data_rtol, double data_atol) {
    return {sigma, data_rtol, data_atol,
            (sigma != nullptr && sigma->size() == n && sigma->any()) || data_rtol > 0.0 || data_atol > 0.0};
  }
};

// α̂'s two unknowns (a0, a1) and their 2 × 2 covariance (c_ab: entry (a, b); none when
// has_covariance is false), as values (ResidualDetector::ClassifyObserveRow2).
struct Row2Estimate {
  double a0 = 0.0, a1 = 0.0;
  double c00 = 0.0, c10 = 0.0, c01 = 0.0, c11 = 0.0;
  bool has_covariance = false;
};

class ResidualDetector final : public JumpDetector {
 public:
  static constexpr double kClip = 3.0;
  static constexpr long kMemory = 1000;
  static constexpr long kUnclipped = 10;

  ResidualDetector(const DetectorSettings& settings, const Model& model);
  Decision Classify(const SampleContext& context) override;
  void Observe(const SampleContext& context, const Decision& decision) override;
  std::string name() const override { return "residual"; }
  void Reset() override;
  std::unique_ptr<JumpDetector> CloneWith(const DetectorSettings& settings) const override;
  // Whether `twin` (another false_alarm, this detector's learned state) flags the sample this one
  // classified and observed last, and flagged: the same bits as twin's own decision there.
  bool FlagsWith(ResidualDetector& twin) const;
  // Whether twin's quantile is at least this one's at every ν: then wherever this detector decides
  // flow, so does twin with the same learned state.
  bool ThresholdsBelow(ResidualDetector& twin);

  // The current robust scale s²_i of row i and the samples it rests on (for tests and traces).
  double excess_variance(int row) const { return excess_[static_cast<std::size_t>(row)]; }
  long scale_samples() const { return scale_samples_; }

  // Classify and then Observe on one sample of a model with one identified row, from raw arrays:
  // the identifier's direct (non-virtual, inlined) path, the same arithmetic in the same order.
  // phi: the row's M unknowns' entries; y: its value; cov: the α estimator's M × M covariance
  // (column-major) or null; alpha_hat: α̂ (all entries); the other arguments as in SampleContext
  // (noise: ResidualNoise::Make of its sigma, data_rtol, data_atol). N = n and M = the number of
  // unknowns when known at compile time (the loops unroll), else 0.
  template <int N, int M>
  [[gnu::always_inline]] Decision ClassifyObserveRow(const double* prev, const double* cur,
                                                     Eigen::Index n_dynamic, double dt, const double* phi,
                                                     double y, const ConstVecRef& alpha_hat,
                                                     const double* cov, long version, long flow_updates,
                                                     const ResidualNoise& noise) {
    const Eigen::Index m = M > 0 ? M : static_cast<Eigen::Index>(unknown_.size());
    return ClassifyObserveRowWith<N, M>(
        prev, cur, n_dynamic, dt, phi, y, alpha_hat,
        [&](Eigen::Index j) { return alpha_hat[unknown_[static_cast<std::size_t>(j)]]; },
        [&](Eigen::Index a, Eigen::Index b) { return cov[b * m + a]; }, cov != nullptr, version, flow_updates,
        noise);
  }

  // The same for two unknowns, with α̂'s two unknowns and their covariance given as values (`row`):
  // a caller that keeps them in local variables (the identifier's RLS state) passes them without
  // storing them first. alpha_hat (the full α̂) is read only for the flow Jacobian.
  template <int N>
  [[gnu::always_inline]] Decision ClassifyObserveRow2(const double* prev, const double* cur,
                                                      Eigen::Index n_dynamic, double dt, const double* phi,
                                                      double y, const ConstVecRef& alpha_hat,
                                                      const Row2Estimate& row, long version,
                                                      long flow_updates, const ResidualNoise& noise) {
    return ClassifyObserveRowWith<N, 2>(
        prev, cur, n_dynamic, dt, phi, y, alpha_hat, [&](Eigen::Index j) { return j == 0 ? row.a0 : row.a1; },
        [&](Eigen::Index a, Eigen::Index b) {
          return a == 0 ? (b == 0 ? row.c00 : row.c01) : (b == 0 ? row.c10 : row.c11);
        },
        row.has_covariance, version, flow_updates, noise);
  }

 private:
  // ClassifyObserveRow's body; alpha_u(j): α̂'s j-th unknown, cov(a, b): its covariance's entry (a, b)
  // (read only when has_cov).
  template <int N, int M, class AlphaU, class Cov>
  [[gnu::always_inline]] Decision ClassifyObserveRowWith(const double* prev, const double* cur,
                                                         Eigen::Index n_dynamic, double dt, const double* phi,
                                                         double y, const ConstVecRef& alpha_hat,
                                                         const AlphaU& alpha_u, const Cov& cov, bool has_cov,
                                                         long version, long flow_updates,
                                                         const ResidualNoise& noise) {
    const Eigen::Index n = N > 0 ? N : n_dynamic;
    if (!Activate(flow_updates)) return {};
    if (noise.known) NoiseVarianceDirect<N>(prev, cur, n, dt, alpha_hat, version, noise);
    const RowFit fit = FitRow<M>(
        static_cast<Eigen::Index>(unknown_.size()), [&](Eigen::Index j) { return phi[j]; }, alpha_u, cov,
        has_cov);
    RowTerms terms;
    const double z2max = std::max(
        0.0, RowStatistic(0, y - fit.pred, fit.lev, fit.magnitude, prev, cur, y, noise.known, &terms));
    const Decision d = Decide(z2max);
    UpdateRowScale(0, terms, ScaleWeight());  // UpdateScale for the one row, its terms not stored
    ++scale_samples_;
    return d;
  }
  // Whether the test runs: the α estimator has seen as many flow samples as α has unknowns. Before,
  // every sample is flow and the scale is not updated.
  [[gnu::always_inline]] bool Activate(long flow_updates) {
    active_ = flow_updates >= unknowns_;
    return active_;
  }
  // A row's one-step prediction Φ_i α̂_u, its magnitude Σ_j |Φ_ij α̂_j| and its leverage h_i = Φ_i P Φ_iᵀ
  // (0 without a covariance): phi(j) = Φ_ij, alpha_u(j): α̂'s j-th unknown, cov(a, b): P's entry
  // (a, b) (read only when has_cov); M = the number of unknowns when known at compile time, else 0.
  struct RowFit {
    double pred, magnitude, lev;
  };
  template <int M, class Phi, class AlphaU, class Cov>
  [[gnu::always_inline]] static RowFit FitRow(Eigen::Index m_dynamic, const Phi& phi, const AlphaU& alpha_u,
                                              const Cov& cov, bool has_cov) {
    const Eigen::Index m = M > 0 ? M : m_dynamic;
    RowFit fit{0.0, 0.0, 0.0};
    for (Eigen::Index j = 0; j < m; ++j) {
      const double term = phi(j) * alpha_u(j);
      fit.pred += term;
      fit.magnitude += std::abs(term);
    }
    if (has_cov) {
      for (Eigen::Index a = 0; a < m; ++a) {
        double s = 0.0;
        for (Eigen::Index b = 0; b < m; ++b) s += cov(a, b) * phi(b);
        fit.lev += phi(a) * s;
      }
      fit.lev = std::max(0.0, fit.lev);
    }
    return fit;
  }
  // The test on the largest z²_i of the sample, the one rule of every path: statistic max |z|,
  // threshold q, γ = 1 when z² > q² (on squares: the square root of the statistic stays off the
  // decision). No scale yet: this sample starts it (flow, q = ∞).
  [[gnu::always_inline]] Decision Decide(double z2max) {
    Decision d;
    d.statistic = std::sqrt(z2max);
    if (scale_samples_ == 0) {
      d.threshold = std::numeric_limits<double>::infinity();
      return d;
    }
    d.threshold = Quantile();
    d.gamma = Exceeds(z2max);
    if (d.gamma) last_z2_ = z2max;
    return d;
  }
  // z² beyond the quantile of the last Quantile or QuantileAt.
  [[gnu::always_inline]] bool Exceeds(double z2) const { return z2 > cached_q2_; }
  // q for ν = min(scale samples, kMemory): cached while ν stays on one value (from kMemory on).
  double Quantile() {
    const long nu = std::min(scale_samples_, kMemory);
    return nu == cached_nu_ ? cached_q_ : QuantileAt(nu);
  }
  double QuantileAt(long nu);
  void NoiseVariance(const SampleContext& c);
  void NoiseVariance(const double* prev, const double* cur, Eigen::Index n, double dt,
                     const ConstVecRef& alpha_hat, long version, const Vec* sigma, double data_rtol,
                     double data_atol, const Context* at_prev = nullptr, const Context* at_cur = nullptr);
  // NoiseVariance without contexts (the direct path): with a constant flow Jacobian and n = 2, the
  // Jacobian is evaluated (out of line) only when α̂ changed and V_i is summed here.
  template <int N>
  [[gnu::always_inline]] void NoiseVarianceDirect(const double* prev, const double* cur, Eigen::Index n,
                                                  double dt, const ConstVecRef& alpha_hat, long version,
                                                  const ResidualNoise& noise) {
    if constexpr (N == 2) {
      if (jacobian_constant_) {
        if (!have_jac_ || version != jac_version_) ConstantJacobian(cur, n, alpha_hat, version, nullptr);
        PropagateInputs<2, true, true>(prev, cur, n, dt, noise.sigma, noise.data_rtol, noise.data_atol);
        return;
      }
    }
    NoiseVariance(prev, cur, n, dt, alpha_hat, version, noise.sigma, noise.data_rtol, noise.data_atol);
  }
  // jac_cur_ = the constant flow Jacobian at α̂ (version `version`).
  void ConstantJacobian(const double* cur, Eigen::Index n, const ConstVecRef& alpha_hat, long version,
                        const Context* at_cur);
  // V_i from the Jacobians and var(j, ξ_j) = σ_j² + d_j², d_j = data_rtol·|ξ_j| + data_atol (σ_j = 0
  // when σ is not given). With σ only, d_j = 0·|ξ_j| + 0 = 0 for a finite sample (the only ones the
  // detector sees), so σ_j² + d_j² = σ_j² exactly: neither |ξ_j| nor d_j² is computed. Without σ,
  // 0² + d_j² = d_j² (a square is never −0), so σ_j² is not added. kOneRow: the first row only (the
  // direct path's one identified row).
  template <int N, bool kSame, bool kOneRow = false>
  [[gnu::always_inline]] void PropagateInputs(const double* prev, const double* cur, Eigen::Index n,
                                              double dt, const Vec* sigma, double data_rtol,
                                              double data_atol) {
    const bool have_sigma = sigma != nullptr && sigma->size() == n;
    if (have_sigma && data_rtol == 0.0 && data_atol == 0.0) {
      PropagateNoise<N, kSame, kOneRow>(prev, cur, n, dt, [&](Eigen::Index j, double /*x*/) {
        const double s = (*sigma)[j];
        return s * s;
      });
    } else if (!have_sigma) {
      PropagateNoise<N, kSame, kOneRow>(prev, cur, n, dt, [&](Eigen::Index /*j*/, double x) {
        const double d = data_rtol * std::abs(x) + data_atol;
        return d * d;
      });
    } else {
      PropagateNoise<N, kSame, kOneRow>(prev, cur, n, dt, [&](Eigen::Index j, double x) {
        const double s = (*sigma)[j];
        const double d = data_rtol * std::abs(x) + data_atol;
        return s * s + d * d;
      });
    }
  }
  // V_i from the Jacobians; N = n when known at compile time (the loop unrolls), else 0; kSame:
  // jac_cur_ at both samples (a constant Jacobian: (δt/2)·J_ij computed once for a and b); kOneRow:
  // the first row only.
  template <int N, bool kSame, bool kOneRow, class Var>
  [[gnu::always_inline]] void PropagateNoise(const double* prev, const double* cur, Eigen::Index n_dynamic,
                                             double dt, const Var& var) {
    const Eigen::Index n = N > 0 ? N : n_dynamic;
    const Mat& jac_prev = kSame ? jac_cur_ : jac_prev_;
    const double h = 0.5 * dt;
    const std::size_t rows = kOneRow ? 1 : rows_.size();
    for (std::size_t i = 0; i < rows; ++i) {
      const int r = rows_[i];
      double v = 0.0;
      for (Eigen::Index j = 0; j < n; ++j) {
        const double unit = j == r ? 1.0 : 0.0;
        const double a = unit - h * jac_cur_(r, j);
        const double b = unit + h * jac_prev(r, j);
        v += var(j, cur[j]) * a * a + var(j, prev[j]) * b * b;
      }
      noise_[i] = v;
    }
  }
  void Jacobian(const ConstVecRef& x, const ConstVecRef& alpha_hat, Mat& jac, const Context* at) const {
    if (at == nullptr) {
      model_.FlowJacobian(x, alpha_hat, jac);
    } else {
      model_.FlowJacobian(x, alpha_hat, jac, *at);
    }
  }
  // What the scale update needs of row i's sample: ρ², the leverage h, V_i (0 when σ is not known)
  // and ε²_i.
  struct RowTerms {
    double rho2, lev, noise, round2;
  };
  // z²_i of row i from its residual ρ, leverage h and |Φ_i|·|α̂| (`magnitude`); *terms: what the
  // scale update needs.
  [[gnu::always_inline]] double RowStatistic(std::size_t i, double rho, double lev, double magnitude,
                                             const double* prev, const double* cur, double y,
                                             bool known_noise, RowTerms* terms) {
    constexpr double kRound = 4.0 * std::numeric_limits<double>::epsilon() / 2.0;
    const int r = rows_[i];
    const double round = kRound * (std::abs(cur[r]) + std::abs(prev[r]) + magnitude + std::abs(y));
    const double noise = known_noise ? noise_[i] : 0.0;
    noise_[i] = noise;
    const double v = (1.0 + lev) * (noise + excess_[i]) + round * round;
    *terms = RowTerms{.rho2 = rho * rho, .lev = lev, .noise = noise, .round2 = round * round};
    // v = 0 only with an exactly zero residual scale and ρ = 0 (then z = 0).
    return v > 0.0 ? rho * rho / v : (rho == 0.0 ? 0.0 : std::numeric_limits<double>::infinity());
  }
  // The robust scale update of Observe (active_ set), from the terms Classify stored.
  [[gnu::always_inline]] void UpdateScale() {
    const double w = ScaleWeight();
    for (std::size_t i = 0; i < rows_.size(); ++i) {
      UpdateRowScale(i, RowTerms{.rho2 = rho2_[i], .lev = lev_[i], .noise = noise_[i], .round2 = round2_[i]},
                     w);
    }
    ++scale_samples_;
  }
  // The weight of this sample in the scale: 1/n for the first kMemory samples, then 1/kMemory.
  [[gnu::always_inline]] double ScaleWeight() const {
    const long n = std::min(scale_samples_ + 1, kMemory);
    // 1/kMemory folded by the compiler (the same correctly rounded quotient) once n stays there.
    constexpr double kMemoryWeight = 1.0 / static_cast<double>(kMemory);
    return n == kMemory ? kMemoryWeight : 1.0 / static_cast<double>(n);
  }
  // s²_i's update with weight w (scale_samples_ not yet counting this sample).
  [[gnu::always_inline]] void UpdateRowScale(std::size_t i, const RowTerms& t, double w) {
    double r = t.rho2 / (1.0 + t.lev);
    // Clipping can only act when r exceeds kClip² (σ² + s²), a lower bound of kClip² · reference
    // (rounded sums and products of non-negative terms are monotonic): below it the reference and
    // its division are skipped, with the same result.
    const double base = t.noise + excess_[i];
    if (scale_samples_ >= kUnclipped && !(r <= kClip * kClip * base)) {
      // Reference: the predicted variance of ρ/√(1+h) (its rounding floor keeps a zero scale from
      // clipping everything to zero).
      const double reference = base + t.round2 / (1.0 + t.lev) + std::numeric_limits<double>::min();
      r = std::min(r, kClip * kClip * reference);
    }
    const double x = (r - kappa_ * t.noise) / kappa_;
    excess_[i] = std::max(0.0, excess_[i] + w * (x - excess_[i]));
  }

  Model model_;
  DetectorSettings settings_;  // reads false_alarm
  std::vector<int> rows_;            // identified state rows
  std::vector<int> unknown_;         // unknown α columns (columns of flow_phi)
  int unknowns_ = 0;
  bool jacobian_constant_ = false;  // the model's spec().flow_jacobian_constant
  double kappa_;  // E[min(Z², kClip²)], Z ~ N(0, 1)
  // Quantile cache on the ν grid.
  std::vector<long> grid_;
  std::vector<double> grid_q_;
  long cached_nu_ = -1;
  double cached_q_ = 0.0;
  double cached_q2_ = 0.0;  // cached_q_²
  // Scale state.
  std::vector<double> excess_;  // s²_i
  long scale_samples_ = 0;
  // Per-sample scratch, filled by Classify and reused by Observe.
  std::vector<double> rho2_, lev_, noise_, round2_;
  bool active_ = false;
  double last_z2_ = 0.0;  // max z² of the last sample flagged (FlagsWith)
  Mat jac_prev_, jac_cur_;
  Vec jac_at_;
  bool have_jac_ = false;
  long jac_version_ = -1;  // α̂ version of jac_cur_ (constant Jacobians)
};

}  // namespace hysid
