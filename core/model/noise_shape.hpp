// Noise covariance shapes C of hysid's two regressions (for the "gtls" estimator), and a robust
// estimate of the measurement noise σ from data (docs/estimators.md, "Noise shapes").
//
// Measurement model: ξ̃_k = ξ_k + e_k, e_k ~ (0, R) i.i.d., R = diag(σ²).
// Regression row z = [φ_u; y] of an identified state component r (core/model/regression.hpp):
//
// Flow (trapezoid): φ_u = (δt/2)(φ_{r,u}(ξ̃_k) + φ_{r,u}(ξ̃_{k−1})),
//                   y   = ξ̃_{k,r} − ξ̃_{k−1,r} − (δt/2)(φ_{r,k}(ξ̃_k) + φ_{r,k}(ξ̃_{k−1})) α_k.
//   To first order, with G = ∂φ_{r,u}/∂ξ (|u|×n), g = ∂(φ_{r,k} α_k)/∂ξ (n), s = e_k + e_{k−1},
//   d = e_k − e_{k−1} (E[ssᵀ] = E[ddᵀ] = 2R, E[sdᵀ] = R − R = 0: the trapezoid cancels the cross term):
//     w = [(δt/2) G s; d_r − (δt/2) gᵀ s],   so with Ĝ = [G; −gᵀ]:
//     C = (δt²/2) Ĝ R Ĝᵀ + 2 R_rr e_last e_lastᵀ.
//   Without known columns depending on ξ (g = 0) this is blockdiag((δt²/2) G R Gᵀ, 2R_rr).
// Jump: φ_u = ψ_{r,u}(ξ̃_{k−1}), y = ξ̃_{k,r} − ψ_{r,k}(ξ̃_{k−1}) β_k, with J = ∂ψ_{r,u}/∂ξ,
//   j = ∂(ψ_{r,k} β_k)/∂ξ:  C = Ĵ R Ĵᵀ + R_rr e_last e_lastᵀ,  Ĵ = [J; −jᵀ]  (e_{k−1} and e_k independent).
// Constant columns have zero rows/columns in C (mixed LS-TLS).
//
// Jacobians: ∂φ/∂ξ by central differences of Model::Phi/Psi (step 1e-6·max(1, |ξ_j|); exact up to
// rounding for φ affine in ξ). For φ nonlinear in ξ the Jacobian depends on the state: the functions
// take a set of states (columns) and return the average of C over them, which is what enters
// E[S]/N = S₀/N + σ²·mean(C) (use the measured samples, or a subsample). Second-order terms
// (E[φ(ξ + e)] − φ(ξ) ∝ σ²∂²φ) are neglected.
// Several identified rows: the estimator takes one C for all rows; the mean of the per-row C is
// exact for E[S] when every row is used equally often, so that is what is returned.
// Scale: the returned C is in absolute units (σ² included), so GTLS's σ̂² estimates 1 when σ is right.
#pragma once

#include <vector>

#include "core/model/model.hpp"
#include "core/model/regression.hpp"

namespace hysid {

// C of the flow regression ((|u|+1)²) averaged over the columns of `states` (n × K, K ≥ 1).
// Throws std::invalid_argument naming sigma, dt or states for a wrong size, σ < 0, δt ≤ 0, or
// non-finite values.
Mat FlowNoiseShape(const Model& model, ConstVecRef sigma, double dt, const Mat& states);
// C of the jump regression averaged over the (pre-jump) states.
Mat JumpNoiseShape(const Model& model, ConstVecRef sigma, const Mat& states);

// Robust per-component estimate of σ from measured samples y (n × K, uniform δt, K ≥ 4):
//   d_k = y_{k+1} − 2y_k + y_{k−1} = δt² ξ''(t_k) + (e_{k+1} − 2e_k + e_{k−1}),  Var = 6σ² for the noise;
//   σ̂ = 1.4826 · median|d_k − median d| / √6  (MAD, consistent for Gaussian noise).
// The median makes the rare jump samples (O(1) outliers in d) harmless; the smooth part δt²ξ'' biases
// σ̂ upwards only when it is comparable to σ (then sample faster or give σ). Throws
// std::invalid_argument when y has fewer than 4 columns or non-finite entries.
Vec EstimateNoiseSigma(const Mat& y);
// The same σ̂ of one component from its second differences d_k (K − 2 of them, reordered in place), for
// samples held apart (several chains read in order) that need not be copied side by side. Throws as
// EstimateNoiseSigma for fewer than 2 differences or a non-finite one.
double NoiseSigmaFromSecondDifferences(std::vector<double>& d);

}  // namespace hysid
