#include "sim/sensitivity/sensitivity.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <set>
#include <stdexcept>

#include <cvodes/cvodes.h>
#include <fmt/format.h>

#include "sim/hybrid_run.hpp"

namespace hysid {

Unknowns Unknowns::Of(const Model& model, bool with_x0) {
  Unknowns u;
  const ModelSpec& spec = model.spec();
  for (std::size_t i = 0; i < spec.alpha.size(); ++i) {
    if (!spec.alpha[i].known) u.alpha.push_back(static_cast<int>(i));
  }
  for (std::size_t i = 0; i < spec.beta.size(); ++i) {
    if (!spec.beta[i].known) u.beta.push_back(static_cast<int>(i));
  }
  for (std::size_t i = 0; i < spec.guard_params.size(); ++i) {
    if (!spec.guard_params[i].known) u.gamma.push_back(static_cast<int>(i));
  }
  u.x0 = with_x0;
  return u;
}

std::vector<std::string> Unknowns::Names(const Model& model) const {
  const ModelSpec& spec = model.spec();
  std::vector<std::string> names;
  for (int i : alpha) names.push_back(spec.alpha[static_cast<std::size_t>(i)].name);
  for (int i : beta) names.push_back(spec.beta[static_cast<std::size_t>(i)].name);
  for (int i : gamma) names.push_back(spec.guard_params[static_cast<std::size_t>(i)].name);
  if (x0) {
    for (const std::string& s : spec.state_names) names.push_back(fmt::format("x0[{}]", s));
  }
  return names;
}

std::vector<const Parameter*> Unknowns::Parameters(const Model& model) const {
  const ModelSpec& spec = model.spec();
  std::vector<const Parameter*> out;
  for (int i : alpha) out.push_back(&spec.alpha[static_cast<std::size_t>(i)]);
  for (int i : beta) out.push_back(&spec.beta[static_cast<std::size_t>(i)]);
  for (int i : gamma) out.push_back(&spec.guard_params[static_cast<std::size_t>(i)]);
  return out;
}

bool Unknowns::IsValid(const Model& model, std::string* error) const {
  auto check = [&](const std::vector<int>& idx, int size, const char* field) {
    std::set<int> seen;
    for (int i : idx) {
      if (i < 0 || i >= size || !seen.insert(i).second) {
        if (error) {
          *error = fmt::format(
              "Unknowns::{} has index {}. Violated constraint: distinct indices in "
              "[0, {})",
              field, i, size);
        }
        return false;
      }
    }
    return true;
  };
  return check(alpha, model.alpha_size(), "alpha") && check(beta, model.beta_size(), "beta") &&
         check(gamma, model.gamma_size(), "gamma");
}

namespace {

void RequireGamma(const Unknowns& u, const Vec& gamma) {
  for (int i : u.gamma) {
    if (i >= gamma.size()) {
      throw std::logic_error(
          fmt::format("HybridParameters::gamma has {} entries; Unknowns::gamma names entry {}", gamma.size(), i));
    }
  }
}

}  // namespace

Vec HybridParameters::Theta(const Unknowns& u) const {
  RequireGamma(u, gamma);
  Vec theta(u.size(static_cast<int>(x0.size())));
  Eigen::Index c = 0;
  for (int i : u.alpha) theta[c++] = alpha[i];
  for (int i : u.beta) theta[c++] = beta[i];
  for (int i : u.gamma) theta[c++] = gamma[i];
  if (u.x0) theta.tail(x0.size()) = x0;
  return theta;
}

HybridParameters HybridParameters::WithTheta(const Unknowns& u, const ConstVecRef& theta) const {
  RequireGamma(u, gamma);
  HybridParameters out = *this;
  Eigen::Index c = 0;
  for (int i : u.alpha) out.alpha[i] = theta[c++];
  for (int i : u.beta) out.beta[i] = theta[c++];
  for (int i : u.gamma) out.gamma[i] = theta[c++];
  if (u.x0) out.x0 = theta.tail(x0.size());
  return out;
}

bool SensitivityOptions::IsValid(std::string* error) const { return sim.IsValid(error); }

void SensitivitySink::WindowSample(long, const double*, const double*) {
  throw std::logic_error("SensitivitySink::WindowSample: a sink that takes windows must override it");
}

void SensitivitySink::CloseWindow(const double*, const double*, const double*, const double*) {
  throw std::logic_error("SensitivitySink::CloseWindow: a sink that takes windows must override it");
}

namespace {

// Central-difference Jacobian (m × n) of a map ℝⁿ → ℝᵐ at x; step 1e-5·max(1, |x_i|).
template <class F>
Mat CentralDifference(const F& map, const Vec& x, Eigen::Index m) {
  Mat jac(m, x.size());
  Vec xp = x, fp(m), fm(m);
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    const double h = 1e-5 * std::max(1.0, std::abs(x[i]));
    xp[i] = x[i] + h;
    map(xp, fp);
    xp[i] = x[i] - h;
    map(xp, fm);
    xp[i] = x[i];
    jac.col(i) = (fp - fm) / ((x[i] + h) - (x[i] - h));
  }
  return jac;
}

// S = ∂ξ/∂θ (n × p, column-major) as the run loop's payload: its flow, the saltation rule at the
// jumps, and S_k by cubic Hermite interpolation between the last two solver returns (S and S' at
// both ends; error ~h⁴/384·|S⁗|, about 1e-9 relative on the §5 system at rtol 1e-12): cheaper per
// sample than the polynomial of all n·p entries.
class SensitivityPayload final : public hybrid::Payload {
 public:
  // `sink`: each sample's S_k goes to it instead of the stored matrix (nullptr: stored).
  SensitivityPayload(const Model& model, const HybridParameters& params, const Unknowns& unknowns,
                     const Exogenous& exo, long sample_count, SensitivitySink* sink)
      : model_(model),
        params_(params),
        unknowns_(unknowns),
        context_(model, exo, &params.alpha, &params.beta),
        n_(model.state_size()),
        p_(unknowns.size(model.state_size())),
        gamma_offset_(static_cast<Eigen::Index>(unknowns.alpha.size() + unknowns.beta.size())),
        gamma_(params.GammaOr(model)),
        jac_(n_, n_),
        phi_(n_, model.alpha_size()),
        f_plus_(n_),
        f_minus_(n_),
        sink_(sink) {
    s_ = Mat::Zero(n_, p_);
    if (unknowns_.x0) s_.rightCols(n_).setIdentity();
    if (sink_ != nullptr) {
      sample_.resize(n_, p_);
      windows_ = sink_->windows();
    } else {
      sensitivities_.resize(static_cast<Eigen::Index>(n_) * p_, sample_count);
    }
    jump_time_gradients_.resize(p_, 0);
    for (std::size_t c = 0; c < unknowns_.gamma.size(); ++c) {
      if (model_.flow_reads_gamma(unknowns_.gamma[c])) flow_gamma_.push_back(c);
    }
  }

