// The paper's identifier (Algorithms 1 and 2) over a stream of measured samples ξ(kδt).
//
// Per sample t (from the second on):
//   1. the flow regression of (ξ(t−δt), ξ(t)) on the identified rows (core/regression.hpp);
//   2. γ(t) from the jump detector (core/detector.hpp);
//   3. γ = 0: update α̂ with the flow estimator; γ = 1: update β̂ with the jump estimator on
//      ξ_r(t) = ψ_r(ξ(t−δt))β (eq. 5);
//   4. Algorithm 2: ξ(t−δt) joins Γ when γ(t) = 1, else Λ. (The paper adds ξ(t) to Λ at once and moves
//      ξ(t−δt) to Γ on a jump; deciding ξ(t−δt) one sample later gives the same sets without removing
//      points from a hull. The newest sample is in neither set until the next one arrives.)
//
// Beyond the paper (options, off by default):
//   localize     the jump regression uses the states just before and after the located jump instant
//                s ∈ (t−δt, t] (core/localize.hpp) instead of ξ(t−δt), ξ(t); falls back to the pair
//                when the jump cannot be located.
//   second_pass  Identify() runs the data twice: the second pass re-classifies every sample with the
//                first pass's final α̂ (and its covariance, and the detector's learned state) held
//                fixed, and re-estimates α, β and the sets from scratch on that classification.
//                IdentifyResult says how many samples changed class. Forgetting (EstimatorSettings::
//                forgetting) is the other way to let early mistakes fade.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "core/detector.hpp"
#include "core/estimator.hpp"
#include "core/regression.hpp"
#include "core/sample_set.hpp"

namespace hysid {

struct IdentifierSettings {
  EstimatorSettings flow_estimator;  // for α
  EstimatorSettings jump_estimator;  // for β
  DetectorSettings detector;
  bool sets = true;  // maintain Λ, Γ and their hulls (Algorithm 2)
  Vec sigma;         // measurement noise σ per component when known (empty: unknown)
  // Prior for the unknown parameters (empty: zero), for both α and β in model order.
  Vec alpha0, beta0;
  bool localize = false;     // sub-sample jump localisation for the jump regression
  bool second_pass = false;  // Identify(): re-classify with the final α̂ and re-estimate
};

class Identifier {
 public:
  // Throws std::invalid_argument for δt ≤ 0 or invalid settings (naming the field).
  Identifier(const Model& model, double dt, const IdentifierSettings& settings);
  ~Identifier();
  Identifier(Identifier&&) noexcept;
  Identifier& operator=(Identifier&&) noexcept;

  // Feeds the next measured sample ξ(t). The first sample only initialises (γ = 0, no update).
  Decision Step(ConstVecRef x);
  // Ends the stream: the newest sample joins Λ (the paper puts every ξ(t) in Λ until a jump moves it).
  void Finish();
  // Starts a second pass over the same stream: α̂ and its covariance are frozen for classification,
  // the estimators and sets restart from their priors, the detector keeps what it has learned.
  void BeginSecondPass();

  Vec alpha_hat() const;  // full α̂: known entries at their known values
  Vec beta_hat() const;
  const Estimator& flow_estimator() const;
  const Estimator& jump_estimator() const;
  const SampleSet& flow_set() const;  // Λ (Ĉ = its hull); empty when settings.sets is false
  const SampleSet& jump_set() const;  // Γ (D̂)
  long samples() const;
  long jumps_detected() const;
  long jumps_localized() const;  // jumps whose regression used the located instant

 private:
  struct State;
  std::unique_ptr<State> s_;
};

// A whole run: samples y (n × K, column k measured at t_k = kδt).
struct IdentifyOptions {
  bool trace = false;  // keep per-sample α̂, β̂ (else only γ, statistic, threshold)
};

struct IdentifyResult {
  Vec alpha_hat, beta_hat;              // final, full vectors
  std::vector<std::uint8_t> gamma;      // per sample (gamma[0] = 0)
  std::vector<double> statistic;        // detector statistic per sample (paper: D_δt ξ)
  std::vector<double> threshold;        // its threshold (paper: τ̂)
  Mat alpha_trace, beta_trace;          // |α| × K and |β| × K when options.trace
  long jumps_detected = 0;
  EstimatorStatus flow_status = EstimatorStatus::kNotExcited;
  EstimatorStatus jump_status = EstimatorStatus::kNotExcited;
  Mat flow_hull, jump_hull;             // n × h hull vertices of Λ and Γ (when settings.sets)
  double flow_hull_volume = 0.0, jump_hull_volume = 0.0;
  long jumps_localized = 0;             // settings.localize: jumps regressed at the located instant
  // settings.second_pass: the first pass's outcome and what the second changed. gamma, estimates
  // and traces above are the second pass's.
  bool second_pass = false;
  std::vector<std::uint8_t> first_pass_gamma;
  Vec first_pass_alpha_hat, first_pass_beta_hat;
  long reclassified_to_jump = 0;  // flow in the first pass, jump in the second
  long reclassified_to_flow = 0;  // jump in the first pass, flow in the second
};

IdentifyResult Identify(const Model& model, const Mat& y, double dt,
                        const IdentifierSettings& settings, const IdentifyOptions& options = {});

}  // namespace hysid
