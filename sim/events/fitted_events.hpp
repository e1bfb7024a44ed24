// The event times of a refined hybrid automaton (docs/method.md "The output-error refinement", event
// times from the fitted model): the fitted model's own guard crossings, run from the refined α, β, γ
// and each chain's refined ξ0 over the whole chain, so each time uses all the data rather than the
// samples around one event (past a span the refinement cut, RefineResult::chain_samples_used, they
// are the fitted model's prediction; `beyond` says where). A detected event (IdentifyResult::events)
// gets the crossing of its chain nearest its time when that crossing applies the event's map and no
// other event of the chain is nearer to it; crossings the detector missed pair with no event.
//
// Standard error: the run's ∂t_j/∂θ (saltation, sim/sensitivity/sensitivity.hpp:
// ∂t_j/∂θ = −(∇ₓh·S⁻ + ∂h/∂θ)/(∇ₓh·f⁻)) with the refinement's covariance C of θ and the chain's
// own ξ0 (RefineResult::chain_covariance), se = √(gᵀCg).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/identify/identifier.hpp"
#include "sim/refine/refine.hpp"

namespace hysid {

// One guard crossing of the fitted model, on the data's clock.
struct FittedCrossing {
  double time = 0.0;
  int map = 0;    // the jump map it applies
  int chain = 0;  // the chain (SplitChains' order) it was run on
};

struct FittedEvents {
  // Per IdentifyResult::events: the fitted crossing's time and its standard error (NaN: none, see
  // `reason`; se also NaN without a covariance).
  std::vector<double> time, se;
  std::vector<FittedCrossing> crossings;  // every crossing of the fitted model, all chains, in order
  std::string reason;                     // why a time is NaN ("" when every event has one)
  std::string beyond;                     // where a chain's run goes past its fitted span ("" when none)
};

// Nothing (every time NaN, `reason` says why) when the refinement is not ok. (t, y, chain_start, u)
// are the samples the refinement was given (RefineIdentification's); `recursive` the pass whose
// events and modes it was given. Throws std::invalid_argument for sizes that disagree (SplitChains).
FittedEvents FitEventTimes(const Model& model, const std::vector<double>& t, const Mat& y,
                           const std::vector<std::uint8_t>& chain_start, const Mat& u,
                           const IdentifyResult& recursive, const RefineResult& refined,
                           const SensitivityOptions& options = {});

}  // namespace hysid
