// The Cramér–Rao lower bound of θ = (unknown α, unknown β, ξ0) for samples y_k = ξ(t_k) + e_k,
// e_k ~ N(0, R), R = diag σ²: Fisher information F = Σ_k S_kᵀ R⁻¹ S_k (S_k from the hybrid forward
// sensitivities, sim/sensitivity/sensitivity.hpp), CRLB = F⁻¹. The information in the jump times
// themselves is left out (S_k is the derivative at a fixed jump count).
#pragma once

#include <string>
#include <vector>

#include "sim/sensitivity/sensitivity.hpp"

namespace hysid {

enum class CrlbStatus {
  kOk,
  kSimulationFailed,  // the sensitivity simulation stopped early (message says why)
  kSingular,          // F is not positive definite: some direction of θ is not identifiable
};
const char* ToString(CrlbStatus status);

struct Crlb {
  CrlbStatus status = CrlbStatus::kOk;
  std::string message;
  std::vector<std::string> names;  // p, in the order of θ
  Mat fisher;                      // p × p
  Mat covariance;                  // F⁻¹ (empty unless ok)
  Vec sd;                          // √diag F⁻¹ (empty unless ok)
  // E‖z‖ for z ~ N(0, CRLB block of the unknown α entries), the same for β (0 when there are none).
  double mean_e_alpha = 0.0, mean_e_beta = 0.0;
  long samples = 0;
  int jumps = 0;
  bool ok() const { return status == CrlbStatus::kOk; }
};

// Σ_k S_kᵀ diag(σ)⁻² S_k over the samples of `s` (σ: n entries, all > 0; else std::invalid_argument).
Mat FisherInformation(const SensitivityTrajectory& s, const Vec& sigma);

// E‖z‖ for z ~ N(0, covariance) (symmetric PSD), deterministic: E√X = (2√π)⁻¹ ∫₀^∞ (1 − Π_i (1 +
// 2λ_i s)^{−1/2}) s^{−3/2} ds over the eigenvalues λ_i, by the trapezoid rule in log s (relative
// error below 1e-10). 0 for an empty matrix.
double MeanGaussianNorm(const Mat& covariance);

// The bound from F: covariance, sd, and the mean errors of the α and β blocks.
Crlb CrlbFromFisher(const Mat& fisher, const Unknowns& unknowns, std::vector<std::string> names);

// The bound at the model's true α, β and the given ξ0 over `grid` with noise σ (n entries > 0).
// Throws std::invalid_argument for bad inputs (as SimulateSensitivities, plus σ).
Crlb ComputeCrlb(const Model& model, const Vec& x0, const SampleGrid& grid, const Vec& sigma,
                 const Unknowns& unknowns, const SensitivityOptions& options = {},
                 const InputSignal* inputs = nullptr);

}  // namespace hysid