  long size() const override { return static_cast<long>(n_) * p_; }
  void Flow(const double* x, const double* s, const Context& ctx, double* sdot) override {
    Eigen::Map<Mat> d(sdot, n_, p_);
    Derivative(Eigen::Map<const Vec>(x, n_), Eigen::Map<const Mat>(s, n_, p_), ctx, d);
  }
  void Restart(const Context& ctx, const Vec& x, double* extra) override {
    CloseWindow();
    context_.set_mode(ctx.mode);  // the flow's mode until the next restart
    Eigen::Map<Mat>(extra, n_, p_) = s_;
    SetWindowEnd(window_b_, ctx.t, x, s_);
    window_a_ = window_b_;
  }
  void Returned(double t, const double* x, const double* s) override {  // the window: (previous, t)
    CloseWindow();
    std::swap(window_a_, window_b_);
    SetWindowEnd(window_b_, t, Eigen::Map<const Vec>(x, n_), Eigen::Map<const Mat>(s, n_, p_));
  }
  void AdoptReturned() override { s_ = window_b_.s; }
  bool BeginJumps(const Context& ctx, int guard, const Vec& x, std::string* why, int projected) override;
  void Jump(const Vec& pre, const Context& ctx) override;
  void EndJumps(const Vec& post, const Context& ctx) override;
  void Sample(long k, double t, const double* x) override;
  void SampleCurrent(long k, const double* x) override {
    if (sink_ != nullptr) return sink_->Sample(k, x, s_.data());
    sensitivities_.col(k) = Eigen::Map<const Vec>(s_.data(), s_.size());
  }

