// Recursive generalized total least squares (GTLS) with a known noise covariance shape C.
//
// Model (docs/estimators.md, "gtls"): each scalar regression row z = [φ; y] ∈ ℝ^{p+1} is z₀ + w with
// z₀ᵀv = 0 for v = [θ; −1] and E[w wᵀ] = σ²C, C known up to the scale σ² and possibly singular
// (exact columns such as a constant 1 have zero rows/columns in C: mixed LS-TLS without explicit
// partitioning). With the information matrix S = Σ λ^{k−j} z zᵀ and the weight W = Σ λ^{k−j}·rows,
//   v̂ = argmin (vᵀSv)/(vᵀCv)  ⇔  the largest ν of C v = ν S v,   θ̂ = −v̂[0:p]/v̂[p],
//   σ̂² = (v̂ᵀSv̂)/(v̂ᵀCv̂)/W.
// C = I is classical TLS; C = diag(0,…,0,1) is least squares.
//
// Algorithm per Update (rows z_i of [Φ | y]):
//   1. forgetting: S ← λS, P ← P/λ, W ← λW (skipped when every row is zero, so that S cannot
//      underflow and P cannot wind up on unexciting data);
//   2. per row: S += z zᵀ, W += 1, and P ≈ S⁻¹ by Sherman–Morrison: g = Pz, P −= g gᵀ/(1 + zᵀg);
//   3. one sweep of inverse iteration warm-started at the previous v: v ← P C v, v ← v/‖v‖
//      (converges at the rate ν₂/ν₁ per sweep; the previous solution is usually very close);
//   4. θ = −v[0:p]/v[p] unless the non-generic case |v[p]| ≤ 1e-8‖v‖ (in equilibrated coordinates):
//      then θ is kept and status() = kNonGeneric.
// Batch start: until at least 2(p+1) rows exist and the regressor block of S has full numerical rank,
// S is only accumulated (status kNotExcited; θ = θ0 until p rows determine the provisional
// least-squares solution, then that). Then, and every `refactor_every` rows (or after
// a failed Sherman–Morrison step), an exact refactorisation: column equilibration D = diag(S)^{−1/2},
// rank check of D S_φφ D (Cholesky pivots ≥ 1e-10), S_d = D S D + 1e-13·I (the tiny ridge keeps exact,
// noise-free data — where S itself is singular — solvable; its relative effect is ~1e-13), LLT,
// P = D S_d⁻¹ D, and the exact top eigenvector of L⁻¹(DCD)L⁻ᵀ (Eigen::SelfAdjointEigenSolver).
// Cost: O(rows·(p+1)²) per update plus O((p+1)³) every refactor_every rows.
#pragma once

#include <Eigen/Cholesky>

#include "core/estimators/estimator.hpp"

namespace hysid {

// Recursive generalized total least squares; reads forgetting and refactor_every, needs a noise shape.
EstimatorDescriptor GtlsDescriptor();

class Gtls final : public Estimator {
 public:
  // noise_shape: (p+1)×(p+1), symmetric positive semidefinite, not zero; empty = identity (classical
  // TLS). Throws std::invalid_argument naming noise_shape, forgetting or refactor_every otherwise.
  Gtls(const Vec& theta0, const Mat& noise_shape, double forgetting, int refactor_every);

  std::string name() const override { return "gtls"; }
  std::unique_ptr<Estimator> Clone() const override { return std::make_unique<Gtls>(*this); }
  // (Φ̃ᵀΦ̃)⁻¹ over the rows so far (forgetting-weighted, the θ block of S), as RLS's P without a
  // prior: the parameter covariance up to the noise variance, which the residual jump detector uses
  // for its leverage term. Computed when asked after S changed; none before S's θ block is
  // positive definite.
  const Mat* covariance_matrix() const override;
  void Reset() override;

  // σ̂² = (vᵀSv)/(vᵀCv)/W: the noise scale in units of C (0 before the batch start).
  double noise_variance() const;
  const Mat& noise_shape() const { return c_; }
  // The current generalized eigenvector v (θ = −v[0:p]/v[p] when generic).
  // Refactorises and solves the eigenproblem exactly now (e.g. at the end of a run). Does nothing
  // before the batch start.
  void Refresh();
  long rows() const { return rows_; }
  // SupportGap at the last refactorisation (0 before the batch start). Below max(1, 10·√(2/W)) (the
  // signal below the noise, or within 10 sampling sd of it) the status is ill-conditioned.
  double support() const { return support_; }

 private:
  void DoUpdate(const ConstMatRef& phi, const ConstVecRef& y) override;
  // Exact refactorisation + eigen solve; false (and a status) when S is not usable.
  bool Factorize();
  void Forget(const ConstMatRef& phi, const ConstVecRef& y);
  void AddRow(Eigen::Index m);
  void InverseIterationStep(Eigen::Index m);
  void SetThetaFromEigenvector();
  // Before the batch start: θ = least squares of the rows so far once they determine it (so that
  // users of the estimate, e.g. the jump detector's τ̂, see a sensible value); status kNotExcited.
  void ProvisionalLeastSquares();
  // The LLT of the equilibrated θ block D·S_θθ·D (d = D's diagonal); false when it is not (yet)
  // positive definite to kRankTolerance.
  bool FactorThetaBlock(Vec* d, Eigen::LLT<Mat>* llt) const;
  // How far the regressors stand above their noise: with ν the smallest generalized eigenvalue of
  // (S, C) (the noise energy, ≈ σ²W) and ν' that of the regressor block (S_φφ, C_φφ) (interlacing:
  // ν ≤ ν'), g = ν'/ν − 1, the signal-to-noise energy ratio of the regressors' weakest direction.
  // TLS corrects least squares along that direction by the factor (1 + g)/g: as g → 0 the estimate
  // is noise divided by noise. l: the Cholesky factor of the equilibrated S, cd the equilibrated C,
  // mu_top = 1/ν. +∞ when the regressors carry no noise (C_φφ = 0: least squares).
  double SupportGap(const Mat& l, const Mat& cd, double mu_top) const;

  Mat c_;          // C, (p+1)²
  Mat s_;          // S
  Mat p_;          // ≈ S⁻¹ (of the slightly ridged S, see above)
  Vec v_;          // generalized eigenvector
  Vec scale_;      // D from the last refactorisation
  Vec z_, g_, t_;  // work vectors
  double lambda_;
  int refactor_every_;
  double weight_ = 0.0;
  double support_ = 0.0;  // SupportGap at the last refactorisation
  long rows_ = 0;
  long rows_since_refactor_ = 0;
  bool started_ = false;
  bool needs_refactor_ = false;
  mutable Mat cov_;                // covariance_matrix() cache
  mutable long cov_updates_ = -1;  // updates_ when cov_ was computed (−1: never, −2: not available)
};

}  // namespace hysid
