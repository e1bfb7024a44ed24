#include "core/identify/identifier.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <type_traits>
#include <utility>

#include <fmt/format.h>

#include "core/detectors/paper.hpp"
#include "core/detectors/residual.hpp"
#include "core/estimators/integral.hpp"
#include "core/estimators/rls.hpp"
#include "core/identify/events.hpp"
#include "core/identify/flow_run_unit.hpp"
#include "core/identify/localize.hpp"
#include "core/identify/self_check.hpp"
#include "core/io/limits.hpp"
#include "core/model/automaton.hpp"
#include "core/model/noise_shape.hpp"

namespace hysid {
namespace {

Vec Prior(const Vec& given, const RegressionLayout& layout, const char* field) {
  const auto u = static_cast<Eigen::Index>(layout.unknown.size());
  if (given.size() == 0) return Vec::Zero(u);
  if (given.size() != u) {
    throw std::invalid_argument(fmt::format(
        "IdentifierSettings::{} has {} entries; the model has {} unknowns", field, given.size(), u));
  }
  return given;
}

// What a model with inputs cannot be identified with: the noise shapes of gtls and frisch and the
// jump localiser integrate or differentiate the flow without the inputs between samples.
void CheckInputSettings(const Model& m, const IdentifierSettings& s) {
  for (const auto& [field, e] :
       {std::pair{"flow_estimator", &s.flow_estimator}, std::pair{"jump_estimator", &s.jump_estimator}}) {
    if (e->NeedsNoiseShape() && e->noise_shape.size() == 0) {
      throw std::invalid_argument(fmt::format(
          "IdentifierSettings::{}: '{}' needs a noise shape, which is not derived for model '{}' with inputs "
          "(give noise_shape, or use rls)",
          field, ToString(e->kind), m.name()));
    }
  }
  if (s.localize) {
    throw std::invalid_argument(
        fmt::format("IdentifierSettings::localize: not available for model '{}' with inputs", m.name()));
  }
}

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

// Settings with the noise shapes filled at the model's default state (Identifier's constructor).
IdentifierSettings ResolvedAtDefault(const Model& m, double dt, const IdentifierSettings& s) {
  if (!s.flow_estimator.NeedsNoiseShape() && !s.jump_estimator.NeedsNoiseShape()) return s;
  if (s.sigma.size() != 0 && s.sigma.size() != m.state_size()) return s;  // reported by State
  const Vec sigma = s.sigma.size() ? s.sigma : Vec::Ones(m.state_size());
  return WithNoiseShapes(m, dt, s, sigma, DefaultState(m));
}

}  // namespace

IdentifierSettings WithNoiseShapes(const Model& model, double dt, const IdentifierSettings& settings,
                                   ConstVecRef sigma, const Mat& states) {
  IdentifierSettings out = settings;
  if (!out.flow_estimator.NeedsNoiseShape() && !out.jump_estimator.NeedsNoiseShape()) return out;
  if (sigma.size() != model.state_size()) {
    throw std::invalid_argument(fmt::format("WithNoiseShapes: sigma has {} entries; the model has {} states",
                                            sigma.size(), model.state_size()));
  }
  const Vec s = sigma.any() ? Vec(sigma) : Vec::Ones(model.state_size());
  auto least_squares_if_zero = [](Mat c) {
    if (!(c.cwiseAbs().maxCoeff() > 0.0)) {
      c.setZero();
      c(c.rows() - 1, c.cols() - 1) = 1.0;
    }
    return c;
  };
  if (out.flow_estimator.NeedsNoiseShape()) {
    out.flow_estimator.noise_shape = least_squares_if_zero(FlowNoiseShape(model, s, dt, states));
  }
  if (out.jump_estimator.NeedsNoiseShape()) {
    out.jump_estimator.noise_shape = least_squares_if_zero(JumpNoiseShape(model, s, states));
  }
  return out;
}

void IdentifierSettings::UseEstimator(EstimatorKind kind) {
  flow_estimator.kind = kind;
  jump_estimator.kind = DescriptorOf(kind).traits.flow_only ? EstimatorKind::kRls : kind;
}

namespace {

// Rls::UpdateRow for P unknowns (0: any), and the one for p unknowns.
template <int P>
void RlsUpdateRow(Rls& rls, const double* phi, double y) {
  rls.UpdateRow<P>(phi, y);
}
void (*ChooseJumpRow(int p))(Rls&, const double*, double) {
  switch (p) {
    case 1: return &RlsUpdateRow<1>;
    case 2: return &RlsUpdateRow<2>;
    case 3: return &RlsUpdateRow<3>;
    default: return &RlsUpdateRow<0>;
  }
}

}  // namespace

namespace {

// The identifier's state that copies as it is (Identifier::State adds the estimators, the detector,
// the sets and the direct calls bound to them).
struct IdentifierValues {
  IdentifierValues(const Model& m, double step, const IdentifierSettings& s)
      : model(m),
        dt(step),
        settings(s),
        builder(m),
        alpha_known(m.alpha()),
        beta_known(m.beta()),
        prev(m.state_size()),
        phi(builder.flow_layout().rows.size(), builder.flow_layout().unknown.size()),
        y(builder.flow_layout().rows.size()),
        psi(builder.jump_layout().rows.size(), builder.jump_layout().unknown.size()),
        yj(builder.jump_layout().rows.size()),
        localizer(m),
        inputs(m.input_size() > 0),
        contextual(inputs || IsAutomaton(m.spec())),
        prev_u(m.input_size()),
        cur_u(m.input_size()) {}