  // The samples' S_k (unless they went to the sink) and ∂t_j/∂θ, the first `samples` columns and
  // `jumps` columns.
  void MoveInto(SensitivityTrajectory* out) {
    CloseWindow();
    out->sensitivities = std::move(sensitivities_);
    if (sink_ == nullptr) out->sensitivities.conservativeResize(Eigen::NoChange, out->trajectory.size());
    out->jump_time_gradients = std::move(jump_time_gradients_);
  }

 private:
  // S and S' = (∂f/∂ξ)S + ∂f/∂θ at one end of the interpolation window.
  struct WindowEnd {
    double t = 0.0;
    Mat s, d;
  };

  // out = (∂f/∂ξ) S + ∂f/∂θ: column i of ∂f/∂θ is column i of φ for α's unknowns, ∂(φα)/∂γ_i by
  // central differences for the γ's a flow reads (Model::flow_reads_gamma), zero for the other γ's,
  // β's and ξ0's.
  void Derivative(const ConstVecRef& x, const Eigen::Ref<const Mat>& s, const Context& ctx, Eigen::Ref<Mat> out) {
    model_.FlowJacobian(x, params_.alpha, jac_, ctx);
    model_.Phi(x, phi_, ctx);
    out.noalias() = jac_ * s;
    const auto& au = unknowns_.alpha;
    for (std::size_t i = 0; i < au.size(); ++i) out.col(static_cast<Eigen::Index>(i)) += phi_.col(au[i]);
    for (const std::size_t c : flow_gamma_) {
      GammaDifference(
          unknowns_.gamma[c], ctx, [&](const Context& at, VecRef f) { model_.Flow(x, params_.alpha, f, at); },
          f_plus_, f_minus_);
      out.col(gamma_offset_ + static_cast<Eigen::Index>(c)) += f_plus_;
    }
  }
  // (map(γ + h e_i) − map(γ − h e_i)) / 2h into plus (minus: scratch), h = 1e-6·max(1, |γ_i|), at
  // the context `base` (its time and inputs) with γ moved.
  template <class Map>
  void GammaDifference(int i, const Context& base, const Map& map, Vec& plus, Vec& minus) {
    Vec& g = gamma_scratch_;
    g = gamma_;
    const double h = 1e-6 * std::max(1.0, std::abs(gamma_[i]));
    Context ctx = base;
    ctx.gamma = g.data();
    g[i] = gamma_[i] + h;
    map(ctx, plus);
    g[i] = gamma_[i] - h;
    map(ctx, minus);
    plus = (plus - minus) / ((gamma_[i] + h) - (gamma_[i] - h));
  }
  // (map(t + h) − map(t − h)) / 2h into plus (minus: scratch), h = 1e-6·max(1, |t|), at the context
  // `base` with its time and inputs u moved (zero, bit for bit, for a map that reads neither).
  template <class Map>
  void TimeDifference(const Context& base, const Map& map, Vec& plus, Vec& minus) {
    const double h = 1e-6 * std::max(1.0, std::abs(base.t));
    Context at = base;
    at.t = base.t + h;
    at.u = context_.At(at.t).u;
    map(at, plus);
    at.t = base.t - h;
    at.u = context_.At(at.t).u;
    map(at, minus);
    plus = (plus - minus) / ((base.t + h) - (base.t - h));
  }
  void SetWindowEnd(WindowEnd& end, double t, const ConstVecRef& x, const Eigen::Ref<const Mat>& s) {
    end.t = t;
    end.s = s;
    end.d.resize(n_, p_);
    Derivative(x, s, context_.At(t), end.d);
  }
  // The window's ends to a sink that takes windows, once samples were read in it.
  void CloseWindow() {
    if (!window_open_) return;
    window_open_ = false;
    sink_->CloseWindow(window_a_.s.data(), window_a_.d.data(), window_b_.s.data(), window_b_.d.data());
  }
  void AddGuardParameterColumns(int guard, const Vec& x, const Context& ctx, Eigen::RowVectorXd& dh) const;
  Eigen::RowVectorXd GuardGradient(int guard, const Vec& x, const Context& ctx) const {
    const Mat jac =
        CentralDifference([&](const Vec& z, Vec& h) { model_.Guards(z, h, ctx); }, x, model_.guard_count());
    return jac.row(guard);
  }

