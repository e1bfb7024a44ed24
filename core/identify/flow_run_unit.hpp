// One identifier's flow run in local variables: RLS for two unknowns (detail::Rls2State) beside the
// paper detector on a constant flow Jacobian (detail::PaperConstant2<A>, A = |α|), with the counters
// the run adds to the identifier when it ends. BeginFlowRun fills it and EndFlowRun writes it back
// (core/identify/lockstep_units.hpp); IdentifyLockstep (core/identify/lockstep.hpp) steps several of
// them side by side over the same samples, the pair's terms computed once for all. Step is the loop
// body of the identifier's FlowRun (core/identify/row_block.cpp): the same operations in the same
// order, so the same bits. Not installed.
#pragma once

#include "core/detectors/detector.hpp"
#include "core/detectors/paper.hpp"
#include "core/estimators/rls.hpp"

namespace hysid::detail {

template <int A>
struct FlowRunUnit {
  Rls2State rls;
  PaperConstant2<A> paper;
  double lambda = 1.0, max_trace = 0.0;  // RLS's forgetting factor and wind-up bound
  double prev_norm = 0.0;                // ‖ξ(t−δt)‖ in the bound's norm
  long version = 0;                      // α̂'s version (the identifier's, counted on)
  long admitted = 0, informative = 0;    // rows admitted in this run, those with φ ≠ 0

  // The next flow sample with the pair's terms (PairTerms of ξ(t−δt), ξ(t) in paper's bound mode)
  // and its finite flow row (f0, f1; yk): classified, and on γ = 0 α̂ updated. False (the run stops
  // here) at a jump or a failed update, the decision in *d for the identifier's own path to apply;
  // nothing counted then. The caller tells paper (PaperConstant2::Saw) of the last sample classified
  // before the state goes back.
  // kThreshold: as PaperConstant2::Decide.
  template <bool kThreshold = true>
  [[gnu::always_inline]] bool Step(const PairTerms& pair, double f0, double f1, double yk, Decision* d) {
    *d = paper.template Decide<kThreshold>(pair, prev_norm, rls.t0, rls.t1, version);
    if (d->gamma || !rls.Update(f0, f1, yk, lambda, max_trace)) return false;
    prev_norm = pair.cur_norm;
    ++admitted;
    informative += f0 != 0.0 || f1 != 0.0 ? 1 : 0;
    ++version;
    return true;
  }
};

}  // namespace hysid::detail