  Model model;
  double dt;
  IdentifierSettings settings;
  RegressionBuilder builder;
  Vec alpha_known, beta_known, alpha_full;
  Vec prev;
  bool has_prev = false;
  Mat phi;
  Vec y;
  Mat psi;
  Vec yj;
  // Feed: the flow regressions of a block of samples (|u| × kFeedBlock rows, kFeedBlock values).
  std::vector<double> block_phi, block_y;
  JumpLocalizer localizer;
  JumpLocation location;
  // Second pass: classification uses these instead of the running estimates.
  bool frozen = false;
  Vec frozen_alpha;
  std::optional<Mat> frozen_covariance;
  long frozen_updates = 0;
  long version = 0;
  long samples = 0;
  long jumps = 0;
  long localized = 0;
  // A model with inputs: the time and u of the previous and the current sample. A hybrid automaton
  // (contextual without inputs too): their modes, and the map of the jump into the current sample.
  bool inputs = false;
  bool contextual = false;
  Vec prev_u, cur_u;
  double prev_t = 0.0, cur_t = 0.0;
  int prev_mode = 0, cur_mode = 0, cur_map = 0;
  // Identifier::StopAtJumps: the direct path stops before it applies a jump, its decision here.
  bool stop_at_jumps = false;
  Decision stopped;
  Context PrevAt() const {
    return {.t = prev_t, .u = inputs ? prev_u.data() : nullptr, .mode = prev_mode, .map = cur_map};
  }
  Context CurAt() const { return {.t = cur_t, .u = inputs ? cur_u.data() : nullptr, .mode = cur_mode, .map = cur_map}; }
};

}  // namespace

struct Identifier::State : IdentifierValues {
  State(const Model& m, double step, const IdentifierSettings& s)
      : IdentifierValues(m, step, s),
        flow(MakeEstimator(s.flow_estimator, Prior(s.alpha0, builder.flow_layout(), "alpha0"))),
        jump(MakeEstimator(s.jump_estimator, Prior(s.beta0, builder.jump_layout(), "beta0"))),
        detector(MakeDetector(s.detector, m)),
        flow_set(s.sets ? m.state_size() : 2),
        jump_set(s.sets ? m.state_size() : 2) {
    alpha_full = builder.flow_layout().Assemble(alpha_known, flow->estimate());
    block_phi.resize(std::size_t(kFeedBlock) * builder.flow_layout().unknown.size());
    block_y.resize(std::size_t(kFeedBlock));
    Bind();
    if (DescriptorOf(s.jump_estimator.kind).traits.flow_only) {
      throw std::invalid_argument(
          fmt::format("jump_estimator: '{}' estimates alpha only (its rows are consecutive flow differences)",
                      ToString(s.jump_estimator.kind)));
    }
    if (s.sigma.size() != 0 && s.sigma.size() != m.state_size()) {
      throw std::invalid_argument(
          fmt::format("IdentifierSettings::sigma has {} entries; the model has {} states", s.sigma.size(),
                      m.state_size()));
    }
  }
  // `other`'s state with `own` settings, which differ from other's in the detector's settings alone
  // (Identifier::AdoptState); no sets (they do not copy).
  State(const State& other, const IdentifierSettings& own)
      : IdentifierValues(other),
        flow(other.flow->Clone()),
        jump(other.jump->Clone()),
        detector(other.detector->CloneWith(own.detector)),
        flow_set(2),
        jump_set(2) {
    settings = own;
    Bind();
  }

  // The common configurations get direct, inlined calls instead of the virtual interfaces: RLS
  // for α on one identified row, and with it the paper detector on a model with a constant flow
  // Jacobian. Same arithmetic in the same order (tests/core/identify/identifier_test.cpp checks
  // bit-equality).
  void Bind() {
    const IdentifierSettings& s = settings;
    const Model& m = model;
    if (s.direct_calls && builder.flow_layout().rows.size() == 1 && !inputs) {
      rls = dynamic_cast<Rls*>(flow.get());
      integral = dynamic_cast<IntegralLs*>(flow.get());
      if (rls != nullptr || integral != nullptr) {
        if (m.spec().flow_jacobian_constant) paper = dynamic_cast<PaperDetector*>(detector.get());
        if (paper != nullptr && !paper->one_row()) paper = nullptr;
        residual = dynamic_cast<ResidualDetector*>(detector.get());
        const std::vector<int>& unknown = builder.flow_layout().unknown;
        flow_run = paper != nullptr && rls != nullptr && m.state_size() == 2 && unknown.size() == 2 &&
                   paper->constant2(static_cast<int>(alpha_full.size()));
        const int u = static_cast<int>(builder.flow_layout().unknown.size());
        row_block = rls != nullptr ? ChooseRowBlock<Rls>(*this, m.state_size(), u)
                                   : ChooseRowBlock<IntegralLs>(*this, m.state_size(), u);
      }
    }
    if (s.direct_calls && builder.jump_layout().rows.size() == 1) {
      jump_rls = dynamic_cast<Rls*>(jump.get());
      jump_row = ChooseJumpRow(static_cast<int>(builder.jump_layout().unknown.size()));
    }
  }

