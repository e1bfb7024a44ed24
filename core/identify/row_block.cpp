// The identifier's direct path: one identified flow row estimated by RLS or integral, the paper or the
// residual detector called directly (or the detector's interface), over blocks of samples whose flow
// rows are built; consecutive flow samples as one flow run with the state in local variables. The same
// arithmetic in the same order as the per-sample path (core/identify/identifier.cpp).
#include <optional>
#include <type_traits>

#include "core/identify/identifier_state.hpp"

namespace hysid::detail {
namespace {

// The detector of a row block: through its interface, or called directly.
enum DetectorCall { kInterface, kPaperDirect, kResidualDirect };

// The residual detector's view of a frozen α̂ (a second pass) with two unknowns: their values and
// the frozen covariance's entries, read once per row block.
Row2Estimate FrozenRow2(const Vec& alpha, const int* unknown, const std::optional<Mat>& covariance) {
  Row2Estimate row{.a0 = alpha[unknown[0]], .a1 = alpha[unknown[1]]};
  if (covariance) {
    const double* c = covariance->data();
    row.c00 = c[0];
    row.c10 = c[1];
    row.c01 = c[2];
    row.c11 = c[3];
    row.has_covariance = true;
  }
  return row;
}

// RLS's θ and P (symmetric) as the residual detector reads them.
Row2Estimate Row2Of(const detail::Rls2State& r) {
  return {
      .a0 = r.t0, .a1 = r.t1, .c00 = r.p00, .c10 = r.p10, .c01 = r.p10, .c11 = r.p11, .has_covariance = true};
}

// The residual detector's inputs fixed through a row block: α̂ (bound once), the noise inputs, and in
// a second pass the frozen α̂'s unknowns and covariance as values (kLocal).
struct ResidualInputs {
  ResidualInputs(const IdentifierState& s, Eigen::Index n, bool local)
      : alpha(s.frozen ? s.frozen_alpha : s.alpha_full),
        noise(ResidualNoise::Make(s.settings.sigma.size() ? &s.settings.sigma : nullptr, n,
                                  s.settings.data_rtol, s.settings.data_atol)) {
    if (local && s.frozen) {
      frozen_row = FrozenRow2(s.frozen_alpha, s.builder.flow_layout().unknown.data(), s.frozen_covariance);
    }
  }
  ConstVecRef alpha;
  ResidualNoise noise;
  Row2Estimate frozen_row;
};

// A row block's ResidualInputs, with the residual detector called directly; nothing otherwise (an
// empty std::optional<ResidualInputs> in their place is zeroed at every call, Step's too).
struct NoInputs {};
template <DetectorCall kCall>
[[gnu::always_inline]] inline auto InputsOf(const IdentifierState& s, Eigen::Index n, bool local) {
  if constexpr (kCall == kResidualDirect) {
    return ResidualInputs(s, n, local);
  } else {
    return NoInputs{};
  }
}

// The residual detector's decision on sample x (classified and observed; the update, which Observe
// does not read, comes after, as Context's covariance pointer is taken before it).
template <int N, int P, bool kLocal, class E>
[[gnu::always_inline]] inline Decision ClassifyResidual(IdentifierState& s, E* est, const ResidualInputs& in,
                                                        const Rls2State& local, const double* x,
                                                        Eigen::Index n, double dt, const double* row,
                                                        double yk) {
  if constexpr (kLocal) {
    return s.frozen ? s.residual->ClassifyObserveRow2<N>(s.prev.data(), x, n, dt, row, yk, in.alpha,
                                                         in.frozen_row, -2, s.frozen_updates, in.noise)
                    : s.residual->ClassifyObserveRow2<N>(s.prev.data(), x, n, dt, row, yk, in.alpha,
                                                         Row2Of(local), s.version, est->updates(), in.noise);
  } else {
    const double* cov = s.frozen ? (s.frozen_covariance ? s.frozen_covariance->data() : nullptr)
                                 : est->covariance_matrix()->data();
    return s.residual->ClassifyObserveRow<N, P>(s.prev.data(), x, n, dt, row, yk, in.alpha, cov,
                                                s.frozen ? -2 : s.version,
                                                s.frozen ? s.frozen_updates : est->updates(), in.noise);
  }
}

// Decision d applied to sample x, whose flow row is (row, yk): α̂ updated (γ = 0) or the jump regressed.
template <int P, bool kLocal, class E>
[[gnu::always_inline]] inline void ApplyRow(IdentifierState& s, E* est, Rls2State& local, const Decision& d,
                                            const double* row, double yk, const double* x, Eigen::Index n,
                                            const Vec& alpha_class) {
  ++s.samples;
  if (d.gamma) {
    AfterJump(s, ConstVecMap(x, n), alpha_class);
    return;
  }
  if constexpr (kLocal) {
    est->UpdateRowIn(local, row, yk);
    const double theta[2] = {local.t0, local.t1};
    AfterFlowUpdate<P>(s, theta);
  } else {
    est->template UpdateRow<P>(row, yk);
    AfterFlowUpdate<P>(s, est->estimate().data());
  }
  if (s.settings.sets) s.flow_set.Add(s.prev);
}

// Consecutive flow samples k, k + 1, … of a row block (n = 2, |α| = 2 unknowns, RLS, the paper
// detector; warm-up over, no sets, first pass): the detector's and RLS's state in local variables
// (detail::PaperConstant2, r) and no call in the loop, the same arithmetic as the per-sample path.
// Stops before a sample whose row is not finite, and at a jump or a failed RLS update: that sample's
// decision goes to *pending (*decided = true) for the caller to apply. Returns the sample it stopped
// at (count: the block is done). α̂ changes at every sample of the run, so ‖J̄_r(α̂)‖² is computed at
// each (the same value the per-sample path's cache would hold) and the cache is set once at the end.
// Out of line: inlined into the row block (its one caller), it makes every call of the row block
// dearer (Step feeds one sample per call).
template <int A>
[[gnu::noinline]] Eigen::Index FlowRun(IdentifierState& s, const double* xs, Eigen::Index k,
                                       Eigen::Index count, const double* phi, const double* y,
                                       Decision* decisions, Rls2State& rls, Decision* pending,
                                       bool* decided) {
  Rls2State r = rls;
  const int* unknown = s.builder.flow_layout().unknown.data();
  PaperConstant2<A> c = s.paper->LoadConstant2<A>(s.alpha_full.data(), unknown[0], unknown[1]);
  const double lambda = s.rls->forgetting(), max_trace = s.rls->max_trace(), inv_dt = 1.0 / s.dt;
  double p0 = s.prev[0], p1 = s.prev[1];
  double prev_norm = c.PrevNorm(p0, p1);
  const Eigen::Index first = k;
  long uninformative = 0;  // rows with φ = 0
  for (; k < count; ++k) {
    const double f0 = phi[2 * k], f1 = phi[2 * k + 1], yk = y[k];
    // x − x is 0 for a finite x and NaN otherwise: one test for the three.
    if (!((f0 - f0) + (f1 - f1) + (yk - yk) == 0.0)) break;
    const double c0 = xs[2 * k], c1 = xs[2 * k + 1];
    double cur_norm;
    const Decision d = c.Classify(p0, p1, c0, c1, prev_norm, inv_dt, r.t0, r.t1, &cur_norm);
    if (d.gamma || !r.Update(f0, f1, yk, lambda, max_trace)) {
      *pending = d;
      *decided = true;
      p0 = c0;  // the detector's last pair ends at this sample; s.prev is the caller's
      p1 = c1;
      prev_norm = cur_norm;
      break;
    }
    if (decisions != nullptr) {
      decisions[k].gamma = false;
      decisions[k].statistic = d.statistic;
      decisions[k].threshold = d.threshold;
    }
    if (f0 == 0.0 && f1 == 0.0) ++uninformative;
    prev_norm = cur_norm;
    p0 = c0;
    p1 = c1;
  }
  rls = r;
  const long admitted = static_cast<long>(k - first);
  if (admitted > 0 || *decided) {  // a sample was classified: the detector's state moves on
    c.last_x0 = p0;
    c.last_x1 = p1;
    c.last_norm = prev_norm;
    c.has_last = true;
    c.Cache(s.version + admitted, rls.t0, rls.t1);
    s.paper->StoreConstant2(c);
  }
  if (admitted > 0) {
    s.rls->CountRowsIn(admitted, admitted - uninformative);
    s.samples += admitted;
    s.version += admitted;
    s.alpha_full[unknown[0]] = rls.t0;
    s.alpha_full[unknown[1]] = rls.t1;
    s.prev[0] = xs[2 * (k - 1)];  // the last sample admitted
    s.prev[1] = xs[2 * (k - 1) + 1];
  }
  return k;
}

// One identified row estimated by RLS or integral (E, s.rls or s.integral set), for `count` consecutive
// samples x_k = xs + k·n after s.prev, with their flow regression rows (phi + k·|u|, y[k]) already built.
// kCall: the paper detector on a constant-Jacobian model or the residual detector, called directly
// (s.paper, s.residual), or the detector's interface. N = n and P = |u| when known at compile time (the
// loops unroll), else 0. Returns where it stopped (StopAtJumps: a direct path's jump classified, not
// counted, not applied), else count.
template <int N, int P, DetectorCall kCall, class E>
Eigen::Index RowBlock(IdentifierState& s, const double* xs, Eigen::Index count, const double* phi,
                      const double* y, Decision* decisions) {
  E* est = nullptr;
  if constexpr (std::is_same_v<E, Rls>) {
    est = s.rls;
  } else {
    est = s.integral;
  }
  const Eigen::Index n = N > 0 ? N : s.prev.size();
  const Eigen::Index u = P > 0 ? P : s.phi.cols();
  const double dt = s.dt;  // a local: what the detectors derive from δt is computed once per block
  // RLS with two unknowns beside the paper or the residual detector: θ and P stay in local variables
  // through the block (Rls::Load2, UpdateRowIn, Store2; nothing in the block reads them from the
  // estimator: the residual detector takes them as values, ClassifyObserveRow2).
  constexpr bool kLocal = kCall != kInterface && std::is_same_v<E, Rls> && P == 2;
  [[maybe_unused]] Rls2State local{};
  if constexpr (kLocal) local = est->Load2();
  [[maybe_unused]] const auto inputs = InputsOf<kCall>(s, n, kLocal);
  // A flow run is tried again only after a flow sample of the per-sample path: where most samples are
  // jumps (a small r), runs would end at once. Fewer than kMinFlowRun samples left (Step feeds one):
  // loading and storing the state would cost more than the run saves.
  constexpr Eigen::Index kMinFlowRun = 16;
  [[maybe_unused]] bool try_run = true;
  Eigen::Index stop = count;
  for (Eigen::Index k = 0; k < count; ++k) {
    Decision d;
    bool decided = false;  // d is sample k's decision already (a flow run stopped there)
    if constexpr (kLocal && kCall == kPaperDirect && N == 2) {
      if (try_run && count - k >= kMinFlowRun && s.flow_run && !s.frozen && !s.settings.sets &&
          est->updates() >= s.paper->unknowns()) {
        k = s.alpha_full.size() == 3 ? FlowRun<3>(s, xs, k, count, phi, y, decisions, local, &d, &decided)
                                     : FlowRun<2>(s, xs, k, count, phi, y, decisions, local, &d, &decided);
        if (k == count) break;
        try_run = !decided;
      }
    }
    const double* x = xs + k * n;
    const Vec& alpha_class = s.frozen ? s.frozen_alpha : s.alpha_full;
    if constexpr (kCall == kInterface) {
      const SampleContext c = SampleContextOf(s, x, phi + k * u, y + k, alpha_class);
      d = s.detector->Classify(c);
      ApplyRow<P, kLocal>(s, est, local, d, phi + k * u, y[k], x, n, alpha_class);
      s.detector->Observe(c, d);
    } else {
      if constexpr (kCall == kPaperDirect) {
        if (!decided) {
          d = s.paper->ClassifyConstant<N, true>(s.prev.data(), x, n, dt, alpha_class.data(),
                                                 s.frozen ? -2 : s.version,
                                                 s.frozen ? s.frozen_updates : est->updates());
        }
      } else {
        d = ClassifyResidual<N, P, kLocal>(s, est, inputs, local, x, n, dt, phi + k * u, y[k]);
      }
      if (d.gamma && s.stop_at_jumps) [[unlikely]] {  // StopAtJumps: classified, not counted, not applied
        s.stopped = d;
        stop = k;
        break;
      }
      ApplyRow<P, kLocal>(s, est, local, d, phi + k * u, y[k], x, n, alpha_class);
    }
    if constexpr (kLocal && kCall == kPaperDirect && N == 2) try_run = try_run || !d.gamma;
    for (Eigen::Index i = 0; i < n; ++i) s.prev[i] = x[i];
    if (decisions != nullptr) decisions[k] = d;
  }
  if constexpr (kLocal) est->Store2(local);
  return stop;
}

template <DetectorCall kCall, class E>
RowBlockFn ChooseRowBlockFor(int n, int u) {
  if (n == 2 && u == 2) return &RowBlock<2, 2, kCall, E>;
  if (n == 2 && u == 1) return &RowBlock<2, 1, kCall, E>;
  if (n == 2 && u == 3) return &RowBlock<2, 3, kCall, E>;
  return &RowBlock<0, 0, kCall, E>;
}

template <class E>
RowBlockFn ChooseRowBlockFor(const IdentifierState& s, int n, int u) {
  return s.paper != nullptr      ? ChooseRowBlockFor<kPaperDirect, E>(n, u)
         : s.residual != nullptr ? ChooseRowBlockFor<kResidualDirect, E>(n, u)
                                 : ChooseRowBlockFor<kInterface, E>(n, u);
}

}  // namespace

RowBlockFn ChooseRowBlock(const IdentifierState& s) {
  const int n = s.model.state_size(), u = static_cast<int>(s.builder.flow_layout().unknown.size());
  return s.rls != nullptr ? ChooseRowBlockFor<Rls>(s, n, u) : ChooseRowBlockFor<IntegralLs>(s, n, u);
}

Eigen::Index ApplyAndFeed(IdentifierState& s, const double* xs, Eigen::Index k, Eigen::Index count,
                          const double* phi, const double* y, const Decision& d, Decision* decisions) {
  const double* x = xs + 2 * k;  // RowBlock's per-sample path with the decision taken
  Rls2State unused{};
  ApplyRow<2, false>(s, s.rls, unused, d, phi + 2 * k, y[k], x, 2, s.alpha_full);
  s.prev[0] = x[0];
  s.prev[1] = x[1];
  decisions[k] = d;
  return FeedRest(s, xs, k + 1, count, phi, y, decisions);
}

Eigen::Index FeedRest(IdentifierState& s, const double* xs, Eigen::Index k, Eigen::Index count,
                      const double* phi, const double* y, Decision* decisions) {
  if (k == count) return count;
  return k + s.row_block(s, xs + 2 * k, count - k, phi + 2 * k, y + k, decisions + k);
}

}  // namespace hysid::detail
