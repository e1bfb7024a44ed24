// The public Identifier: construction, the per-sample path through the estimator and detector
// interfaces (Step), Feed over blocks (the direct path in core/identify/row_block.cpp), the jump
// update, chains and the second pass's state. Identify's passes: core/identify/identify.cpp.
#include "core/identify/identifier.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

#include <fmt/format.h>

#include "core/identify/identifier_state.hpp"
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

namespace detail {

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

// Settings with the noise shapes filled at the model's default state (Identifier's constructor).
IdentifierSettings ResolvedAtDefault(const Model& m, double dt, const IdentifierSettings& s) {
  if (!s.flow_estimator.NeedsNoiseShape() && !s.jump_estimator.NeedsNoiseShape()) return s;
  if (s.sigma.size() != 0 && s.sigma.size() != m.state_size()) return s;  // reported by IdentifierState
  const Vec sigma = s.sigma.size() ? s.sigma : Vec::Ones(m.state_size());
  return WithNoiseShapes(m, dt, s, sigma, DefaultState(m));
}

IdentifierState::IdentifierState(const Model& m, double step, const IdentifierSettings& s)
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
    throw std::invalid_argument(fmt::format(
        "IdentifierSettings::sigma has {} entries; the model has {} states", s.sigma.size(), m.state_size()));
  }
}
IdentifierState::IdentifierState(const IdentifierState& other, const IdentifierSettings& own)
    : IdentifierValues(other),
      flow(other.flow->Clone()),
      jump(other.jump->Clone()),
      detector(other.detector->CloneWith(own.detector)),
      flow_set(2),
      jump_set(2) {
  settings = own;
  Bind();
}

void IdentifierState::Bind() {
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
      row_block = ChooseRowBlock(*this);
    }
  }
  if (s.direct_calls && builder.jump_layout().rows.size() == 1) {
    jump_rls = dynamic_cast<Rls*>(jump.get());
    jump_row = ChooseJumpRow(static_cast<int>(builder.jump_layout().unknown.size()));
  }
}

// γ = 1: the jump regression (at the located instant when asked and found), β̂, Γ.
void AfterJump(IdentifierState& s, ConstVecRef x, const Vec& alpha_class) {
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

// What the detector sees of sample x after s.prev, with the flow regression (phi: rows × |u|
// column-major, y: rows) already built.
SampleContext SampleContextOf(IdentifierState& s, const double* x, const double* phi, const double* y,
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

}  // namespace detail

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

Identifier::Identifier(const Model& model, double dt, const IdentifierSettings& settings) {
  if (!(dt > 0.0) || !std::isfinite(dt)) {
    throw std::invalid_argument(fmt::format("dt = {}: must be > 0", dt));
  }
  if (!(settings.data_rtol >= 0.0) || !std::isfinite(settings.data_rtol) || !(settings.data_atol >= 0.0) ||
      !std::isfinite(settings.data_atol)) {
    throw std::invalid_argument(fmt::format("data_rtol = {}, data_atol = {}: must be finite and >= 0",
                                            settings.data_rtol, settings.data_atol));
  }
  if (model.input_size() > 0) detail::CheckInputSettings(model, settings);
  s_ = std::make_unique<detail::IdentifierState>(model, dt, detail::ResolvedAtDefault(model, dt, settings));
}
Identifier::~Identifier() = default;
Identifier::Identifier(Identifier&&) noexcept = default;
Identifier& Identifier::operator=(Identifier&&) noexcept = default;

namespace {

// One sample; `given` (may be null) replaces the detector's decision; `at` (may be null without inputs)
// is its context.
Decision Advance(detail::IdentifierState& s, ConstVecRef x, const bool* given, const Context* at) {
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
  const SampleContext c = detail::SampleContextOf(s, x.data(), s.phi.data(), s.y.data(), alpha_class);
  Decision d;
  if (given != nullptr) {
    d.gamma = *given;
  } else {
    d = s.detector->Classify(c);
  }
  if (!d.gamma) {
    s.flow->Update(s.phi, s.y);
    detail::AfterFlowUpdate<0>(s, s.flow->estimate().data());
    if (s.settings.sets) s.flow_set.Add(s.prev);
  } else {
    detail::AfterJump(s, x, alpha_class);
  }
  if (given == nullptr) s.detector->Observe(c, d);
  s.prev = x;
  s.prev_t = s.cur_t;
  s.prev_u.swap(s.cur_u);
  s.prev_mode = s.cur_mode;
  return d;
}

}  // namespace

Decision Identifier::Step(ConstVecRef x) { return Advance(*s_, x, nullptr, nullptr); }

Decision Identifier::Step(ConstVecRef x, bool gamma) { return Advance(*s_, x, &gamma, nullptr); }

Decision Identifier::Step(ConstVecRef x, const Context& at) { return Advance(*s_, x, nullptr, &at); }

Decision Identifier::Step(ConstVecRef x, bool gamma, const Context& at) {
  return Advance(*s_, x, &gamma, &at);
}

void Identifier::Feed(const ConstMatRef& samples, Decision* decisions) {
  Feed(samples, nullptr, nullptr, decisions);
}

void Identifier::Feed(const ConstMatRef& samples, const double* phi, const double* y, Decision* decisions) {
  detail::IdentifierState& s = *s_;
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
    const Eigen::Index len = std::min<Eigen::Index>(detail::kFeedBlock, count - k);
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
  detail::IdentifierState& s = *s_;
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

}  // namespace hysid