  const Model& model_;
  const HybridParameters& params_;
  const Unknowns& unknowns_;
  ContextSource context_;
  int n_ = 0, p_ = 0;
  Eigen::Index gamma_offset_ = 0;  // of γ_u's columns in θ
  Vec gamma_, gamma_scratch_;      // the run's γ; γ ± a step
  std::vector<std::size_t> flow_gamma_;  // the γ_u entries a flow reads (Model::flow_reads_gamma)
  int guard_ = -1, chain_ = 0;     // the guard that fired, and the jumps applied, in the chain under way
  int projected_ = -1;             // a guard crossed past zero whose projection the state went through
  Mat jac_, phi_;                 // scratch, n × n and n × |α|
  Vec f_plus_, f_minus_;          // scratch, n
  Mat s_;                         // S at the current state (the run loop's restart point)
  WindowEnd window_a_, window_b_;
  Eigen::RowVectorXd dt_dtheta_;  // ∂t_j/∂θ of the jumps under way
  Mat total_;                     // S⁻ + f⁻ ∂t_j/∂θ, then through each jump of the chain
  Mat sensitivities_, jump_time_gradients_;
  SensitivitySink* sink_;  // takes the samples' S_k when not null (sensitivities_ then empty)
  Mat sample_;             // with a sink: S_k of the sample under way (n × p)
  bool windows_ = false;       // the sink takes windows (SensitivitySink::windows)
  bool window_open_ = false;   // samples were given as weights of the current window
};

// ∂t_j/∂θ = −(∇ₓh·S⁻ + ∂h/∂θ)/(dh/dt) at a guard crossing, dh/dt = ∇ₓh·f⁻ + ∂h/∂t the rate of h
// along the flow (∂h/∂t: h's own time and inputs u(t) moving, zero for a guard in ξ and parameters);
// ∂h/∂θ: the α_u, β_u and γ_u columns of Model::GuardParameterJacobian (zero for a guard that reads
// none of them; all of θ zero for the initial state's jumps, at t = 0 whatever θ);
// total = S⁻ + f⁻ ∂t_j/∂θ.
bool SensitivityPayload::BeginJumps(const Context& ctx, int guard, const Vec& x, std::string* why, int projected) {
  const double t = ctx.t;
  Vec f_minus(n_);
  model_.Flow(x, params_.alpha, f_minus, ctx);
  dt_dtheta_ = Eigen::RowVectorXd::Zero(p_);
  guard_ = guard;
  projected_ = projected;
  chain_ = 0;
  if (guard >= 0) {
    const Eigen::RowVectorXd grad = GuardGradient(guard, x, ctx);
    Vec dh_dt(model_.guard_count());
    context_.GuardTimeDerivative(model_, x, ctx, dh_dt);
    const double rate = grad.dot(f_minus) + dh_dt[guard];
    if (!(std::abs(rate) > 1e-14 * std::max(1.0, grad.norm() * f_minus.norm() + std::abs(dh_dt[guard])))) {
      *why = fmt::format("grazing guard crossing at t = {:.17g}: the jump time has no sensitivity", t);
      return false;
    }
    Eigen::RowVectorXd dh = grad * s_;
    AddGuardParameterColumns(guard, x, ctx, dh);
    dt_dtheta_ = -dh / rate;
  }
  total_ = s_ + f_minus * dt_dtheta_;
  return true;
}

// dh(θ's α_u, β_u, γ_u columns) += ∂h_guard/∂(α, β, γ) at (x, ctx), for the blocks with unknowns.
void SensitivityPayload::AddGuardParameterColumns(int guard, const Vec& x, const Context& ctx,
                                                  Eigen::RowVectorXd& dh) const {
  using Block = Model::ParameterBlock;
  const std::pair<const std::vector<int>*, Block> blocks[] = {
      {&unknowns_.alpha, Block::kAlpha}, {&unknowns_.beta, Block::kBeta}, {&unknowns_.gamma, Block::kGamma}};
  const int sizes[] = {model_.alpha_size(), model_.beta_size(), model_.gamma_size()};
  Eigen::Index offset = 0;
  for (int b = 0; b < 3; ++b) {
    const std::vector<int>& indices = *blocks[b].first;
    if (!indices.empty()) {
      Mat jac(model_.guard_count(), sizes[b]);
      model_.GuardParameterJacobian(x, ctx, blocks[b].second, jac);
      for (std::size_t c = 0; c < indices.size(); ++c) dh[offset + static_cast<Eigen::Index>(c)] += jac(guard, indices[c]);
    }
    offset += static_cast<Eigen::Index>(indices.size());
  }
}

// total ← (∂g/∂ξ)·total + ∂g/∂θ + (∂g/∂t)·∂t_j/∂θ at the pre-jump state (∂g/∂t: the map's own time and
// inputs u(t) moving, zero unless ψ reads them), g the map ctx.map (Context::map: ψ with
// that map's β slice only, so ∂g/∂β is zero off the slice; an identity map: ∂g/∂ξ = I, ∂g/∂β = 0).
// g = ψ(ξ)β; with unknown γ, or after a crossing past zero, the chain's first jump is g = ψ(P(ξ, γ))β,
// P the projection onto the guard that fired, so that ∂g/∂γ carries the projection's dependence on γ
// and ∂g/∂ξ its independence of the projected rows (both by central differences of that composite).
void SensitivityPayload::Jump(const Vec& pre, const Context& ctx) {
  // Past zero, the projection decides the state the map reads (∂/∂ξ of the projected rows is 0).
  const bool project = chain_++ == 0 && ((guard_ >= 0 && !unknowns_.gamma.empty()) || projected_ >= 0);
  const int onto = guard_ >= 0 ? guard_ : projected_;
  const auto jump = [&](const Vec& z, const Context& ctx, VecRef g) {
    if (!project) return model_.Jump(z, params_.beta, g, ctx);
    Vec on = z;
    model_.ProjectOntoGuard(onto, on, ctx);
    model_.Jump(on, params_.beta, g, ctx);
  };
  const Mat g_x = CentralDifference([&](const Vec& z, Vec& g) { jump(z, ctx, g); }, pre, n_);
  Mat next = g_x * total_;
  const std::vector<JumpMap>& maps = model_.spec().jumps;
  if (maps.empty() || !maps[static_cast<std::size_t>(ctx.map)].identity) {  // ∂g/∂β = 0 for an identity
    Mat psi(n_, model_.beta_size());
    model_.Psi(pre, psi, ctx);
    const auto offset = static_cast<Eigen::Index>(unknowns_.alpha.size());
    for (std::size_t i = 0; i < unknowns_.beta.size(); ++i) {
      next.col(offset + static_cast<Eigen::Index>(i)) += psi.col(unknowns_.beta[i]);
    }
  }
  for (std::size_t c = 0; c < unknowns_.gamma.size(); ++c) {
    GammaDifference(
        unknowns_.gamma[c], ctx, [&](const Context& at, VecRef g) { jump(pre, at, g); }, f_plus_, f_minus_);
    next.col(gamma_offset_ + static_cast<Eigen::Index>(c)) += f_plus_;
  }
  if (guard_ >= 0) {  // a map that reads the time or the inputs moves with the jump time: + (∂g/∂t) ∂t_j/∂θ
    TimeDifference(ctx, [&](const Context& at, VecRef g) { jump(pre, at, g); }, f_plus_, f_minus_);
    next.noalias() += f_plus_ * dt_dtheta_;
  }
  total_ = std::move(next);
  jump_time_gradients_.conservativeResize(Eigen::NoChange, jump_time_gradients_.cols() + 1);
  jump_time_gradients_.rightCols(1) = dt_dtheta_.transpose();
}

// S⁺ = total − f⁺ ∂t_j/∂θ, f⁺ the flow of the mode after the jumps (ctx.mode).
void SensitivityPayload::EndJumps(const Vec& post, const Context& ctx) {
  context_.set_mode(ctx.mode);
  Vec f_plus(n_);
  model_.Flow(post, params_.alpha, f_plus, ctx);
  s_ = total_ - f_plus * dt_dtheta_;
}

void SensitivityPayload::Sample(long k, double t, const double* x) {
  const double h = window_b_.t - window_a_.t;
  double w[4] = {0.0, 0.0, 1.0, 0.0};  // (h = 0: the window's end)
  if (h != 0.0) {
    const double u = (t - window_a_.t) / h, u2 = u * u, u3 = u2 * u;
    w[0] = 2 * u3 - 3 * u2 + 1;
    w[1] = (u3 - 2 * u2 + u) * h;
    w[2] = -2 * u3 + 3 * u2;
    w[3] = (u3 - u2) * h;
  }
  if (windows_) {
    window_open_ = true;
    return sink_->WindowSample(k, x, w);
  }
  double* s = sink_ != nullptr ? sample_.data() : sensitivities_.col(k).data();
  const Eigen::Index size = static_cast<Eigen::Index>(n_) * p_;
  if (h == 0.0) {
    std::copy_n(window_b_.s.data(), size, s);
  } else {
    const double ca = w[0], cda = w[1], cb = w[2], cdb = w[3];
    const double *sa = window_a_.s.data(), *da = window_a_.d.data(), *sb = window_b_.s.data(),
                 *db = window_b_.d.data();
    for (Eigen::Index i = 0; i < size; ++i) s[i] = ca * sa[i] + cda * da[i] + cb * sb[i] + cdb * db[i];
  }
  if (sink_ != nullptr) sink_->Sample(k, x, s);
}

// Matched mode on the run loop's primitives: segment j starts at the model's own jump (t_j(θ),
// ξ(t_j)); its samples before t_j are read integrating backward, the rest forward, past the model's
// next crossing (guards off after it) when samples of segment j lie beyond it; then the jumps there.
class Matched {
 public:
  Matched(hybrid::Engine& engine, const std::vector<int>& segments, SensitivityTrajectory& out)
      : engine_(engine), segments_(segments), out_(out) {}

