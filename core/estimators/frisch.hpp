// Recursive Frisch-scheme estimator in the spirit of the bounding-box recursive Frisch scheme (BBRF,
// Massaroli et al., ASCC 2019); estimators.md §2.3.
//
// Frisch scheme. For rows z = [φ; y] ∈ ℝ^{m}, m = p+1, with second-moment matrix Σ and unknown
// *diagonal* noise covariance Σ̃ ≥ 0, the admissible θ (Σ − Σ̃ ≥ 0 singular, v = [θ; −1] in its null
// space) lie in the simplex whose m vertices are the elementary regressions ("all noise on column
// i"); vertex i is the i-th column of Σ⁻¹ normalised so that its last entry is −1:
//   θ_i = −(Σ⁻¹)_{0:p, i} / (Σ⁻¹)_{p, i}.          (vertex m−1 = ordinary least squares)
// The simplex bounds every Frisch solution when Σ⁻¹ is sign-equivalent to a positive matrix
// (Kalman's condition; kalman_condition() reports it for the last window as a diagnostic).
//
// Windows. settings.window = w > 0: every w rows a window's simplex and its bounding box [l, u] are
// computed (one Cholesky of the equilibrated Σ, O(m³), amortised over w rows); w = 0: after every
// Update, from the forgetting-weighted Σ of all rows so far.
// Box rule (EstimatorSettings::frisch_box):
//   "intersect"  (BBRF): Σ of each window's own rows (non-overlapping blocks); the box is the running
//                intersection γ = max(γ, l), μ = min(μ, u). If the intersection would be empty the
//                previous box is kept (counted in empty_intersections()).
//   "cumulative" (default): Σ of all rows so far (with forgetting), the box is the bounding box of
//                that one simplex, refreshed every window.
// Why "intersect" loses the truth: BBRF's published experiment added the *exact* noise covariance to
// each window instead of sampled noise. With sampled noise each window's Σ carries O(1/√w) sampling
// error, so each window box misses θ with some probability q > 0 (a vertex can move past θ, most of
// all when θ lies near a face — for an exact column it lies *on* one); the intersection keeps θ only
// if every window contains it, probability ≈ (1−q)^K → 0 over K windows, and the box shrinks onto a
// wrong point rather than becoming empty. The cumulative box is one simplex whose sampling error
// shrinks as 1/√N while its size (set by the noise levels) does not, so it keeps θ; it does not
// shrink below the population simplex. tests/test_frisch.cpp measures both coverages.
//
// Both boxes are always maintained (two O(m³) factorisations per window); frisch_box selects the one
// reported by lower()/upper(); the intersected one is also available.
// Point estimate (EstimatorSettings::frisch_point): "rls" (default) = an internal RLS estimate (same
// forgetting and p0) clamped into the BBRF-intersected box — the authors' DPRLS; clamping into the
// cumulative box would do nothing, since least squares is a vertex of that simplex. "centre" = the
// centre of the reported box. Measured on the static problem of tests/test_frisch.cpp (σ_φ = 0.4,
// 0.3, σ_y = 0.3, 2000 rows): mean ‖θ̂ − θ‖ = 0.155 (rls-clamped), 0.217 (plain RLS), 0.265
// (cumulative centre), 0.240 (intersected centre). Before the first box the estimate is the internal
// RLS estimate and status() is kNotExcited.
//
// Degenerate windows are skipped (skipped_windows()): a zero or collinear column (Cholesky pivot² of
// the equilibrated Σ < 1e-12), exact noise-free data (then Σ is singular: the Frisch set collapses to
// the exact solution, which RLS already gives), or a vertex at infinity ((Σ⁻¹)_{p,i} ≈ 0).
//
// Where the diagonal-noise assumption holds for hysid's regressions (see core/noise_shape.hpp): the
// noise of a trapezoid flow row is [(δt/2)G(e_k + e_{k−1}); e_{k,r} − e_{k−1,r}] (G = ∂φ_{r,u}/∂ξ);
// the cross term between the regressors and y cancels exactly and, with independent noise per state
// component, the regressor block (δt²/2)G R Gᵀ is diagonal when every state component enters at most
// one unknown column of the row (impact-msd: φ_1 = [−ξ1, −ξ2]; bouncing-ball; impact-pendulum to first
// order). It is NOT diagonal when one component enters two columns (e.g. ξ1 and ξ1³), when R is not
// diagonal, or when a known column of the row depends on ξ (then y and φ noise correlate). Jump rows
// [ψ(ξ_{k−1}); ξ_{k,r}] are diagonal under the same condition (e_{k−1} vs e_k are independent).
// Exact columns (a constant 1 in ψ, the −1 of the bouncing ball) have zero noise: the truth then lies
// on the simplex face with zero weight on that column's vertex. The box of the full simplex still
// contains it (conservative); the opposite face is not used (estimators.md marks that claim [I]).
#pragma once

#include <memory>

#include "core/estimator.hpp"
#include "core/estimators/rls.hpp"

namespace hysid {

enum class FrischBox { kIntersect, kCumulative };
enum class FrischPoint { kCentre, kClampedRls };

class Frisch final : public Estimator {
 public:
  // window: 0 or ≥ p+1. Throws std::invalid_argument naming the field otherwise.
  Frisch(const Vec& theta0, int window, double forgetting, double p0, FrischBox box,
         FrischPoint point);

  std::string name() const override { return "frisch"; }
  void Reset() override;

  bool has_box() const { return has_box_; }
  // The current solution box [lower, upper] (θ0 for both before the first window).
  const Vec& lower() const { return lower_; }
  const Vec& upper() const { return upper_; }
  // Coverage helper: θ inside the box widened by `tolerance` on each side.
  bool Contains(ConstVecRef theta, double tolerance = 0.0) const;
  double BoxVolume() const;
  // Simplex vertices of the last accepted window, p × (p+1), column i = elementary regression i.
  const Mat& vertices() const { return vertices_; }
  bool kalman_condition() const { return kalman_; }
  const Vec& rls_estimate() const { return rls_.estimate(); }
  // The BBRF-intersected box, kept whichever box is reported (used by the "rls" point rule).
  const Vec& intersect_lower() const { return inter_lower_; }
  const Vec& intersect_upper() const { return inter_upper_; }
  long windows() const { return windows_; }
  long skipped_windows() const { return skipped_windows_; }
  long empty_intersections() const { return empty_intersections_; }

 private:
  void DoUpdate(ConstMatRef phi, ConstVecRef y) override;
  // Bounding box of the simplex of `sigma`; false for a degenerate window.
  bool WindowBox(const Mat& sigma, VecRef lower, VecRef upper);
  void TakeWindow(const Mat& block, const Mat& all);
  void SetPoint();

  Vec theta0_;
  int window_;
  double lambda_;
  FrischBox box_rule_;
  FrischPoint point_rule_;
  Rls rls_;
  Mat block_sigma_, all_sigma_;
  Mat vertices_, work_inverse_;
  Vec lower_, upper_, window_lower_, window_upper_, scale_;
  Vec inter_lower_, inter_upper_, cum_lower_, cum_upper_;
  bool has_inter_ = false, has_cum_ = false;
  long rows_in_block_ = 0;
  long rows_ = 0;
  long windows_ = 0;
  long skipped_windows_ = 0;
  long empty_intersections_ = 0;
  bool has_box_ = false;
  bool kalman_ = false;
};

}  // namespace hysid
