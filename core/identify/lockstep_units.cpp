// What the lockstep driver asks of an identifier (core/identify/lockstep_units.hpp): its flow runs
// begun and ended from outside, the twins' questions, and the rest of a block fed by its own path.
#include "core/identify/lockstep_units.hpp"

#include <memory>

#include "core/identify/identifier_state.hpp"

namespace hysid::detail {

template <int A>
bool BeginFlowRun(const Identifier& id, FlowRunUnit<A>* unit) {
  const IdentifierState& s = IdentifierAccess::Of(id);
  if (!s.flow_run || s.frozen || s.settings.sets || !s.has_prev || s.alpha_full.size() != A ||
      s.rls->updates() < s.paper->unknowns()) {
    return false;
  }
  const int* unknown = s.builder.flow_layout().unknown.data();
  unit->rls = s.rls->Load2();
  unit->paper = s.paper->LoadConstant2<A>(s.alpha_full.data(), unknown[0], unknown[1]);
  unit->lambda = s.rls->forgetting();
  unit->max_trace = s.rls->max_trace();
  unit->prev_norm = unit->paper.PrevNorm(s.prev[0], s.prev[1]);
  unit->version = s.version;
  unit->admitted = unit->informative = 0;
  return true;
}

template <int A>
Eigen::Index EndFlowRun(Identifier& id, const FlowRunUnit<A>& unit, const double* xs, Eigen::Index k,
                        Eigen::Index count, const double* phi, const double* y, const Decision* pending,
                        Decision* decisions) {
  IdentifierState& s = IdentifierAccess::Of(id);
  s.rls->Store2(unit.rls);
  s.paper->StoreConstant2(unit.paper);
  if (unit.admitted > 0) {  // as FlowRun's end: samples k − admitted … k − 1 taken
    const int* unknown = s.builder.flow_layout().unknown.data();
    s.rls->CountRowsIn(unit.admitted, unit.informative);
    s.samples += unit.admitted;
    s.version = unit.version;
    s.alpha_full[unknown[0]] = unit.rls.t0;
    s.alpha_full[unknown[1]] = unit.rls.t1;
    s.prev[0] = xs[2 * k - 2];
    s.prev[1] = xs[2 * k - 1];
  }
  if (k == count) return count;
  if (pending == nullptr) return FeedRest(s, xs, k, count, phi, y, decisions);
  if (pending->gamma && s.stop_at_jumps) {
    s.stopped = *pending;
    return k;
  }
  return ApplyAndFeed(s, xs, k, count, phi, y, *pending, decisions);
}

template bool BeginFlowRun<2>(const Identifier&, FlowRunUnit<2>*);
template bool BeginFlowRun<3>(const Identifier&, FlowRunUnit<3>*);
template Eigen::Index EndFlowRun<2>(Identifier&, const FlowRunUnit<2>&, const double*, Eigen::Index,
                                    Eigen::Index, const double*, const double*, const Decision*, Decision*);
template Eigen::Index EndFlowRun<3>(Identifier&, const FlowRunUnit<3>&, const double*, Eigen::Index,
                                    Eigen::Index, const double*, const double*, const Decision*, Decision*);

namespace {

bool SameValues(const Vec& a, const Vec& b) { return a.size() == b.size() && (a.array() == b.array()).all(); }
bool SameValues(const Mat& a, const Mat& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() && (a.array() == b.array()).all();
}
bool SameEstimator(const EstimatorSettings& a, const EstimatorSettings& b) {
  return a.kind == b.kind && a.forgetting == b.forgetting && a.p0 == b.p0 &&
         SameValues(a.prior_scale, b.prior_scale) && a.refactor_every == b.refactor_every &&
         a.window == b.window && a.frisch_box == b.frisch_box && a.frisch_point == b.frisch_point &&
         a.frisch_confidence == b.frisch_confidence && SameValues(a.noise_shape, b.noise_shape);
}
// Every field equal except the detector's r and false_alarm (the thresholds).
bool SameExceptThreshold(const IdentifierSettings& a, const IdentifierSettings& b) {
  return SameEstimator(a.flow_estimator, b.flow_estimator) &&
         SameEstimator(a.jump_estimator, b.jump_estimator) && a.detector.kind == b.detector.kind &&
         a.detector.tau0 == b.detector.tau0 && a.detector.bound == b.detector.bound && a.sets == b.sets &&
         SameValues(a.sigma, b.sigma) && a.data_rtol == b.data_rtol && a.data_atol == b.data_atol &&
         SameValues(a.alpha0, b.alpha0) && SameValues(a.beta0, b.beta0) && a.localize == b.localize &&
         a.second_pass == b.second_pass && a.direct_calls == b.direct_calls;
}

}  // namespace

bool Leads(Identifier& leader, Identifier& twin) {
  IdentifierState& s = IdentifierAccess::Of(leader);
  IdentifierState& t = IdentifierAccess::Of(twin);
  const bool paper = s.paper != nullptr && t.paper != nullptr;
  const bool residual = s.residual != nullptr && t.residual != nullptr;
  if (!(paper || residual) || s.rls == nullptr || t.rls == nullptr || s.prev.size() != 2 ||
      s.builder.flow_layout().unknown.size() != 2 || s.settings.sets || s.frozen || t.frozen ||
      s.dt != t.dt || !SameExceptThreshold(s.settings, t.settings)) {
    return false;
  }
  return paper ? s.settings.detector.r <= t.settings.detector.r : s.residual->ThresholdsBelow(*t.residual);
}

void StopAtJumps(Identifier& id, bool on) { IdentifierAccess::Of(id).stop_at_jumps = on; }
const Decision& Stopped(const Identifier& id) { return IdentifierAccess::Of(id).stopped; }

bool Flags(Identifier& follower, const Identifier& leader, const double* cur) {
  const IdentifierState& l = IdentifierAccess::Of(leader);
  IdentifierState& f = IdentifierAccess::Of(follower);
  if (l.paper != nullptr) {
    return l.paper->FlagsWith(f.settings.detector.r, l.prev.data(), cur, 2, l.dt, l.rls->updates());
  }
  return l.residual->FlagsWith(*f.residual);
}

void AdoptState(Identifier& follower, const Identifier& leader) {
  std::unique_ptr<IdentifierState>& s = IdentifierAccess::Pointer(follower);
  s = std::make_unique<IdentifierState>(IdentifierAccess::Of(leader), s->settings);
  s->stop_at_jumps = false;
}

Eigen::Index FeedRest(Identifier& id, const double* xs, Eigen::Index k, Eigen::Index count, const double* phi,
                      const double* y, Decision* decisions) {
  return FeedRest(IdentifierAccess::Of(id), xs, k, count, phi, y, decisions);
}

Eigen::Index ApplyAndFeed(Identifier& id, const double* xs, Eigen::Index k, Eigen::Index count,
                          const double* phi, const double* y, const Decision& d, Decision* decisions) {
  return ApplyAndFeed(IdentifierAccess::Of(id), xs, k, count, phi, y, d, decisions);
}

}  // namespace hysid::detail