  bool Run() {
    const int last = segments_.back();
    const long count = engine_.samples().count;
    long lo = 0;
    for (int j = 0; j <= last; ++j) {
      long hi = lo - 1;
      while (hi + 1 < count && segments_[static_cast<std::size_t>(hi + 1)] == j) ++hi;
      // A segment without samples lies between two samples; one the run has passed already was left
      // by a chain of jumps at one instant (at t = 0: the initial state's).
      if (hi < lo && engine_.jumps() > j) continue;
      long first_forward = lo;
      while (first_forward <= hi && At(first_forward) < engine_.t()) ++first_forward;
      if (first_forward > lo && !Backward(j, lo, first_forward - 1)) return false;
      if (!Forward(j, first_forward, hi, j < last)) return false;
      lo = hi + 1;
    }
    return true;
  }

 private:
  double At(long k) const { return engine_.samples().at(k); }

  // Samples to, to − 1, …, from (all before the segment's start), integrating backward; the
  // segment's start stays the current state.
  bool Backward(int j, long from, long to) {
    if (!engine_.Start(At(from), /*roots=*/false)) return false;
    long next = to;
    while (next >= from) {
      double tret = engine_.t();
      const int flag = engine_.Step(At(from), &tret);
      if (flag < 0) return false;
      long lo = next + 1;
      while (lo > from && (flag == CV_TSTOP_RETURN || At(lo - 1) >= tret)) --lo;
      engine_.EmitStep(lo, next + 1, j);
      next = lo - 1;
    }
    return true;
  }

