// Recursive Frisch-scheme estimator in the spirit of the bounding-box recursive Frisch scheme (BBRF,
// Massaroli et al., ASCC 2019); docs/estimators.md, "frisch".
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
// Update, from the forgetting-weighted Σ of all rows so far (then there are no disjoint windows
// to intersect, and both box rules give that one box).
// Box rule (EstimatorSettings::frisch_box):
//   "intersect"  (BBRF): Σ of each window's own rows (non-overlapping blocks); the box is the running
//                intersection γ = max(γ, l), μ = min(μ, u). If the intersection would be empty the
//                previous box is kept (counted in empty_intersections()).
//   "cumulative" (default): Σ of all rows so far (with forgetting), the box is the bounding box of
//                that one simplex, refreshed every window.
// Sampling allowance (EstimatorSettings::frisch_confidence = c, default 0.95; 0 = none). The Frisch
// simplex is a population statement: it contains θ for the *expected* Σ. A window's Σ carries
// sampling error, which moves the vertices; where θ lies near a vertex or a face (RLS is a vertex,
// and with little attenuation θ is close to it; an exact column puts θ on a face) the plain box
// misses θ about half the time. Each box is therefore widened on both sides, per coordinate j, by
// t·se_j, se_j the least-squares standard error of the window (s² = RSS/(count − p) with RSS =
// 1/(Σ⁻¹)_pp, se_j² = s²·(Σ_φφ⁻¹)_jj) and t the Student quantile at level 1 − c (two-sided) with
// count − p degrees of freedom. For the BBRF intersection, window k gets the level
// (1 − c)·6/(π²k²) (a union bound: Σ_k = 1 − c), so the intersection keeps θ with probability ≥ c
// per coordinate however many windows there are. The allowance is the LS vertex's; the other
// vertices' sampling error is not covered (it matters only when θ lies near one of them). The
// cumulative box caches its t and recomputes it when the degrees of freedom have doubled (a smaller
// dof gives a larger, conservative t).
// Why the plain intersection (c = 0) loses the truth: BBRF's published experiment added the *exact*
// noise covariance to each window instead of sampled noise. With sampled noise each window box misses
// θ with some probability q > 0, the intersection keeps θ only if every window contains it,
// probability ≈ (1−q)^K → 0 over K windows, and the box shrinks onto a wrong point rather than
// becoming empty. tests/core/estimators/frisch_test.cpp measures the coverages with and without the
// allowance.
//
// Both boxes are always maintained (two O(m³) factorisations per window); frisch_box selects the one
// reported by lower()/upper(); the intersected one is also available.
// Point estimate (EstimatorSettings::frisch_point): "rls" (default) = an internal RLS estimate (same
// forgetting and p0) clamped into the BBRF-intersected box — the authors' DPRLS — and then into the
// reported box, so the point always lies in the reported box. "centre" = the centre of the reported
// box. Clamping into boxes that contain θ never increases any coordinate's error, but it reduces the
// error only where a box has cut into RLS's own sampling spread — so with the allowance the point is
// essentially RLS. Measured on the static problem of tests/core/estimators/frisch_test.cpp (σ_φ = 0.4, 0.3,
// σ_y = 0.3, 2000 rows, window 200; mean ‖θ̂ − θ‖ over 300 runs): RLS 0.217; "rls" with c = 0.95
// 0.217 (both boxes contain θ in 300/300 runs); "rls" with c = 0 0.155 (but the intersected box
// contains θ in only 28 % of the runs); centre of the cumulative box 0.265. On the §5 system the
// plain BBRF (c = 0) collapses onto wrong values (docs/results.md, errors-in-variables estimators). Before
// the first box the estimate is the internal RLS estimate and status() is kNotExcited.
//
// Degenerate windows are skipped (skipped_windows()): a zero or collinear column (Cholesky pivot² of
// the equilibrated Σ < 1e-12), exact noise-free data (then Σ is singular: the Frisch set collapses to
// the exact solution, which RLS already gives), or a vertex at infinity ((Σ⁻¹)_{p,i} ≈ 0).
//
// Where the diagonal-noise assumption holds for hysid's regressions (see core/model/noise_shape.hpp): the
// noise of a trapezoid flow row is [(δt/2)G(e_k + e_{k−1}); e_{k,r} − e_{k−1,r}] (G = ∂φ_{r,u}/∂ξ);
// the cross term between the regressors and y cancels exactly and, with independent noise per state
// component, the regressor block (δt²/2)G R Gᵀ is diagonal when every state component enters at most
// one unknown column of the row (impact-msd: φ_1 = [−ξ1, −ξ2]; bouncing-ball; impact-pendulum to first
// order). It is NOT diagonal when one component enters two columns (e.g. ξ1 and ξ1³), when R is not
// diagonal, or when a known column of the row depends on ξ (then y and φ noise correlate). Jump rows
// [ψ(ξ_{k−1}); ξ_{k,r}] are diagonal under the same condition (e_{k−1} vs e_k are independent).
// Exact columns (a constant 1 in ψ, the −1 of the bouncing ball) have zero noise. Every Frisch
// solution satisfies (Σ − Σ̃)v = 0, i.e. v = Σ⁻¹Σ̃v = Σ_i (σ̃_i² v_i)·Σ⁻¹e_i: a combination of the
// vertex columns weighted by σ̃_i². An exact column has σ̃_i = 0, so its vertex has weight 0 and the
// solutions lie on the face spanned by the other columns' vertices (the weights are ≥ 0 under the
// same Kalman condition that makes the full simplex bound them). When the noise shape C is given
// (EstimatorSettings::noise_shape; the identifier derives it, see core/model/noise_shape.hpp), the columns
// with C_ii = 0 are exact and only the other columns give vertices: the box is that face's bounding
// box. Without C every column gives a vertex (the full simplex, which also contains the face).
// tests/core/estimators/frisch_test.cpp checks the face box's coverage with an exact constant column.
#pragma once

