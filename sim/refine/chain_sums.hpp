// What the output-error fit keeps of one chain's run with sensitivities: sums over its samples, not
// the run. Internal to sim/refine.
//
// With r_ik = y_ik − ξ_i(t_k) the residual of measured component i at sample k and S_ik the row of
// ∂ξ_i(t_k)/∂θ (θ: the chain's p unknowns, shared ones then its ξ0), the sums per component are
//   G_i = Σ_k S_ikᵀ S_ik (p × p),  h_i = Σ_k S_ikᵀ r_ik,  c_i = Σ_k r_ik²,  l_i = Σ_k r_ik r_i,k+1.
// For any weights w_i = 1/σ_i they give the weighted cost Σ_i w_i² c_i, the Gauss–Newton matrix and
// Fisher information Σ_i w_i² G_i, the gradient −Σ_i w_i² h_i, and the residual checks (σ̂_i, RMS,
// lag-1): the fit holds O(p²) numbers per chain instead of its n·p per sample.
//
// Ceres is handed a compressed residual of p + 1 entries with the same cost, gradient and
// Gauss–Newton matrix as the chain's m·K weighted residuals: with A = JᵀJ, D = diag(A)^{−1/2},
// D A D = V Λ Vᵀ and g = Jᵀr, the residual (Λ^{−1/2} Vᵀ D g, e) and Jacobian (Λ^{1/2} Vᵀ D⁻¹; 0),
// e² = ‖r‖² − ‖Λ^{−1/2} Vᵀ D g‖² (the equilibration keeps unknowns in any units resolved).
// (The Gauss–Newton model ½‖r + JΔ‖² is the same quadratic in Δ, and the cost at every point is
// exact, so Levenberg–Marquardt takes the same steps; Ceres' Jacobian scaling uses the column norms
// of J, which the compressed Jacobian keeps.)
#pragma once

#include <vector>

#include "core/model/model.hpp"
#include "sim/sensitivity/sensitivity.hpp"

namespace hysid {

struct ChainSums {
  std::vector<Mat> gram;  // G_i, one per measured component
  Mat h;                  // p × m: column i is h_i
  Vec squares;            // c_i
  Vec lag;                // l_i
  long samples = 0;

  Mat Information(const Vec& weight) const;  // Σ_i w_i² G_i
  Vec Gradient(const Vec& weight) const;     // Jᵀr = −Σ_i w_i² h_i (J = −W S, r = W(y − Hξ))
  double Cost(const Vec& weight) const;      // ‖r‖² = Σ_i w_i² c_i
};

// The sums of run s against the chain's measured samples y (m × K, the rows `rows` of ξ).
ChainSums SumChain(const SensitivityTrajectory& s, const Mat& y, const std::vector<int>& rows);

// The same sums taken while the run integrates (SimulateSensitivitiesMatched's sink), so that no run
// holds S for all its samples: G_i and h_i as each sample's S_k comes, c_i and l_i from the run's
// states at the end. Most samples come as windows (SensitivitySink::windows): S_ik = V_iᵀw_k with V_i
// the 4 × p rows of component i of the window's ends, so the window adds V_iᵀ(Σ_k w_k w_kᵀ)V_i to G_i
// and V_iᵀ(Σ_k w_k r_ik) to h_i: 4 × 4 products per sample instead of p × p. Equal to SumChain's up
// to rounding (the order of summation).
class ChainSummer final : public SensitivitySink {
 public:
  // y: the chain's measured samples (m × K; its storage and rows must outlive the summer); n states,
  // p unknowns.
  ChainSummer(const Eigen::Ref<const Mat>& y, const std::vector<int>& rows, int n, int p);
  void Sample(long k, const double* x, const double* s) override;
  bool windows() const override { return true; }
  void WindowSample(long k, const double* x, const double* w) override;
  void CloseWindow(const double* sa, const double* da, const double* sb, const double* db) override;
  // The sums once the run (its states: n × K) is done.
  ChainSums Finish(const Mat& x);
  // S at the chain's last sample (n × p; zero until the run read it).
  const Mat& last_sensitivities() const { return last_; }

 private:
  // Samples gathered before they are added to G_i and h_i (a rank-kBlock update each).
  static constexpr Eigen::Index kBlock = 128;
  void Flush();

  Eigen::Map<const Mat, 0, Eigen::OuterStride<>> y_;
  const std::vector<int>& rows_;
  int n_ = 0;
  std::vector<Mat> gram_;      // G_i, the lower triangle
  Mat h_;                      // p × m
  std::vector<Mat> block_;     // per component: ∂ξ_i/∂θ of the gathered samples (kBlock × p)
  Mat residuals_;              // kBlock × m: r_ik of the gathered samples
  Eigen::Index gathered_ = 0;  // samples gathered
  Mat last_;
  // The open window: Σ_k w_k w_kᵀ and, per component, Σ_k w_k r_ik (4 × m) over its samples; the
  // weights of the chain's last sample when it is among them.
  Eigen::Matrix4d window_weights_ = Eigen::Matrix4d::Zero();
  Mat window_residuals_;
  Eigen::Vector4d last_weights_;
  bool last_in_window_ = false;
  Mat ends_, ends_weighted_;  // scratch: V_i (4 × p) and (Σ w wᵀ)V_i
};

// The joint information of θ = (the s shared unknowns, then each chain's n-entry ξ0) over C chains,
// held per chain: the chains couple only through the shared block, so F is an arrow of blocks
//   F = [A B_1 … B_C; B_1ᵀ D_1 0 …; …; B_Cᵀ 0 … D_C],  A = Σ_c A_c,
// and what the fit needs of F is computed with each ξ0_c eliminated (the Schur complement
// S = A − Σ_c B_c D_c⁻¹ B_cᵀ), never forming the (s + n·C)² matrix.
struct ChainInformation {
  Mat shared;                 // A (s × s)
  std::vector<Mat> coupling;  // B_c (s × n)
  std::vector<Mat> own;       // D_c (n × n)

  // From each chain's (s + n) × (s + n) information (its shared unknowns, then its ξ0).
  static ChainInformation Of(const std::vector<Mat>& chains, int shared);
  // F itself (for few chains, and for the message of a singular F).
  Mat Joint() const;
  // gᵀF⁻¹g for g over the joint θ; infinity when F is not positive definite.
  double InverseQuadratic(const Vec& g) const;
  // The block of F⁻¹ for the shared unknowns and chain c's ξ0 ((s + n) × (s + n)). False when F is
  // not positive definite by CrlbFromFisher's test, applied to the blocks: on the equilibrated
  // matrix (D = diag(F)^(−1/2)), every D_c and S positive definite with LDLT pivots above 1e-14
  // (F is positive definite exactly when they all are).
  bool CovarianceBlock(std::size_t c, Mat* covariance) const;
};

// The compressed residual (p + 1 entries) and its Jacobian ((p + 1) × p, row-major) for the weights.
void CompressedResidual(const ChainSums& sums, const Vec& weight, double* residuals, Mat* jacobian);

}  // namespace hysid