  // Samples from..to forward from the segment's start; `need_jump`: then the jumps at the model's
  // first crossing after the start (the current state stays the start when there is none to take).
  bool Forward(int j, long from, long to, bool need_jump) {
    if (engine_.t() >= engine_.t_last()) {
      engine_.EmitCurrent(from, to + 1, j);
      return need_jump ? Missing(j) : true;
    }
    if (!engine_.Start(engine_.t_last(), /*roots=*/true)) return false;
    long next = from;
    int guard = -1;
    while (next <= to || (need_jump && guard < 0)) {
      double tret = engine_.t();
      const int flag = engine_.Step(engine_.t_last(), &tret);
      if (flag < 0) return false;
      long end = next;
      while (end <= to && (flag == CV_TSTOP_RETURN || At(end) <= tret)) ++end;
      engine_.EmitStep(next, end, j);
      next = end;
      if (flag == CV_ROOT_RETURN && !need_jump) ++out_.extra_jumps;
      if (flag == CV_ROOT_RETURN && need_jump && guard < 0) {
        guard = engine_.AdoptRoot(tret);  // the jump waits until segment j's samples are read
        if (!engine_.DisableRoots()) return false;
      }
      if (flag == CV_TSTOP_RETURN) {
        if (need_jump && guard < 0) return Missing(j);
        break;
      }
    }
    return guard < 0 || engine_.Jumps(guard);
  }