#include <memory>
#include <vector>

#include "core/estimators/estimator.hpp"
#include "core/estimators/rls.hpp"

namespace hysid {

// The recursive Frisch scheme; reads window, forgetting, p0 and the frisch_* options, needs a noise
// shape (its zero diagonal entries), reports a solution box.
EstimatorDescriptor FrischDescriptor();

class Frisch final : public Estimator {
 public:
  // window: 0 or ≥ p+1. noise_shape: empty, or (p+1)×(p+1) whose zero diagonal entries mark the
  // exact (noise-free) columns; nothing else of it is used. Throws std::invalid_argument naming the
  // field otherwise.
  // confidence ∈ [0, 1): the sampling allowance added to every window box (see above; 0 = none).
  Frisch(const Vec& theta0, int window, double forgetting, const Vec& p0_diagonal, FrischBox box, FrischPoint point,
         const Mat& noise_shape = Mat(), double confidence = 0.0);

  std::string name() const override { return "frisch"; }
  std::unique_ptr<Estimator> Clone() const override { return std::make_unique<Frisch>(*this); }
  void Reset() override;
  Mat solution_box() const override;

  bool has_box() const { return has_box_; }
  // The current solution box [lower, upper] (θ0 for both before the first window).
  const Vec& lower() const { return lower_; }
  const Vec& upper() const { return upper_; }
  // Coverage helper: θ inside the box widened by `tolerance` on each side.
  bool Contains(ConstVecRef theta, double tolerance = 0.0) const;
  double BoxVolume() const;
  // Vertices of the last accepted window, p × |noisy_columns()|: column k = the elementary
  // regression with all noise on column noisy_columns()[k] (every column when none is exact).
  const Mat& vertices() const { return vertices_; }
  const std::vector<Eigen::Index>& noisy_columns() const { return noisy_; }
  bool kalman_condition() const { return kalman_; }
  const Vec& rls_estimate() const { return rls_.estimate(); }
  // The BBRF-intersected box, kept whichever box is reported (used by the "rls" point rule).
  const Vec& intersect_lower() const { return inter_lower_; }
  const Vec& intersect_upper() const { return inter_upper_; }
  long windows() const { return windows_; }
  long skipped_windows() const { return skipped_windows_; }
  long empty_intersections() const { return empty_intersections_; }

 private:
  void DoUpdate(const ConstMatRef& phi, const ConstVecRef& y) override;
  // Bounding box of the simplex of `sigma`; false for a degenerate window.
  // `count`: rows (forgetting-weighted) behind `sigma`; `quantile`: the multiplier of the least-
  // squares vertex's standard error added on each side (0 = none).
  bool WindowBox(const Mat& sigma, double count, double quantile, VecRef lower, VecRef upper);
  double CumulativeQuantile(double dof);
  void TakeWindow(const Mat& block, double block_count, const Mat& all, double all_count);
  void SetPoint();

  std::vector<Eigen::Index> noisy_;  // columns of z = [φ; y] that may carry noise (vertex columns)
  int window_;
  double lambda_;
  double confidence_;
  FrischBox box_rule_;
  FrischPoint point_rule_;
  Rls rls_;
  Mat block_sigma_, all_sigma_;
  Mat vertices_, work_inverse_;
  Vec lower_, upper_, window_lower_, window_upper_, scale_;
  Vec inter_lower_, inter_upper_, cum_lower_, cum_upper_;
  bool has_inter_ = false, has_cum_ = false;
  long rows_in_block_ = 0;
  double all_weight_ = 0.0;
  long blocks_ = 0;                            // block windows so far (for the union-bound level)
  double cum_dof_ = 0.0, cum_quantile_ = 0.0;  // cached t quantile of the cumulative box
  long rows_ = 0;
  long windows_ = 0;
  long skipped_windows_ = 0;
  long empty_intersections_ = 0;
  bool has_box_ = false;
  bool kalman_ = false;
};

}  // namespace hysid
