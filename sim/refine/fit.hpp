// One fit of the output-error refinement (sim/refine/refine.hpp) and the pieces its recoveries
// share. Internal to sim/refine.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "sim/input_signal.hpp"
#include "sim/refine/refine.hpp"

namespace hysid {

// What one fit of the chains starts from.
struct FitStart {
  HybridParameters start;                        // α, β (x0 unused: per chain below)
  std::vector<std::vector<std::uint8_t>> gamma;  // per chain: its jump labels
  std::vector<Vec> x0;                           // per chain: its initial state's start
  std::vector<long> limit;                       // per chain: the samples the span retries leave
  std::vector<std::string> reason;               // per chain: why the retries cut it ("" when not)
  // Multiple shooting (sim/refine/shooting.hpp): per chain, 1 when its last sample is the next
  // chain's first and the two are linked by continuity residuals (x_c(t_last) − ξ0_{c+1})/(w·σ) while
  // both are fit and chain c is fit whole. Empty: no links.
  std::vector<std::uint8_t> continues;
};

// The chain whose failure the span retries may mend, and its first sample at which the model's jumps
// and the detected ones disagree (−1: none).
struct ChainFailure {
  long chain = -1;  // in the caller's list
  long disagreement = -1;
  // When the fit ran: the fitted model's own jump times on that chain (from its first sample).
  std::vector<double> model_jumps;
};

// One fit from s: the chains as fit (span rule, retry limits, chains too short or outside C ∪ D left
// out), the start, the Ceres solve (polished for noise-free data), the jump checks per chain and
// the residual checks pooled. A failure the span retries may mend names its chain in *failure.
// The chains' data are finite and their sizes checked.
RefineResult FitChains(const Model& model, const std::vector<RefineChain>& chains, const FitStart& s,
                       const RefineOptions& options, ChainFailure* failure);

// The fit's integration options (RefineOptions::noise_tolerance's rule) and residual weights 1/σ_i
// (σ given, else the MAD estimate) for the samples y.
void FitWeighting(const Mat& y, const RefineOptions& options, const Vec& mad_sigma, SensitivityOptions* sens,
                  Vec* weight);
// The same from what it reads of the samples: each component's largest |y_ik| and their number.
void FitWeighting(const Vec& largest, long samples, const RefineOptions& options, const Vec& mad_sigma,
                  SensitivityOptions* sens, Vec* weight);

// Whether the model can be simulated at p: α, β, γ and x0 finite, x0 in C or D (at t = 0, u(0), p's
// γ and initial mode).
bool Admissible(const Model& model, const HybridParameters& p, const InputSignal& inputs);

// The measured components: RefineOptions::measured, or all n when it is empty.
std::vector<int> MeasuredRows(const RefineOptions& options, int n);

// Why a chain is left out of the fit with `used` of its samples ("" when it is fit); C and D with the
// guard parameters γ (the model's size).
std::string LeftOut(const Model& model, const RefineChain& chain, long used, const Vec& gamma);

// A chain's inputs over its first `used` samples, their times from its first sample (the clock its
// fits run on); empty without inputs.
InputSignal ChainInputs(const RefineChain& chain, long used);
// The inputs a run of a chain takes: nullptr when the signal is empty (a model without inputs).
inline const InputSignal* InputsOf(const InputSignal& inputs) { return inputs.empty() ? nullptr : &inputs; }

// The samples of the chains side by side (Part: anything with an n × K member y).
template <class Part>
Mat Concatenated(const std::vector<Part>& parts, int n) {
  Eigen::Index k = 0;
  for (const Part& p : parts) k += p.y.cols();
  Mat all(n, k);
  k = 0;
  for (const Part& p : parts) {
    all.middleCols(k, p.y.cols()) = p.y;
    k += p.y.cols();
  }
  return all;
}

// s moved to the fit r's point: its α, β, γ and each fitted chain's ξ0 (labels and spans kept).
void MoveTo(const RefineResult& r, FitStart& s);

// A failed fit: its status and the reason printed with it.
void Fail(RefineResult& r, RefineStatus status, std::string reason);

// Integration accuracy per row of y (1e3 · (rtol · max_k |y_k| + atol)): residuals below it are
// numerical, not noise (noise-free data), and get no residual test.
Vec NumericalFloor(const Mat& y, const SimOptions& sim);

}  // namespace hysid