  bool Missing(int j) {
    out_.missing_jumps = segments_.back() - j;
    // The status says completed; missing_jumps says what is wrong.
    return engine_.Fail(SimStop::kCompleted,
                        fmt::format("the model makes {} jump(s) before the last sample time; the data show {}",
                                    j, segments_.back()));
  }

  hybrid::Engine& engine_;
  const std::vector<int>& segments_;
  SensitivityTrajectory& out_;
};

// The run's γ and inputs.
Exogenous ExogenousOf(const HybridParameters& params, const InputSignal* inputs) {
  return Exogenous{.gamma = params.gamma, .inputs = inputs, .initial_mode = params.initial_mode};
}

void CheckInputs(const Model& model, const HybridParameters& params, const Unknowns& unknowns,
                 const SampleGrid& grid, const SensitivityOptions& options, const InputSignal* inputs) {
  std::string error;
  if (!grid.IsValid(&error) || !options.IsValid(&error) || !unknowns.IsValid(model, &error)) {
    throw std::invalid_argument(error);
  }
  auto check = [&](const Vec& v, Eigen::Index size, const char* what) {
    if (v.size() != size) {
      throw std::invalid_argument(fmt::format("HybridParameters::{} has {} entries; model '{}' has {}", what,
                                              v.size(), model.name(), size));
    }
    if (!v.allFinite()) throw std::invalid_argument(fmt::format("HybridParameters::{} is not finite", what));
  };
  check(params.alpha, model.alpha_size(), "alpha");
  check(params.beta, model.beta_size(), "beta");
  check(params.x0, model.state_size(), "x0");
  if (params.gamma.size() != 0 || !unknowns.gamma.empty()) check(params.gamma, model.gamma_size(), "gamma");
  const Exogenous exo = ExogenousOf(params, inputs);
  if (std::string why = ExogenousError(model, exo, grid.size() > 0 ? static_cast<double>(grid.size() - 1) * grid.dt : 0.0);
      !why.empty()) {
    throw std::invalid_argument(why);
  }
  ContextSource context(model, exo, &params.alpha, &params.beta);
  if (!model.InFlowSet(params.x0, context.At(0.0)) && !model.InJumpSet(params.x0, context.At(0.0))) {
    throw std::invalid_argument(fmt::format("x0 lies outside C and D of model '{}'", model.name()));
  }
}

// Plain (segments null: Simulate's loop) or matched mode; the sensitivities as the loop's payload.
SensitivityTrajectory Integrate(const Model& model, const HybridParameters& params, const Unknowns& unknowns,
                                const hybrid::SampleTimes& samples, const SensitivityOptions& options,
                                const std::vector<int>* segments, const InputSignal* inputs,
                                SensitivitySink* sink = nullptr) {
  SensitivityTrajectory out;
  out.parameters = unknowns.size(model.state_size());
  const Exogenous exo = ExogenousOf(params, inputs);
  std::optional<SensitivityPayload> payload;
  if (options.sensitivities) payload.emplace(model, params, unknowns, exo, samples.count, sink);
  hybrid::Engine engine(model, params.alpha, params.beta, exo, samples, options.sim, payload ? &*payload : nullptr,
                        segments ? hybrid::SampleOrder::kAny : hybrid::SampleOrder::kIncreasing);
  if (segments == nullptr) {
    out.trajectory = engine.Run(params.x0);
  } else {
    if (engine.Setup(params.x0) && Matched(engine, *segments, out).Run()) engine.Complete();
    out.trajectory = engine.Finish();
  }
  if (payload) payload->MoveInto(&out);
  return out;
}

}  // namespace