  std::unique_ptr<Estimator> flow, jump;
  std::unique_ptr<JumpDetector> detector;
  SampleSet flow_set, jump_set;
  // The α estimator on one identified row (direct_calls), when it is RLS or integral.
  Rls* rls = nullptr;
  IntegralLs* integral = nullptr;
  // The β estimator on one identified row (direct_calls), when it is RLS.
  Rls* jump_rls = nullptr;
  void (*jump_row)(Rls&, const double*, double) = nullptr;  // its UpdateRow for |u| unknowns
  // With rls or integral: the detector, when it is the paper's (on a constant Jacobian) or the residual
  // detector, and RowBlock for the model's sizes.
  PaperDetector* paper = nullptr;
  ResidualDetector* residual = nullptr;
  RowBlockFn row_block = nullptr;
  bool flow_run = false;  // RowBlock<2, 2, kPaperDirect, Rls> may take runs of flow samples (FlowRun)
};

Identifier::Identifier(const Model& model, double dt, const IdentifierSettings& settings) {
  if (!(dt > 0.0) || !std::isfinite(dt)) {
    throw std::invalid_argument(fmt::format("dt = {}: must be > 0", dt));
  }
  if (!(settings.data_rtol >= 0.0) || !std::isfinite(settings.data_rtol) || !(settings.data_atol >= 0.0) ||
      !std::isfinite(settings.data_atol)) {
    throw std::invalid_argument(fmt::format("data_rtol = {}, data_atol = {}: must be finite and >= 0",
                                            settings.data_rtol, settings.data_atol));
  }
  if (model.input_size() > 0) CheckInputSettings(model, settings);
  s_ = std::make_unique<State>(model, dt, ResolvedAtDefault(model, dt, settings));
}
Identifier::~Identifier() = default;
Identifier::Identifier(Identifier&&) noexcept = default;
Identifier& Identifier::operator=(Identifier&&) noexcept = default;

// γ = 0, after the α estimator's update to θ (its estimate): α̂ and its version (the caller adds
// ξ(t−δt) to Λ).
template <int P>
void Identifier::AfterFlowUpdate(State& s, const double* theta) {
  const int* unknown = s.builder.flow_layout().unknown.data();
  const int u = P > 0 ? P : static_cast<int>(s.builder.flow_layout().unknown.size());
  for (int i = 0; i < u; ++i) s.alpha_full[unknown[i]] = theta[i];
  ++s.version;
}

// γ = 1: the jump regression (at the located instant when asked and found), β̂, Γ.
void Identifier::AfterJump(State& s, ConstVecRef x, const Vec& alpha_class) {
  if (s.contextual) {
    s.builder.Jump(s.prev, x, s.psi, s.yj, s.PrevAt());
  } else if (s.settings.localize && s.localizer.Locate(s.prev, x, s.dt, alpha_class, &s.location)) {
    s.builder.Jump(s.location.pre, s.location.post, s.psi, s.yj);
    ++s.localized;
  } else {
    s.builder.Jump(s.prev, x, s.psi, s.yj);
  }
  if (s.jump_rls != nullptr) {
    s.jump_row(*s.jump_rls, s.psi.data(), s.yj[0]);  // = Update on the one row, without the interface
  } else {
    s.jump->Update(s.psi, s.yj);
  }
  s.flow->Break();
  ++s.jumps;
  if (s.settings.sets) s.jump_set.Add(s.prev);
}

Decision Identifier::Step(ConstVecRef x) { return Advance(x, nullptr, nullptr); }

Decision Identifier::Step(ConstVecRef x, bool gamma) { return Advance(x, &gamma, nullptr); }

Decision Identifier::Step(ConstVecRef x, const Context& at) { return Advance(x, nullptr, &at); }

Decision Identifier::Step(ConstVecRef x, bool gamma, const Context& at) { return Advance(x, &gamma, &at); }

// One sample; `given` (may be null) replaces the detector's decision; `at` (may be null without inputs)
// is its context.
Decision Identifier::Advance(ConstVecRef x, const bool* given, const Context* at) {
  State& s = *s_;
  if (x.size() != s.prev.size()) {
    throw std::invalid_argument(
        fmt::format("Identifier::Step: sample has {} entries; model '{}' has {} states", x.size(),
                    s.model.name(), s.prev.size()));
  }
  if (s.inputs) {
    if (at == nullptr || at->u == nullptr) {
      throw std::invalid_argument(
          fmt::format("Identifier::Step: model '{}' has inputs; each sample needs its context (t and u)",
                      s.model.name()));
    }
    s.cur_t = at->t;
    s.cur_u = Eigen::Map<const Vec>(at->u, s.cur_u.size());
  }
  if (at != nullptr && s.contextual) {
    s.cur_mode = at->mode;
    s.cur_map = at->map;
  }
  if (!s.has_prev) {
    ++s.samples;
    s.prev = x;
    s.has_prev = true;
    s.prev_t = s.cur_t;
    s.prev_u.swap(s.cur_u);
    s.prev_mode = s.cur_mode;
    return {};
  }
  if (s.row_block != nullptr && given == nullptr && (at == nullptr || !s.contextual)) {  // counts the sample
    s.builder.FlowRow(s.prev.data(), x.data(), s.dt, s.phi.data(), s.y.data());
    Decision d;
    if (s.row_block(s, x.data(), 1, s.phi.data(), s.y.data(), &d) != 1) {
      throw std::logic_error("Identifier::Step: stopped at a jump (StopAtJumps is for FeedRest)");
    }
    return d;
  }
  // Several identified rows, another estimator, or given labels: the interfaces throughout.
  ++s.samples;
  if (s.contextual) {
    s.builder.Flow(s.prev, x, s.dt, s.phi, s.y, s.PrevAt(), s.CurAt());
  } else {
    s.builder.Flow(s.prev, x, s.dt, s.phi, s.y);
  }
  const Vec& alpha_class = s.frozen ? s.frozen_alpha : s.alpha_full;
  const SampleContext c = SampleContextOf(s, x.data(), s.phi.data(), s.y.data(), alpha_class);
  Decision d;
  if (given != nullptr) {
    d.gamma = *given;
  } else {
    d = s.detector->Classify(c);
  }
  if (!d.gamma) {
    s.flow->Update(s.phi, s.y);
    AfterFlowUpdate<0>(s, s.flow->estimate().data());
    if (s.settings.sets) s.flow_set.Add(s.prev);
  } else {
    AfterJump(s, x, alpha_class);
  }
  if (given == nullptr) s.detector->Observe(c, d);
  s.prev = x;
  s.prev_t = s.cur_t;
  s.prev_u.swap(s.cur_u);
  s.prev_mode = s.cur_mode;
  return d;
}

// What the detector sees of sample x after s.prev, with the flow regression (phi: rows × |u|
// column-major, y: rows) already built.
SampleContext Identifier::SampleContextOf(State& s, const double* x, const double* phi, const double* y,
                                          const Vec& alpha_class) {
  const Eigen::Index n = s.prev.size(), rows = s.phi.rows(), u = s.phi.cols();
  return SampleContext{.model = &s.model,
                       .dt = s.dt,
                       .prev = ConstVecMap(s.prev.data(), n),
                       .cur = ConstVecMap(x, n),
                       .flow_phi = ConstMatMap(phi, rows, u),
                       .flow_y = ConstVecMap(y, rows),
                       .alpha_hat = ConstVecMap(alpha_class.data(), alpha_class.size()),
                       .alpha_covariance = s.frozen ? (s.frozen_covariance ? &*s.frozen_covariance : nullptr)
                                                    : s.flow->covariance_matrix(),
                       .flow_updates = s.frozen ? s.frozen_updates : s.flow->updates(),
                       .version = s.frozen ? -2 : s.version,
                       .flow_set = s.settings.sets ? &s.flow_set : nullptr,
                       .sigma = s.settings.sigma.size() ? &s.settings.sigma : nullptr,
                       .data_rtol = s.settings.data_rtol,
                       .data_atol = s.settings.data_atol,
                       .at_prev = s.contextual ? s.PrevAt() : Context{},
                       .at_cur = s.contextual ? s.CurAt() : Context{}};
}

// The residual detector's inputs fixed through a row block: α̂ (bound once), the noise inputs, and in
// a second pass the frozen α̂'s unknowns and covariance as values (kLocal).
struct Identifier::ResidualInputs {
  ResidualInputs(const State& s, Eigen::Index n, bool local)
      : alpha(s.frozen ? s.frozen_alpha : s.alpha_full),
        noise(ResidualNoise::Make(s.settings.sigma.size() ? &s.settings.sigma : nullptr, n, s.settings.data_rtol,
                                  s.settings.data_atol)) {
    if (local && s.frozen) {
      frozen_row = FrozenRow2(s.frozen_alpha, s.builder.flow_layout().unknown.data(), s.frozen_covariance);
    }
  }
  ConstVecRef alpha;
  ResidualNoise noise;
  Row2Estimate frozen_row;
};

// The residual detector's decision on sample x (classified and observed; the update, which Observe
// does not read, comes after, as Context's covariance pointer is taken before it).
template <int N, int P, bool kLocal, class E>
Decision Identifier::ClassifyResidual(State& s, E* est, const ResidualInputs& in, const detail::Rls2State& local,
                                      const double* x, Eigen::Index n, double dt, const double* row, double yk) {
  if constexpr (kLocal) {
    return s.frozen ? s.residual->ClassifyObserveRow2<N>(s.prev.data(), x, n, dt, row, yk, in.alpha, in.frozen_row,
                                                         -2, s.frozen_updates, in.noise)
                    : s.residual->ClassifyObserveRow2<N>(s.prev.data(), x, n, dt, row, yk, in.alpha, Row2Of(local),
                                                         s.version, est->updates(), in.noise);
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
void Identifier::ApplyRow(State& s, E* est, detail::Rls2State& local, const Decision& d, const double* row,
                          double yk, const double* x, Eigen::Index n, const Vec& alpha_class) {
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

// One identified row estimated by RLS or integral (E, s.rls or s.integral set), for `count` consecutive
// samples x_k = xs + k·n after s.prev, with their flow regression rows (phi + k·|u|, y[k]) already built.
// kCall: the paper detector on a constant-Jacobian model or the residual detector, called directly
// (s.paper, s.residual), or the detector's interface. N = n and P = |u| when known at compile time (the
// loops unroll), else 0. Returns where it stopped (StopAtJumps: a direct path's jump classified, not
// counted, not applied), else count.
template <int N, int P, Identifier::DetectorCall kCall, class E>
Eigen::Index Identifier::RowBlock(State& s, const double* xs, Eigen::Index count, const double* phi,
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
  [[maybe_unused]] detail::Rls2State local{};
  if constexpr (kLocal) local = est->Load2();
  [[maybe_unused]] std::optional<ResidualInputs> inputs;
  if constexpr (kCall == kResidualDirect) inputs.emplace(s, n, kLocal);
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
        d = ClassifyResidual<N, P, kLocal>(s, est, *inputs, local, x, n, dt, phi + k * u, y[k]);
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

// Consecutive flow samples k, k + 1, … of a row block (n = 2, |α| = 2 unknowns, RLS, the paper
// detector; warm-up over, no sets, first pass): the detector's and RLS's state in local variables
// (detail::PaperConstant2, r) and no call in the loop, the same arithmetic as the per-sample path.
// Stops before a sample whose row is not finite, and at a jump or a failed RLS update: that sample's
// decision goes to *pending (*decided = true) for the caller to apply. Returns the sample it stopped
// at (count: the block is done). α̂ changes at every sample of the run, so ‖J̄_r(α̂)‖² is computed at
// each (the same value the per-sample path's cache would hold) and the cache is set once at the end.
template <int A>
Eigen::Index Identifier::FlowRun(State& s, const double* xs, Eigen::Index k, Eigen::Index count,
                                 const double* phi, const double* y, Decision* decisions,
                                 detail::Rls2State& rls, Decision* pending, bool* decided) {
  detail::Rls2State r = rls;
  const int* unknown = s.builder.flow_layout().unknown.data();
  detail::PaperConstant2<A> c = s.paper->LoadConstant2<A>(s.alpha_full.data(), unknown[0], unknown[1]);
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

template <int A>
bool Identifier::BeginFlowRun(detail::FlowRunUnit<A>* unit) const {
  const State& s = *s_;
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
Eigen::Index Identifier::EndFlowRun(const detail::FlowRunUnit<A>& unit, const double* xs, Eigen::Index k,
                                    Eigen::Index count, const double* phi, const double* y,
                                    const Decision* pending, Decision* decisions) {
  State& s = *s_;
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
  if (pending == nullptr) return FeedRest(xs, k, count, phi, y, decisions);
  if (pending->gamma && s.stop_at_jumps) {
    s.stopped = *pending;
    return k;
  }
  return ApplyAndFeed(xs, k, count, phi, y, *pending, decisions);
}

Eigen::Index Identifier::ApplyAndFeed(const double* xs, Eigen::Index k, Eigen::Index count, const double* phi,
                                      const double* y, const Decision& d, Decision* decisions) {
  State& s = *s_;
  const double* x = xs + 2 * k;  // RowBlock's per-sample path with the decision taken
  detail::Rls2State unused{};
  ApplyRow<2, false>(s, s.rls, unused, d, phi + 2 * k, y[k], x, 2, s.alpha_full);
  s.prev[0] = x[0];
  s.prev[1] = x[1];
  decisions[k] = d;
  return FeedRest(xs, k + 1, count, phi, y, decisions);
}

Eigen::Index Identifier::FeedRest(const double* xs, Eigen::Index k, Eigen::Index count, const double* phi,
                                  const double* y, Decision* decisions) {
  if (k == count) return count;
  return k + s_->row_block(*s_, xs + 2 * k, count - k, phi + 2 * k, y + k, decisions + k);
}

template bool Identifier::BeginFlowRun<2>(detail::FlowRunUnit<2>*) const;
template bool Identifier::BeginFlowRun<3>(detail::FlowRunUnit<3>*) const;
template Eigen::Index Identifier::EndFlowRun<2>(const detail::FlowRunUnit<2>&, const double*, Eigen::Index,
                                                Eigen::Index, const double*, const double*, const Decision*,
                                                Decision*);
template Eigen::Index Identifier::EndFlowRun<3>(const detail::FlowRunUnit<3>&, const double*, Eigen::Index,
                                                Eigen::Index, const double*, const double*, const Decision*,
                                                Decision*);

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

bool Identifier::Leads(Identifier& twin) {
  State& s = *s_;
  State& t = *twin.s_;
  const bool paper = s.paper != nullptr && t.paper != nullptr;
  const bool residual = s.residual != nullptr && t.residual != nullptr;
  if (!(paper || residual) || s.rls == nullptr || t.rls == nullptr || s.prev.size() != 2 ||
      s.builder.flow_layout().unknown.size() != 2 || s.settings.sets || s.frozen || t.frozen ||
      s.dt != t.dt || !SameExceptThreshold(s.settings, t.settings)) {
    return false;
  }
  return paper ? s.settings.detector.r <= t.settings.detector.r : s.residual->ThresholdsBelow(*t.residual);
}

void Identifier::StopAtJumps(bool on) { s_->stop_at_jumps = on; }
const Decision& Identifier::stopped() const { return s_->stopped; }

bool Identifier::Flags(const Identifier& leader, const double* cur) {
  const State& l = *leader.s_;
  if (l.paper != nullptr) {
    return l.paper->FlagsWith(s_->settings.detector.r, l.prev.data(), cur, 2, l.dt, l.rls->updates());
  }
  return l.residual->FlagsWith(*s_->residual);
}

void Identifier::AdoptState(const Identifier& leader) {
  s_ = std::make_unique<State>(*leader.s_, s_->settings);
  s_->stop_at_jumps = false;
}

template <Identifier::DetectorCall kCall, class E>
Identifier::RowBlockFn Identifier::ChooseRowBlock(int n, int u) {
  if (n == 2 && u == 2) return &RowBlock<2, 2, kCall, E>;
  if (n == 2 && u == 1) return &RowBlock<2, 1, kCall, E>;
  if (n == 2 && u == 3) return &RowBlock<2, 3, kCall, E>;
  return &RowBlock<0, 0, kCall, E>;
}

template <class E>
Identifier::RowBlockFn Identifier::ChooseRowBlock(const State& s, int n, int u) {
  return s.paper != nullptr      ? ChooseRowBlock<kPaperDirect, E>(n, u)
         : s.residual != nullptr ? ChooseRowBlock<kResidualDirect, E>(n, u)
                                 : ChooseRowBlock<kInterface, E>(n, u);
}

void Identifier::Feed(const ConstMatRef& samples, Decision* decisions) {
  Feed(samples, nullptr, nullptr, decisions);
}

void Identifier::Feed(const ConstMatRef& samples, const double* phi, const double* y, Decision* decisions) {
  State& s = *s_;
  const Eigen::Index n = s.prev.size(), count = samples.cols();
  if (samples.rows() != n) {
    throw std::invalid_argument(
        fmt::format("Identifier::Feed: samples have {} rows; model '{}' has {} states", samples.rows(),
                    s.model.name(), n));
  }
  if (s.inputs) {
    throw std::invalid_argument(
        fmt::format("Identifier::Feed: model '{}' has inputs; feed its samples with Step and their contexts",
                    s.model.name()));
  }
  Eigen::Index k = 0;
  auto step = [&](Eigen::Index col) {
    const Decision d = Step(samples.col(col));
    if (decisions != nullptr) decisions[col] = d;
  };
  if (s.row_block == nullptr || (count > 1 && samples.outerStride() != n)) {
    for (; k < count; ++k) step(k);
    return;
  }
  if (!s.has_prev && k < count) step(k++);
  const auto u = static_cast<Eigen::Index>(s.builder.flow_layout().unknown.size());
  while (k < count) {
    const Eigen::Index len = std::min<Eigen::Index>(kFeedBlock, count - k);
    const double* block_phi = phi != nullptr ? phi + k * u : s.block_phi.data();
    const double* block_y = y != nullptr ? y + k : s.block_y.data();
    if (phi == nullptr) {
      s.builder.FlowRows(s.prev.data(), samples.col(k).data(), len, s.dt, s.block_phi.data(),
                         s.block_y.data());
    }
    if (s.row_block(s, samples.col(k).data(), len, block_phi, block_y,
                    decisions == nullptr ? nullptr : decisions + k) != len) {
      throw std::logic_error("Identifier::Feed: stopped at a jump (StopAtJumps is for FeedRest)");
    }
    k += len;
  }
}

FlowRows BuildFlowRows(const Model& model, const Mat& y, double dt) {
  FlowRows rows;
  rows.samples = y.data();
  rows.count = y.cols();
  rows.dt = dt;
  RegressionBuilder builder(model);
  if (builder.flow_layout().rows.size() != 1 || model.input_size() > 0 || y.cols() < 2) return rows;
  const std::size_t u = builder.flow_layout().unknown.size();
  const auto count = static_cast<std::size_t>(y.cols());
  rows.phi.assign(count * u, 0.0);
  rows.y.assign(count, 0.0);
  builder.FlowRows(y.col(0).data(), y.col(1).data(), y.cols() - 1, dt, rows.phi.data() + u,
                   rows.y.data() + 1);
  return rows;
}

void Identifier::Finish() {
  if (s_->has_prev && s_->settings.sets) s_->flow_set.Add(s_->prev);
}

void Identifier::Restart() {
  Finish();
  s_->flow->Break();  // estimators on consecutive rows (integral) do not join rows across the break
  s_->has_prev = false;
}

void Identifier::SetStep(double dt) {
  if (!(dt > 0.0) || !std::isfinite(dt)) throw std::invalid_argument(fmt::format("dt = {}: must be > 0", dt));
  s_->dt = dt;
}

void Identifier::BeginSecondPass() {
  State& s = *s_;
  s.frozen = true;
  s.frozen_alpha = s.alpha_full;
  const Mat* covariance = s.flow->covariance_matrix();
  s.frozen_covariance = covariance ? std::optional<Mat>(*covariance) : std::nullopt;
  s.frozen_updates = s.flow->updates();
  s.flow->Reset();
  s.jump->Reset();
  s.alpha_full = s.builder.flow_layout().Assemble(s.alpha_known, s.flow->estimate());
  ++s.version;
  s.flow_set = SampleSet(s.settings.sets ? s.model.state_size() : 2);
  s.jump_set = SampleSet(s.settings.sets ? s.model.state_size() : 2);
  s.has_prev = false;
  s.samples = 0;
  s.jumps = 0;
  s.localized = 0;
}

Vec Identifier::alpha_hat() const { return s_->alpha_full; }
Vec Identifier::beta_hat() const {
  return s_->builder.jump_layout().Assemble(s_->beta_known, s_->jump->estimate());
}
const Estimator& Identifier::flow_estimator() const { return *s_->flow; }
const Estimator& Identifier::jump_estimator() const { return *s_->jump; }
const SampleSet& Identifier::flow_set() const { return s_->flow_set; }
const SampleSet& Identifier::jump_set() const { return s_->jump_set; }
long Identifier::samples() const { return s_->samples; }
long Identifier::jumps_detected() const { return s_->jumps; }
long Identifier::jumps_localized() const { return s_->localized; }

namespace {

// gtls / frisch without a noise shape: σ given or estimated from y, C averaged over up to 256 evenly
// spaced measured states (too short or non-finite data: the Identifier constructor's rule). Records
// σ and the shapes in r.
IdentifierSettings ResolveNoiseShapes(const Model& model, const Mat& y, double dt,
                                      const IdentifierSettings& settings, IdentifyResult* r) {
  IdentifierSettings resolved = settings;
  if (settings.flow_estimator.NeedsNoiseShape() || settings.jump_estimator.NeedsNoiseShape()) {
    const bool given = settings.sigma.size() != 0;
    if (given && settings.sigma.size() != model.state_size()) {
      throw std::invalid_argument(
          fmt::format("IdentifierSettings::sigma has {} entries; the model has {} states",
                      settings.sigma.size(), model.state_size()));
    }
    if (y.cols() >= 4 && y.allFinite()) {
      r->noise_sigma = given ? settings.sigma : EstimateNoiseSigma(y);
      r->noise_sigma_estimated = !given;
      const Eigen::Index count = std::min<Eigen::Index>(256, y.cols());
      Mat states(y.rows(), count);
      for (Eigen::Index i = 0; i < count; ++i) {
        states.col(i) = y.col(count > 1 ? i * (y.cols() - 1) / (count - 1) : 0);
      }
      resolved = WithNoiseShapes(model, dt, settings, r->noise_sigma, states);
    } else {
      r->noise_sigma = given ? settings.sigma : Vec::Ones(model.state_size());
      resolved = ResolvedAtDefault(model, dt, settings);
    }
  }
  if (DescriptorOf(resolved.flow_estimator.kind).traits.needs_noise_shape) {
    r->flow_noise_shape = resolved.flow_estimator.noise_shape;
  }
  if (DescriptorOf(resolved.jump_estimator.kind).traits.needs_noise_shape) {
    r->jump_noise_shape = resolved.jump_estimator.noise_shape;
  }
  return resolved;
}

// Sample k's context: t_k (times, else kδt), column k of the inputs (a model with inputs), and its
// mode and the map of a jump into it (IdentifyOptions::modes, maps; else 0).
Context SampleAt(const IdentifyOptions& options, double dt, Eigen::Index k) {
  const auto u = static_cast<std::size_t>(k);
  return {.t = options.times.empty() ? static_cast<double>(k) * dt : options.times[u],
          .u = options.inputs.rows() > 0 ? options.inputs.col(k).data() : nullptr,
          .mode = options.modes.empty() ? 0 : options.modes[u],
          .map = options.maps.empty() ? 0 : options.maps[u]};
}

// The RMS of each unknown's flow (jump) regression column over up to 256 evenly spaced pairs of
// consecutive finite samples of y (flow rows at step dt); 1 for a column that is zero there. Scales
// with the data: a column in units of ξ·δt gets its RMS in those units.
void RegressorScales(const Model& model, const Mat& y, double dt, const IdentifyOptions& options, Vec* flow,
                     Vec* jump) {
  RegressionBuilder builder(model);
  const RegressionLayout& fl = builder.flow_layout();
  const RegressionLayout& jl = builder.jump_layout();
  Mat phi(fl.rows.size(), fl.unknown.size()), psi(jl.rows.size(), jl.unknown.size());
  Vec fy(fl.rows.size()), jy(jl.rows.size());
  Vec f2 = Vec::Zero(phi.cols()), j2 = Vec::Zero(psi.cols());
  double f_rows = 0.0, j_rows = 0.0;
  const Eigen::Index pairs = y.cols() - 1, count = std::min<Eigen::Index>(256, pairs);
  for (Eigen::Index i = 0; i < count; ++i) {
    const Eigen::Index k = 1 + (count > 1 ? i * (pairs - 1) / (count - 1) : 0);
    if (!y.col(k - 1).allFinite() || !y.col(k).allFinite()) continue;
    if (model.input_size() > 0) {
      const Context before = SampleAt(options, dt, k - 1), after = SampleAt(options, dt, k);
      builder.Flow(y.col(k - 1), y.col(k), dt, phi, fy, before, after);
      builder.Jump(y.col(k - 1), y.col(k), psi, jy, before);
    } else {
      builder.Flow(y.col(k - 1), y.col(k), dt, phi, fy);
      builder.Jump(y.col(k - 1), y.col(k), psi, jy);
    }
    if (phi.allFinite()) {
      f2 += phi.colwise().squaredNorm().transpose();
      f_rows += static_cast<double>(phi.rows());
    }
    if (psi.allFinite()) {
      j2 += psi.colwise().squaredNorm().transpose();
      j_rows += static_cast<double>(psi.rows());
    }
  }
  auto rms = [](const Vec& sum, double rows) {
    Vec g = (sum / std::max(rows, 1.0)).cwiseSqrt();
    for (double& v : g) v = v > 0.0 && std::isfinite(v) ? v : 1.0;
    return g;
  };
  *flow = rms(f2, f_rows);
  *jump = rms(j2, j_rows);
}

// Empty prior scales of the estimators filled from the data (RegressorScales).
IdentifierSettings WithPriorScales(const Model& model, const Mat& y, double dt,
                                   const IdentifyOptions& options, IdentifierSettings s) {
  if (y.cols() < 2 || (s.flow_estimator.prior_scale.size() && s.jump_estimator.prior_scale.size())) return s;
  Vec flow, jump;
  RegressorScales(model, y, dt, options, &flow, &jump);
  if (s.flow_estimator.prior_scale.size() == 0) s.flow_estimator.prior_scale = flow;
  if (s.jump_estimator.prior_scale.size() == 0) s.jump_estimator.prior_scale = jump;
  return s;
}

void Record(Eigen::Index k, const Decision& d, IdentifyResult* r) {
  r->gamma[static_cast<std::size_t>(k)] = d.gamma ? 1 : 0;
  if (r->statistic.empty()) return;  // IdentifyOptions::statistics off
  r->statistic[static_cast<std::size_t>(k)] = d.statistic;
  r->threshold[static_cast<std::size_t>(k)] = d.threshold;
}

// Whether every entry is finite: 0·v is 0 for a finite v and NaN for ±inf or NaN, and Eigen sums
// with vector instructions (its allFinite stops at the first non-finite entry, one entry at a time).
bool AllFinite(const Mat& y) { return (y.array() * 0.0).sum() == 0.0; }

// Irregular sampling, chains or non-finite columns: one Step per sample, with its own δt and a
// Restart at each chain start.
bool NeedsChains(const Mat& y, const IdentifyOptions& options) {
  return !options.times.empty() || !options.chain_start.empty() || options.inputs.rows() > 0 ||
         !options.modes.empty() || !AllFinite(y);
}

// Sample k fed with its label when given, and its context when there are inputs.
Decision StepAt(Identifier& id, const Mat& y, double dt, const IdentifyOptions& options, Eigen::Index k) {
  const bool labelled = !options.labels.empty();
  const bool gamma = labelled && options.labels[static_cast<std::size_t>(k)] != 0;
  if (options.inputs.rows() > 0 || !options.modes.empty()) {
    const Context at = SampleAt(options, dt, k);
    return labelled ? id.Step(y.col(k), gamma, at) : id.Step(y.col(k), at);
  }
  return labelled ? id.Step(y.col(k), gamma) : id.Step(y.col(k));
}

bool StopRaised(const IdentifyOptions& options) {
  return options.stop != nullptr && options.stop->load(std::memory_order_relaxed);
}

// Samples between two looks at IdentifyOptions::stop: fewer when hulls of n ≥ 3 states are built.
Eigen::Index StopPoll(bool sets, Eigen::Index n) {
  return sets && n >= 3 ? IdentifyOptions::kStopPollSamples / 16 : IdentifyOptions::kStopPollSamples;
}

// A column with a non-finite entry is a missing sample: skipped, and the chain goes on (the next pair
// spans it, its step from the last sample fed: times, else the count of steps of δt). False when
// stopped (IdentifyOptions::stop).
bool ChainPass(Identifier& id, const Mat& y, double dt, const IdentifyOptions& options, Eigen::Index poll,
               IdentifyResult* r) {
  r->skipped_samples = 0;
  r->chains = 0;
  bool open = false;
  Eigen::Index last = -1;  // the last sample fed in the open chain
  for (Eigen::Index k = 0; k < y.cols(); ++k) {
    const auto u = static_cast<std::size_t>(k);
    if (k % poll == 0 && StopRaised(options)) return false;
    if (!options.chain_start.empty() && options.chain_start[u] && open) {
      id.Restart();
      open = false;
    }
    if (!y.col(k).allFinite()) {
      ++r->skipped_samples;
      Record(k, Decision{}, r);
    } else {
      if (open) {
        id.SetStep(options.times.empty() ? static_cast<double>(k - last) * dt
                                         : options.times[u] - options.times[static_cast<std::size_t>(last)]);
      }
      r->chains += open ? 0 : 1;
      open = true;
      last = k;
      Record(k, StepAt(id, y, dt, options, k), r);
    }
    if (!options.trace) continue;
    r->alpha_trace.col(k) = id.alpha_hat();
    r->beta_trace.col(k) = id.beta_hat();
  }
  return true;
}

// One pass over the samples. Without a trace or labels, samples go to Feed in chunks (its block
// path); a trace needs α̂, β̂ after each sample, labels a Step with each. Looks at
// IdentifyOptions::stop every `poll` samples; false when stopped.
bool Pass(Identifier& id, const Mat& y, double dt, const IdentifyOptions& options, Eigen::Index poll,
          IdentifyResult* r) {
  if (NeedsChains(y, options)) return ChainPass(id, y, dt, options, poll, r);
  const Eigen::Index count = y.cols();
  if (!options.trace && options.labels.empty()) {
    std::vector<Decision> decisions(static_cast<std::size_t>(std::min(poll, count)));
    const FlowRows* rows =
        options.flow_rows != nullptr && !options.flow_rows->empty() ? options.flow_rows : nullptr;
    const Eigen::Index u = rows != nullptr ? static_cast<Eigen::Index>(rows->phi.size()) / count : 0;
    for (Eigen::Index k = 0; k < count; k += poll) {
      if (StopRaised(options)) return false;
      const Eigen::Index len = std::min(poll, count - k);
      if (rows != nullptr) {
        id.Feed(y.middleCols(k, len), rows->phi.data() + k * u, rows->y.data() + k, decisions.data());
      } else {
        id.Feed(y.middleCols(k, len), decisions.data());
      }
      for (Eigen::Index j = 0; j < len; ++j) Record(k + j, decisions[static_cast<std::size_t>(j)], r);
    }
    return true;
  }
  for (Eigen::Index k = 0; k < count; ++k) {
    if (k % poll == 0 && StopRaised(options)) return false;
    Record(
        k,
        options.labels.empty() ? id.Step(y.col(k)) : id.Step(y.col(k), options.labels[std::size_t(k)] != 0),
        r);
    if (!options.trace) continue;
    r->alpha_trace.col(k) = id.alpha_hat();
    r->beta_trace.col(k) = id.beta_hat();
  }
  return true;
}

// The second pass: records the first pass's outcome, re-runs, counts the changed classes. False when
// stopped.
bool SecondPass(Identifier& id, const Mat& y, double dt, const IdentifyOptions& options, Eigen::Index poll,
                IdentifyResult* r) {
  r->second_pass = true;
  r->first_pass_gamma = r->gamma;
  r->first_pass_alpha_hat = id.alpha_hat();
  r->first_pass_beta_hat = id.beta_hat();
  id.BeginSecondPass();
  if (!Pass(id, y, dt, options, poll, r)) return false;
  for (std::size_t k = 0; k < r->gamma.size(); ++k) {
    r->reclassified_to_jump += (!r->first_pass_gamma[k] && r->gamma[k]) ? 1 : 0;
    r->reclassified_to_flow += (r->first_pass_gamma[k] && !r->gamma[k]) ? 1 : 0;
  }
  return true;
}

// IdentifyOptions::stop was raised: not ok, whatever the estimates.
void MarkStopped(IdentifyResult* r) {
  r->stopped = true;
  r->flow_status = r->jump_status = EstimatorStatus::kNotExcited;
  r->flow_reason = r->jump_reason = "stopped";
}

// The hulls' vertices and volumes, looking at IdentifyOptions::stop while the n ≥ 3 hulls are finished
// (their boundary can have many facets); false, with no hulls, when stopped.
bool CollectHulls(const Identifier& id, const std::atomic<bool>* stop, IdentifyResult* r) {
  std::optional<Mat> flow = id.flow_set().vertices(stop);
  std::optional<Mat> jump = flow ? id.jump_set().vertices(stop) : std::nullopt;
  const std::optional<double> flow_volume = jump ? id.flow_set().Volume(stop) : std::nullopt;
  const std::optional<double> jump_volume = flow_volume ? id.jump_set().Volume(stop) : std::nullopt;
  if (!jump_volume) return false;
  r->flow_hull = std::move(*flow);
  r->jump_hull = std::move(*jump);
  r->flow_hull_volume = *flow_volume;
  r->jump_hull_volume = *jump_volume;
  return true;
}

// IdentifyOptions::flow_rows, when given, were built from these samples.
void CheckFlowRows(const IdentifyOptions& options, const Mat& y, double dt) {
  const FlowRows* rows = options.flow_rows;
  if (rows == nullptr || (rows->samples == y.data() && rows->count == y.cols() && rows->dt == dt)) return;
  throw std::invalid_argument(
      fmt::format("IdentifyOptions::flow_rows were built from {} samples at dt = {:g} of another matrix than "
                  "the {} samples at dt = {:g} given",
                  rows->count, rows->dt, y.cols(), dt));
}

// The final estimates, statuses, boxes and hulls; false when stopped while the hulls were finished.
bool Collect(Identifier& id, bool sets, const std::atomic<bool>* stop, IdentifyResult* r) {
  id.Finish();
  r->jumps_localized = id.jumps_localized();
  r->alpha_hat = id.alpha_hat();
  r->beta_hat = id.beta_hat();
  r->jumps_detected = id.jumps_detected();
  r->flow_status = id.flow_estimator().status();
  r->jump_status = id.jump_estimator().status();
  r->flow_reason = id.flow_estimator().reason();
  r->jump_reason = id.jump_estimator().reason();
  r->flow_box = id.flow_estimator().solution_box();
  r->jump_box = id.jump_estimator().solution_box();
  return !sets || CollectHulls(id, stop, r);
}

// The paper detector's bound checked for the whole flow at the final α̂ (CheckPaperBound), over at
// most 1024 samples spread over the run: when it cannot hold, the detected jumps include flow
// samples and the jump estimate is not ok.
void CheckDetectorBound(const Model& model, const Mat& y, const IdentifierSettings& settings,
                        IdentifyResult* r) {
  if (r->flow_status != EstimatorStatus::kOk) {  // α̂ is the prior: say why when the warm-up never ended
    if (r->flow_reason.empty() && r->jumps_detected + 1 >= y.cols()) {
      r->flow_reason = fmt::format(
          "the paper detector took every sample for a jump: its bound stays tau0 = {:g} until alpha has "
          "flow samples, and D_dt xi of these data is above it (their scale? set tau0 above D)",
          settings.detector.tau0);
    }
    return;
  }
  const Eigen::Index stride = std::max<Eigen::Index>(1, y.cols() / 1024);
  std::vector<Eigen::Index> columns;
  for (Eigen::Index k = 0; k < y.cols(); k += stride) {
    if (y.col(k).allFinite()) columns.push_back(k);
  }
  Mat points(y.rows(), static_cast<Eigen::Index>(columns.size()));
  for (std::size_t i = 0; i < columns.size(); ++i) points.col(static_cast<Eigen::Index>(i)) = y.col(columns[i]);
  const std::string why = CheckPaperBound(model, r->alpha_hat, settings.detector, points);
  if (why.empty() || r->jump_status != EstimatorStatus::kOk) return;
  r->jump_status = EstimatorStatus::kIllConditioned;
  r->jump_reason = why;
}

}  // namespace

namespace {

// Identify's checks of the data and the options against the model.
void CheckIdentifyInputs(const Model& model, const Mat& y, double dt, const IdentifyOptions& options) {
  if (y.rows() != model.state_size()) {
    throw std::invalid_argument(fmt::format("data has {} state rows; model '{}' has {} states", y.rows(),
                                            model.name(), model.state_size()));
  }
  if (!options.labels.empty() && static_cast<Eigen::Index>(options.labels.size()) != y.cols()) {
    throw std::invalid_argument(fmt::format("IdentifyOptions::labels has {} entries; the data has {} samples",
                                            options.labels.size(), y.cols()));
  }
  if (options.inputs.rows() != model.input_size() ||
      (model.input_size() > 0 && (options.inputs.cols() != y.cols() || !options.inputs.allFinite()))) {
    throw std::invalid_argument(fmt::format(
        "IdentifyOptions::inputs is {} × {}{}; model '{}' has {} inputs and the data {} samples",
        options.inputs.rows(), options.inputs.cols(), options.inputs.allFinite() ? "" : " (not finite)",
        model.name(), model.input_size(), y.cols()));
  }
  for (const auto& [what, size] :
       {std::pair{"times", options.times.size()}, std::pair{"chain_start", options.chain_start.size()},
        std::pair{"modes", options.modes.size()}, std::pair{"maps", options.maps.size()}}) {
    if (size != 0 && static_cast<Eigen::Index>(size) != y.cols()) {
      throw std::invalid_argument(
          fmt::format("IdentifyOptions::{} has {} entries; the data has {} samples", what, size, y.cols()));
    }
  }
  CheckFlowRows(options, y, dt);
}

// The identifier of Identify's pass (the hulls within their dimension limit, the noise shapes and
// prior scales from the data), and *r sized for the pass.
Identifier PassIdentifier(const Model& model, const Mat& y, double dt, const IdentifierSettings& settings,
                          const IdentifyOptions& options, IdentifyResult* r) {
  IdentifierSettings bounded = settings;  // the exact hulls within their dimension limit
  if (const std::int64_t max = LimitValue(kMaxHullDimension); settings.sets && model.state_size() > max) {
    bounded.sets = false;
    r->sets_skipped = fmt::format("{} states exceed the limit of {} {} (raise it with {}=N)",
                                  model.state_size(), max, kMaxHullDimension.what, kMaxHullDimension.variable);
  }
  if (model.input_size() > 0) CheckInputSettings(model, bounded);  // before the noise shapes
  Identifier id(model, dt,
                WithPriorScales(model, y, dt, options, ResolveNoiseShapes(model, y, dt, bounded, r)));
  const auto count = static_cast<std::size_t>(y.cols());
  r->gamma.resize(count);
  if (options.statistics) {
    r->statistic.resize(count);
    r->threshold.resize(count);
  }
  if (options.trace) {
    r->alpha_trace.resize(model.alpha_size(), y.cols());
    r->beta_trace.resize(model.beta_size(), y.cols());
  }
  return id;
}

// Whether the pass builds hulls (IdentifierSettings::sets within the dimension limit).
bool PassSets(const IdentifierSettings& settings, const IdentifyResult& r) {
  return settings.sets && r.sets_skipped.empty();
}

}  // namespace

IdentifyResult Identify(const Model& model, const Mat& y, double dt, const IdentifierSettings& settings,
                        const IdentifyOptions& options) {
  CheckIdentifyInputs(model, y, dt, options);
  if (options.assign_events && IsAutomaton(model.spec())) {
    if (options.flow_rows == nullptr) return IdentifyAutomaton(model, y, dt, settings, options);
    IdentifyOptions own = options;  // its passes identify other models (one per mode) on these samples
    own.flow_rows = nullptr;
    return IdentifyAutomaton(model, y, dt, settings, own);
  }
  IdentifyResult r;
  Identifier id = PassIdentifier(model, y, dt, settings, options, &r);
  const Eigen::Index poll = StopPoll(PassSets(settings, r), model.state_size());
  const bool completed = Pass(id, y, dt, options, poll, &r) &&
                         (!settings.second_pass || SecondPass(id, y, dt, options, poll, &r));
  detail::FinishIdentify(model, y, dt, settings, options, id, completed, &r);
  return r;
}

namespace detail {

bool PassInBlocks(const Model& model, const Mat& y, const IdentifyOptions& options) {
  return !(options.assign_events && IsAutomaton(model.spec())) && !NeedsChains(y, options) && !options.trace &&
         options.labels.empty();
}

Identifier StartIdentify(const Model& model, const Mat& y, double dt, const IdentifierSettings& settings,
                         const IdentifyOptions& options, IdentifyResult* r) {
  CheckIdentifyInputs(model, y, dt, options);
  return PassIdentifier(model, y, dt, settings, options, r);
}

void FinishIdentify(const Model& model, const Mat& y, double dt, const IdentifierSettings& settings,
                    const IdentifyOptions& options, Identifier& id, bool completed, IdentifyResult* r) {
  if (!completed) {
    r->alpha_hat = id.alpha_hat();  // of the samples seen
    r->beta_hat = id.beta_hat();
    r->jumps_detected = id.jumps_detected();
    MarkStopped(r);
    return;
  }
  if (!Collect(id, PassSets(settings, *r), options.stop, r)) {
    MarkStopped(r);
    return;
  }
  if (options.check_paper_bound && options.labels.empty() && settings.detector.kind == DetectorKind::kPaper)
    CheckDetectorBound(model, y, settings, r);
  if (r->flow_status != EstimatorStatus::kOk && settings.flow_estimator.kind != EstimatorKind::kRls) {
    IdentifierSettings safe = settings;
    safe.flow_estimator.kind = EstimatorKind::kRls;
    r->safe_start = std::make_shared<const IdentifyResult>(Identify(model, y, dt, safe, options));
    if (r->safe_start->stopped) MarkStopped(r);
    r->safe_start_reason =
        fmt::format("the {} estimate of alpha is {}{}{}; the refinement starts from rls (alpha {})",
                    ToString(settings.flow_estimator.kind), ToString(r->flow_status),
                    r->flow_reason.empty() ? "" : ": ", r->flow_reason, ToString(r->safe_start->flow_status));
  }
  if (r->flow_status == EstimatorStatus::kOk &&
      options.check_residuals) {  // after the safe start: not its cause
    std::string why = CheckFlowResiduals(model, y, dt, settings, options, *r);
    if (!why.empty()) {
      r->flow_status = EstimatorStatus::kInconsistent;
      r->flow_reason = std::move(why);
    }
  }
}

}  // namespace detail

const IdentifyResult& RefinementStart(const IdentifyResult& recursive) {
  return recursive.safe_start ? *recursive.safe_start : recursive;
}

}  // namespace hysid
