// The Cramér–Rao lower bound of θ = (unknown α, unknown β, unknown γ, ξ0) for samples y_k = Hξ(t_k) + e_k
// (H selects the measured states), e_k ~ N(0, R), R = diag σ²: Fisher information
// F = Σ_k S_kᵀHᵀR⁻¹HS_k (S_k from the hybrid forward
// sensitivities, sim/sensitivity/sensitivity.hpp), CRLB = F⁻¹. The information in the jump times
// themselves is left out (S_k is the derivative at a fixed jump count).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "sim/sensitivity/sensitivity.hpp"

namespace hysid {

enum class CrlbStatus {
  kOk,
  kSimulationFailed,  // the sensitivity simulation stopped early (message says why)
  kSingular,          // F is not positive definite: some direction of θ is not identifiable (the
                      // message names that direction's largest entries)
};
const char* ToString(CrlbStatus status);

struct Crlb {
  CrlbStatus status = CrlbStatus::kOk;
  std::string message;
  std::vector<std::string> names;  // p, in the order of θ
  Mat fisher;                      // p × p
  Mat covariance;                  // F⁻¹ (empty unless ok)
  Vec sd;                          // √diag F⁻¹ (empty unless ok)
  // E‖z‖ for z ~ N(0, CRLB block of the unknown α entries), the same for β and for the guard
  // parameters γ (0 when there are none).
  double mean_e_alpha = 0.0, mean_e_beta = 0.0, mean_e_gamma = 0.0;
  long samples = 0;
  int jumps = 0;
  bool ok() const { return status == CrlbStatus::kOk; }
};

// Σ_k S_kᵀ Hᵀ diag(σ)⁻² H S_k over the samples of `s` (those with present[k] = 1 when `present` is
// given, one entry per sample), H the rows `measured` of the identity (empty: all n). σ: one entry per
// measured state, all > 0; else std::invalid_argument.
Mat FisherInformation(const SensitivityTrajectory& s, const Vec& sigma, const std::vector<int>& measured = {},
                      const std::vector<std::uint8_t>& present = {});

// E‖z‖ for z ~ N(0, covariance) (symmetric PSD), deterministic: E√X = (2√π)⁻¹ ∫₀^∞ (1 − Π_i (1 +
// 2λ_i s)^{−1/2}) s^{−3/2} ds over the eigenvalues λ_i, by the trapezoid rule in log s (relative
// error below 1e-10). 0 for an empty matrix.
double MeanGaussianNorm(const Mat& covariance);

// A hybrid automaton: E‖z‖ for z ~ N(0, the block of `c`'s covariance of each jump map's own unknown
// β entries), one entry per map of spec.jumps, in order; NaN for a map without unknown β (an identity
// map, or every β of the map known). `unknowns` are those `c` was computed for.
std::vector<double> MeanEBetaPerMap(const ModelSpec& spec, const Unknowns& unknowns, const Crlb& c);

// The bound from F: covariance, sd, and the mean errors of the α and β blocks. The entries `held`
// (indices into θ, increasing; in any block) are known: F without their rows and columns is inverted,
// their rows and columns of the covariance (and their sd) are 0, and the mean errors are those of
// the blocks' other entries.
Crlb CrlbFromFisher(const Mat& fisher, const Unknowns& unknowns, std::vector<std::string> names,
                    const std::vector<int>& held = {});

// √(e_iᵀF⁻e_i) for each entry i of θ the information determines, NaN for the others. F⁻ = D·G⁺·D
// with G = D·F·D (D = diag(F)^(−1/2), 1 where that entry is not > 0) and G⁺ its pseudo-inverse over
// the eigenvalues above 1e-10 times the largest; the rest span the null space (CrlbFromFisher's test
// finds F singular only when there is one), and entry i is determined when e_i's squared component
// in it is below 1e-6 (a null direction names every entry it moves with a component of 0.1 or more).
// For such an entry e_iᵀF⁻e_i is the same for every generalised inverse of F: holding one entry of
// the null direction known and inverting the rest gives it too; a nonsingular F gives √diag F⁻¹.
// Empty when F is not finite or square.
Vec DeterminedSd(const Mat& fisher);

// A direction v of the parameters by its largest entries, named (`theta[i]` beyond `names`):
// "direction 0.71 x0[v] - 0.7 g" (up to three entries, each after the first at least 0.1 in size;
// signs relative to the first).
std::string Direction(const Vec& v, const std::vector<std::string>& names);

// The bound `c` (computed for `unknowns` over n states, ξ0 last in θ) with the components `known` of ξ0
// (state indices) known: held, sd 0, left out of the inverse (CrlbFromFisher), its samples and jumps
// kept. `c` itself when none is known, ξ0 is not in θ or the simulation failed.
Crlb HoldKnownX0(Crlb c, const Unknowns& unknowns, const std::vector<int>& known, int n);

// The bound at the model's true α, β and the given ξ0 over `grid` with noise σ (one entry > 0 per
// measured state) on the states `measured` (indices, increasing; empty: all), with the measured
// inputs `inputs` for a model with inputs (else nullptr), on the grid's samples k with present[k] = 1
// when `present` is given (one entry per sample: a record with missing samples and gaps).
// Throws std::invalid_argument for bad inputs (as SimulateSensitivities, plus σ and measured).
Crlb ComputeCrlb(const Model& model, const Vec& x0, const SampleGrid& grid, const Vec& sigma,
                 const Unknowns& unknowns, const SensitivityOptions& options = {},
                 const std::vector<int>& measured = {}, const InputSignal* inputs = nullptr,
                 const std::vector<std::uint8_t>& present = {});
// The same at the given α, β, γ and ξ0 (γ empty: the model's).
Crlb ComputeCrlb(const Model& model, const HybridParameters& at, const SampleGrid& grid, const Vec& sigma,
                 const Unknowns& unknowns, const SensitivityOptions& options = {},
                 const std::vector<int>& measured = {}, const InputSignal* inputs = nullptr,
                 const std::vector<std::uint8_t>& present = {});

}  // namespace hysid