SensitivityTrajectory SimulateSensitivities(const Model& model, const HybridParameters& params,
                                            const Unknowns& unknowns, const SampleGrid& grid,
                                            const SensitivityOptions& options, const InputSignal* inputs) {
  CheckInputs(model, params, unknowns, grid, options, inputs);
  return Integrate(model, params, unknowns, {.count = grid.size(), .dt = grid.dt}, options, nullptr, inputs);
}

namespace {

void CheckSegments(const std::vector<int>& segment_of_sample, std::size_t k_count) {
  if (segment_of_sample.size() != k_count) {
    throw std::invalid_argument(fmt::format("segment_of_sample has {} entries; the grid has {} samples",
                                            segment_of_sample.size(), k_count));
  }
  for (std::size_t k = 0; k < k_count; ++k) {
    const int prev = k == 0 ? 0 : segment_of_sample[k - 1];
    if (segment_of_sample[k] < prev) {
      throw std::invalid_argument(fmt::format("segment_of_sample[{}] = {} after {}: must be at least 0 and never "
                                              "decrease from one sample to the next",
                                              k, segment_of_sample[k], prev));
    }
  }
}

}  // namespace

SensitivityTrajectory SimulateSensitivitiesMatched(const Model& model, const HybridParameters& params,
                                                   const Unknowns& unknowns, const SampleGrid& grid,
                                                   const std::vector<int>& segment_of_sample,
                                                   const SensitivityOptions& options, const InputSignal* inputs) {
  CheckInputs(model, params, unknowns, grid, options, inputs);
  CheckSegments(segment_of_sample, static_cast<std::size_t>(grid.size()));
  return Integrate(model, params, unknowns, {.count = grid.size(), .dt = grid.dt}, options, &segment_of_sample,
                   inputs);
}

namespace {

// The grid standing for samples at their own times (checked: at least 2, the first at 0, increasing).
SampleGrid GridOfTimes(const std::vector<double>& times) {
  if (times.size() < 2 || times[0] != 0.0) {
    throw std::invalid_argument(fmt::format("times: {} samples, first {}: need at least 2, the first at 0",
                                            times.size(), times.empty() ? 0.0 : times[0]));
  }
  for (std::size_t k = 1; k < times.size(); ++k) {
    if (!(times[k] > times[k - 1]) || !std::isfinite(times[k])) {
      throw std::invalid_argument(
          fmt::format("times[{}] = {} after {}: must increase", k, times[k], times[k - 1]));
    }
  }
  return EvenGrid(times.back(), static_cast<long>(times.size()));
}

}  // namespace

SensitivityTrajectory SimulateSensitivities(const Model& model, const HybridParameters& params,
                                            const Unknowns& unknowns, const std::vector<double>& times,
                                            const SensitivityOptions& options, const InputSignal* inputs) {
  const SampleGrid grid = GridOfTimes(times);
  CheckInputs(model, params, unknowns, grid, options, inputs);
  return Integrate(model, params, unknowns,
                   {.count = static_cast<long>(times.size()), .dt = grid.dt, .times = &times}, options, nullptr,
                   inputs);
}

SensitivityTrajectory SimulateSensitivitiesMatched(const Model& model, const HybridParameters& params,
                                                   const Unknowns& unknowns, const std::vector<double>& times,
                                                   const std::vector<int>& segment_of_sample,
                                                   const SensitivityOptions& options,
                                                   const InputSignal* inputs, SensitivitySink* sink) {
  const SampleGrid grid = GridOfTimes(times);
  CheckInputs(model, params, unknowns, grid, options, inputs);
  CheckSegments(segment_of_sample, times.size());
  return Integrate(model, params, unknowns,
                   {.count = static_cast<long>(times.size()), .dt = grid.dt, .times = &times}, options,
                   &segment_of_sample, inputs, sink);
}

}  // namespace hysid
