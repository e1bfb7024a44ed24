#include "sim/hybrid_run.hpp"

#include <algorithm>
#include <cmath>

#include <cvodes/cvodes.h>
#include <fmt/format.h>
#include <sundials/sundials_context.h>
#include <sunnonlinsol/sunnonlinsol_fixedpoint.h>

#include "core/model/automaton.hpp"

namespace hysid::hybrid {
namespace {

// ξ' = φ(ξ)α into ydot[0..n), then the payload's components.
int FlowRhs(sunrealtype t, N_Vector y, N_Vector ydot, void* user_data) {
  auto* data = static_cast<CallbackData*>(user_data);
  const Eigen::Index n = data->n;
  const double* yp = N_VGetArrayPointer_Serial(y);
  double* ydotp = N_VGetArrayPointer_Serial(ydot);
  const Eigen::Map<const Vec> x(yp, n);
  Eigen::Map<Vec> f(ydotp, n);
  const Context ctx = data->context->At(t);
  data->model->Flow(x, *data->alpha, f, ctx);
  if (!f.allFinite() || !x.allFinite()) {
    data->nonfinite_rhs = true;
    return -1;  // unrecoverable: CVODE stops with CV_RHSFUNC_FAIL
  }
  if (data->payload) data->payload->Flow(yp, yp + n, ctx, ydotp + n);
  return 0;
}

int GuardFunctions(sunrealtype t, N_Vector y, sunrealtype* gout, void* user_data) {
  auto* data = static_cast<CallbackData*>(user_data);
  const Eigen::Map<const Vec> x(N_VGetArrayPointer_Serial(y), data->n);
  Eigen::Map<Vec> h(gout, data->guard_count);
  data->model->Guards(x, h, data->context->At(t));
  if (data->armed) {  // a guard not armed in the current mode never changes sign
    for (int i = 0; i < data->guard_count; ++i) {
      if (!(*data->armed)[static_cast<std::size_t>(i)]) h(i) = 1.0;
    }
  }
  return 0;
}

void CaptureError(int /*error_code*/, const char* module, const char* function, char* msg, void* user_data) {
  static_cast<CallbackData*>(user_data)->last_error = fmt::format("{}/{}: {}", module, function, msg);
}

// Intervals count as shrinking only when each is below this fraction of the one before: constant
// intervals (a stiff spring's half-periods) equal up to rounding are not an accumulation.
constexpr double kZenoMaxRatio = 1.0 - 1e-3;

// A guard within this of zero (times max(1, ‖ξ‖∞)) after a jump is at zero: whether it fires again at
// the same instant is decided by its rate under the new flow.
constexpr double kAtZero = 1e-10;

// The sign of a crossing in a guard's direction: +1 rising, −1 falling, 0 both.
double DirectionSign(Crossing c) { return c == Crossing::kRising ? 1.0 : c == Crossing::kFalling ? -1.0 : 0.0; }

}  // namespace

Engine::Engine(const Model& model, const Vec& alpha, const Vec& beta, const Exogenous& exo,
               const SampleTimes& samples, const SimOptions& options, Payload* payload, SampleOrder order)
    : model_(model),
      alpha_(alpha),
      beta_(beta),
      samples_(samples),
      options_(options),
      payload_(payload),
      order_(order),
      context_(model, exo, &alpha, &beta),
      explicit_maps_(!model.spec().jumps.empty()),
      several_modes_(ModeCount(model.spec()) > 1),
      n_(model.state_size()) {
  t_last_ = samples_.at(samples_.count - 1);
  out_.dt = samples_.dt;
  const auto count = static_cast<std::size_t>(samples_.count);
  if (order_ == SampleOrder::kIncreasing) {
    out_.t.reserve(count);
    out_.j.reserve(count);
    if (several_modes_) out_.q.reserve(count);
  } else {
    out_.t.assign(count, 0.0);
    out_.j.assign(count, 0);
    if (several_modes_) out_.q.assign(count, 0);
    filled_.assign(count, 0);
  }
  out_.x.resize(n_, samples_.count);
  data_.model = &model_;
  data_.alpha = &alpha_;
  data_.payload = payload_;
  data_.context = &context_;
  data_.n = n_;
  data_.guard_count = model_.guard_count();
  SetMode(InitialMode(model, exo));
  if (exo.inputs) {
    input_stops_ = options_.input_kink > 0.0 ? InputKinkTimes(*exo.inputs, options_.input_kink) : exo.inputs->times;
  }
}

// The first input stop strictly after t (forward) or strictly before t (backward), or `limit` when
// there is none before it.
double Engine::NextInputStop(double t, double limit) const {
  if (limit >= t) {
    const auto it = std::upper_bound(input_stops_.begin(), input_stops_.end(), t);
    return it == input_stops_.end() ? limit : std::min(*it, limit);
  }
  auto it = std::lower_bound(input_stops_.begin(), input_stops_.end(), t);  // first ≥ t; the one before is < t
  if (it == input_stops_.begin()) return limit;
  return std::max(*std::prev(it), limit);
}

// The current mode q: the context's Context::mode and, with explicit maps, the guards armed in it.
void Engine::SetMode(int mode) {
  mode_ = mode;
  context_.set_mode(mode);
  if (!explicit_maps_) return;
  armed_.assign(static_cast<std::size_t>(model_.guard_count()), 0);
  for (int g = 0; g < model_.guard_count(); ++g) armed_[static_cast<std::size_t>(g)] = ArmedMap(model_.spec(), mode, g) >= 0;
  data_.armed = &armed_;
}

Trajectory Engine::Run(const Vec& x0) {
  if (!Setup(x0)) return Finish();
  const long count = samples_.count;
  long next = 0;
  for (;;) {
    if (t_ >= t_last_) {  // a jump at the last sample time leaves nothing to integrate
      EmitCurrent(next, count, jumps());
      Complete();
      return Finish();
    }
    if (!Start(t_last_, /*roots=*/true)) return Finish();
    if (next == 0) {
      EmitCurrent(0, 1, jumps());
      next = 1;
    }
    for (;;) {
      double tret = t_;
      const int flag = Step(t_last_, &tret);
      if (flag < 0) return Finish();
      const bool root = flag == CV_ROOT_RETURN;
      long end = next;
      while (end < count && (root ? samples_.at(end) < tret : samples_.at(end) <= tret)) ++end;
      EmitStep(next, end, jumps());
      next = end;
      if (root) {
        if (!Jumps(AdoptRoot(tret))) return Finish();
        break;
      }
      t_ = tret;
      const Context ctx = ContextAt(tret);
      if (!model_.InFlowSet(returned(), ctx) && !model_.InJumpSet(returned(), ctx)) {
        Fail(SimStop::kLeftDomain,
             fmt::format("state left C and D at t = {:.17g} without a located crossing", tret));
        return Finish();
      }
      if (flag == CV_TSTOP_RETURN) {  // samples at t_last within rounding, from the returned step
        EmitStep(next, count, jumps());
        Complete();
        return Finish();
      }
    }
  }
}

bool Engine::Setup(const Vec& x0) {
  SUNContext ctx = nullptr;
  if (SUNContext_Create(nullptr, &ctx) != 0) return Fail(SimStop::kSolverFailure, "SUNContext_Create failed");
  ctx_.reset(ctx);
  const long size = n_ + (payload_ ? payload_->size() : 0);
  y_.reset(N_VNew_Serial(size, ctx_.get()));
  scratch_.reset(N_VNew_Serial(size, ctx_.get()));
  if (!y_ || !scratch_) return Fail(SimStop::kSolverFailure, "N_VNew_Serial failed");
  // Fused vector kernels (off by default for serial vectors; clones inherit them): CVODE's Adams
  // updates and CVodeGetDky then run as one loop each instead of chains of N_VLinearSum calls.
  N_VEnableFusedOps_Serial(y_.get(), SUNTRUE);
  N_VEnableFusedOps_Serial(scratch_.get(), SUNTRUE);
  t_ = 0.0;
  x_ = x0;
  double* y = N_VGetArrayPointer_Serial(y_.get());
  Eigen::Map<Vec>(y, n_) = x0;
  if (payload_) payload_->Restart(ContextAt(t_), x_, y + n_);
  cvode_.reset(CVodeCreate(CV_ADAMS, ctx_.get()));
  if (!cvode_) return Fail(SimStop::kSolverFailure, "CVodeCreate failed");
  void* mem = cvode_.get();
  if (!Check(CVodeSetErrHandlerFn(mem, CaptureError, &data_), "CVodeSetErrHandlerFn")) return false;
  {
    const nordsieck::CloneRecorder recorder(y_.get());
    if (!Check(CVodeInit(mem, FlowRhs, 0.0, y_.get()), "CVodeInit")) return false;
    history_.Locate(mem, recorder.clones(), n_);
  }
  if (!Check(CVodeSStolerances(mem, options_.rtol, options_.atol), "CVodeSStolerances")) return false;
  nls_.reset(SUNNonlinSol_FixedPoint(y_.get(), 0, ctx_.get()));
  if (!nls_) return Fail(SimStop::kSolverFailure, "SUNNonlinSol_FixedPoint failed");
  if (!Check(CVodeSetNonlinearSolver(mem, nls_.get()), "CVodeSetNonlinearSolver") ||
      !Check(CVodeSetUserData(mem, &data_), "CVodeSetUserData")) {
    return false;
  }
  // Explicit maps: a guard may be crossed and crossed back within one long step (a ball through a
  // ceiling on an exact parabola, which Adams integrates with huge steps); CVODE sees sign changes at
  // step ends only, so no step is longer than the mean sample interval.
  if (explicit_maps_ && !Check(CVodeSetMaxStep(mem, MeanSampleInterval()), "CVodeSetMaxStep")) return false;
  if (explicit_maps_) {  // an armed guard already past (or at and moving past) zero fires at t = 0
    bool at_zero = false;
    const int guard = ChainedCrossing(&at_zero);
    return guard < 0 || MapChain(guard, /*located=*/false);
  }
  // HyEQ rule 1: an initial state in D jumps before it flows.
  return !model_.InJumpSet(x_, ContextAt(t_)) || JumpChain(-1);
}

double Engine::MeanSampleInterval() const {
  return samples_.count > 1 ? t_last_ / static_cast<double>(samples_.count - 1) : t_last_;
}

bool Engine::Start(double tstop, bool roots) {
  void* mem = cvode_.get();
  if (!at_init_) {
    AccumulateCounters();
    double* y = N_VGetArrayPointer_Serial(y_.get());
    Eigen::Map<Vec>(y, n_) = x_;
    if (payload_) payload_->Restart(ContextAt(t_), x_, y + n_);
    if (!Check(CVodeReInit(mem, t_, y_.get()), "CVodeReInit")) return false;
  }
  at_init_ = false;
  last_tret_ = t_;
  stop_set_ = NextInputStop(t_, tstop);
  if (!Check(CVodeSetStopTime(mem, stop_set_), "CVodeSetStopTime")) return false;
  if (roots == roots_) return true;
  if (!roots) return DisableRoots();
  roots_ = true;
  if (!Check(CVodeRootInit(mem, model_.guard_count(), GuardFunctions), "CVodeRootInit")) return false;
  std::vector<int> directions;
  for (const Guard& g : model_.spec().guards) directions.push_back(sundials_ptr::ToCvodeDirection(g.direction));
  return Check(CVodeSetRootDirection(mem, directions.data()), "CVodeSetRootDirection") &&
         Check(CVodeSetNoInactiveRootWarn(mem), "CVodeSetNoInactiveRootWarn");
}

bool Engine::DisableRoots() {
  roots_ = false;
  return Check(CVodeRootInit(cvode_.get(), 0, nullptr), "CVodeRootInit");
}

int Engine::Step(double tstop, double* tret) {
  if (options_.stopped()) {
    Fail(SimStop::kSolverFailure, fmt::format("stopped at t = {:.17g} (SimOptions::stop)", t_));
    return -1;
  }
  if (steps_ >= options_.max_steps) {
    Fail(SimStop::kSolverFailure,
         fmt::format("step budget of {} CVODE steps exhausted at t = {:.17g}", options_.max_steps, t_));
    return -1;
  }
  ++steps_;
  double stop = tstop;
  if (!input_stops_.empty()) {
    stop = NextInputStop(last_tret_, tstop);
    if (stop != stop_set_ && !Check(CVodeSetStopTime(cvode_.get(), stop), "CVodeSetStopTime")) return -1;
    stop_set_ = stop;
  }
  int flag = CVode(cvode_.get(), stop, y_.get(), tret, CV_ONE_STEP);
  if (flag == CV_TSTOP_RETURN && stop != tstop) flag = CV_SUCCESS;  // an input kink: go on
  last_tret_ = *tret;
  if (flag < 0) {
    if (data_.nonfinite_rhs) {
      Fail(SimStop::kNonFinite, fmt::format("flow map is not finite near t = {:.17g}", *tret));
    } else {
      Fail(SimStop::kSolverFailure, fmt::format("CVode returned {} at t = {:.17g}: {}",
                                                CVodeGetReturnFlagName(flag), *tret, data_.last_error));
    }
    return -1;
  }
  if (!returned().allFinite()) {
    Fail(SimStop::kNonFinite, fmt::format("state not finite at t = {:.17g}", *tret));
    return -1;
  }
  if (payload_) {
    const double* y = N_VGetArrayPointer_Serial(y_.get());
    payload_->Returned(*tret, y, y + n_);
  }
  return flag;
}

int Engine::AdoptRoot(double tret) {
  t_ = tret;
  x_ = returned();
  if (payload_) payload_->AdoptReturned();
  if (!explicit_maps_) return sundials_ptr::FiredGuard(cvode_.get(), model_.guard_count());
  std::vector<int> found(static_cast<std::size_t>(model_.guard_count()), 0);
  CVodeGetRootInfo(cvode_.get(), found.data());
  int fired = -1, first_map = 0;
  for (int g = 0; g < model_.guard_count(); ++g) {
    const int map = ArmedMap(model_.spec(), mode_, g);
    if (found[static_cast<std::size_t>(g)] != 0 && map >= 0 && (fired < 0 || map < first_map)) {
      fired = g;
      first_map = map;
    }
  }
  return std::max(fired, 0);
}

bool Engine::Jumps(int guard) {
  return (explicit_maps_ ? MapChain(guard, /*located=*/true) : JumpChain(guard)) && CheckZenoAndBudget();
}

// Applies the jump map at t_ to x_, then again while ξ+ ∈ D (rule 1).
bool Engine::JumpChain(int guard) {
  const Context ctx = ContextAt(t_);
  if (guard >= 0) model_.ProjectOntoGuard(guard, x_, ctx);
  at_init_ = false;
  std::string why;
  if (payload_ && !payload_->BeginJumps(ctx, guard, x_, &why)) return Fail(SimStop::kSolverFailure, why);
  Vec post(n_);
  for (int chain = 0;; ++chain) {
    if (chain >= options_.max_jumps_at_one_time) {
      out_.status.zeno_time = t_;
      return Fail(SimStop::kZeno, fmt::format("Zeno: {} jumps at t = {:.17g} (the jump map keeps the state "
                                              "in D); estimated accumulation time {:.17g}",
                                              chain, t_, t_));
    }
    model_.Jump(x_, beta_, post, ContextAt(t_));
    if (payload_) payload_->Jump(x_, ContextAt(t_));
    out_.jumps.push_back(JumpRecord{jumps() + 1, t_, chain == 0 ? guard : -1, x_, post, 0, mode_});
    x_ = post;
    if (!x_.allFinite()) {
      return Fail(SimStop::kNonFinite, fmt::format("jump map gave a non-finite state at t = {:.17g}", t_));
    }
    if (!model_.InJumpSet(x_, ContextAt(t_))) break;
  }
  if (payload_) payload_->EndJumps(x_, ContextAt(t_));
  return true;
}

// Explicit maps: the map armed for `guard` in the current mode (ξ put on the guard first), the mode
// after it, then the next chained crossing at ξ+.
// Each crossing is its own BeginJumps … EndJumps for the payload; a crossing not located (past zero,
// or the initial state's) has a jump time that does not move with θ (guard −1 to the payload).
bool Engine::MapChain(int guard, bool located) {
  at_init_ = false;
  std::string why;
  Vec post(n_);
  for (int chain = 0; guard >= 0; ++chain) {
    if (chain >= options_.max_jumps_at_one_time) {
      out_.status.zeno_time = t_;
      return Fail(SimStop::kZeno, fmt::format("Zeno: {} jumps at t = {:.17g} (crossings chain at one instant; "
                                              "last guard '{}'); estimated accumulation time {:.17g}",
                                              chain, t_, model_.spec().guards[std::size_t(guard)].name, t_));
    }
    const int map = ArmedMap(model_.spec(), mode_, guard);
    if (map < 0) {  // not reached: a guard not armed is the constant 1 to CVODE and never chained
      return Fail(SimStop::kSolverFailure, fmt::format("guard {} fired at t = {:.17g} but is not armed in mode {}",
                                                       guard, t_, mode_));
    }
    Context ctx = ContextAt(t_);
    ctx.map = map;
    // A crossing past zero is put on the guard too (a tank past its rim is at its rim): the jump map
    // reads the guard's state, as at a located crossing.
    model_.ProjectOntoGuard(guard, x_, ctx);
    if (payload_ && !payload_->BeginJumps(ctx, located ? guard : -1, x_, &why, located ? -1 : guard)) {
      return Fail(SimStop::kSolverFailure, why);
    }
    model_.Jump(x_, beta_, post, ctx);
    if (payload_) payload_->Jump(x_, ctx);
    SetMode(ModeAfter(model_.spec(), mode_, map));
    out_.jumps.push_back(JumpRecord{jumps() + 1, t_, guard, x_, post, map, mode_});
    x_ = post;
    if (!x_.allFinite()) {
      return Fail(SimStop::kNonFinite, fmt::format("jump map '{}' gave a non-finite state at t = {:.17g}",
                                                   model_.spec().jumps[std::size_t(map)].name, t_));
    }
    if (payload_) payload_->EndJumps(x_, ContextAt(t_));
    guard = ChainedCrossing(&located);
  }
  return true;
}

// The guard armed in the current mode that fires at (t_, x_) without flowing: past zero in its
// direction, or at zero (kAtZero) with its rate dh/dt = ∇h·f + ∂h/∂t (central differences along the
// current mode's flow and in time, u(t) moving) in its direction; of several, the one whose map comes
// first in spec.jumps. −1 when none.
int Engine::ChainedCrossing(bool* at_zero) {
  const int count = model_.guard_count();
  const Context ctx = ContextAt(t_);
  Vec h(count), f(n_), rate = Vec::Zero(count), dh_dt(count);
  model_.Guards(x_, h, ctx);
  model_.Flow(x_, alpha_, f, ctx);
  const double scale = std::max(1.0, x_.cwiseAbs().maxCoeff());
  const double fnorm = f.cwiseAbs().maxCoeff();
  if (fnorm > 0.0 && std::isfinite(fnorm)) {
    const double eps = 1e-6 * scale / fnorm;
    Vec hm(count);
    model_.Guards(x_ + eps * f, rate, ctx);
    model_.Guards(x_ - eps * f, hm, ctx);
    rate = (rate - hm) / (2.0 * eps);
  }
  context_.GuardTimeDerivative(model_, x_, ctx, dh_dt);
  rate += dh_dt;
  int fired = -1, first_map = 0;
  for (int g = 0; g < count; ++g) {
    const int map = ArmedMap(model_.spec(), mode_, g);
    const double s = DirectionSign(model_.spec().guards[std::size_t(g)].direction);
    if (map < 0 || s == 0.0) continue;
    const bool zero = std::abs(h[g]) <= kAtZero * scale;
    const bool fires = zero ? s * rate[g] > 0.0 : s * h[g] > 0.0;
    if (fires && (fired < 0 || map < first_map)) {
      fired = g;
      first_map = map;
      *at_zero = zero;
    }
  }
  return fired;
}

bool Engine::CheckZenoAndBudget() {
  if (!explicit_maps_) {
    if (!CheckZeno(-1)) return false;
  } else {
    // Every guard that fired at this instant, on its own jumps.
    for (auto it = out_.jumps.rbegin(); it != out_.jumps.rend() && it->t == t_; ++it) {
      if (!CheckZeno(it->guard)) return false;
    }
  }
  if (jumps() >= options_.max_jumps) {
    return Fail(SimStop::kJumpBudget,
                fmt::format("jump budget of {} jumps exhausted at t = {:.17g}", options_.max_jumps, t_));
  }
  return true;
}

// The Zeno-interval rule on the jumps of `guard` (−1: all jumps, the paper's class).
bool Engine::CheckZeno(int guard) {
  const int window = options_.zeno_window;
  const std::size_t need = static_cast<std::size_t>(window) + 2;
  std::vector<double> times;  // the last `need` jump times of the guard, newest first
  for (auto it = out_.jumps.rbegin(); it != out_.jumps.rend() && times.size() < need; ++it) {
    if (guard < 0 || it->guard == guard) times.push_back(it->t);
  }
  if (times.size() < need) return true;
  const double last = times[0] - times[1];
  bool shrinking = last < options_.zeno_interval;
  for (int i = 0; shrinking && i < window; ++i) {
    const double newer = times[std::size_t(i)] - times[std::size_t(i) + 1];
    const double older = times[std::size_t(i) + 1] - times[std::size_t(i) + 2];
    shrinking = newer < kZenoMaxRatio * older;
  }
  if (!shrinking) return true;
  const double prev = times[1] - times[2];
  const double rho = last / prev;  // geometric ratio of the intervals
  const double tz = times[0] + last * rho / (1.0 - rho);
  out_.status.zeno_time = tz;
  const std::string which =
      guard < 0 ? std::string() : fmt::format(" of guard '{}'", model_.spec().guards[std::size_t(guard)].name);
  return Fail(SimStop::kZeno, fmt::format("Zeno: jump interval{} {:.3g} s and shrinking (ratio {:.6g}) "
                                          "after {} jumps; estimated accumulation time {:.17g}",
                                          which, last, rho, jumps(), tz));
}

// Times and segments of samples begin..end−1 (appended in increasing order, else at their places).
void Engine::Mark(long begin, long end, int segment) {
  const auto b = static_cast<std::size_t>(begin), e = static_cast<std::size_t>(end);
  if (order_ == SampleOrder::kIncreasing) {
    if (samples_.times) {
      out_.t.insert(out_.t.end(), samples_.times->begin() + begin, samples_.times->begin() + end);
    } else {
      for (long k = begin; k < end; ++k) out_.t.push_back(static_cast<double>(k) * samples_.dt);
    }
    out_.j.resize(e, segment);
    if (several_modes_) out_.q.resize(e, mode_);
    return;
  }
  for (long k = begin; k < end; ++k) out_.t[static_cast<std::size_t>(k)] = samples_.at(k);
  std::fill(out_.j.begin() + b, out_.j.begin() + e, segment);
  if (several_modes_) std::fill(out_.q.begin() + b, out_.q.begin() + e, mode_);
  std::fill(filled_.begin() + b, filled_.begin() + e, 1);
}

void Engine::EmitCurrent(long begin, long end, int segment) {
  if (end <= begin) return;
  Mark(begin, end, segment);
  for (long k = begin; k < end; ++k) {
    out_.x.col(k) = x_;
    if (payload_) payload_->SampleCurrent(k, x_.data());
  }
}

// Few samples: ξ(t_k) each, as CVodeGetDky(t_k, 0). Many: the polynomial's q + 1 Taylor coefficients
// at t_n once (as CVodeGetDky(t_n, k), k = 0..q), then Horner's rule per sample. Both read CVODE's
// Nordsieck array directly when history_ allows (the same bits, sim/nordsieck.hpp).
void Engine::EmitStep(long begin, long end, int segment) {
  if (end <= begin) return;
  void* mem = cvode_.get();
  int q = 0;
  sunrealtype tn = 0.0, h = 0.0;
  CVodeGetLastOrder(mem, &q);
  CVodeGetCurrentTime(mem, &tn);
  CVodeGetLastStep(mem, &h);
  const bool direct = history_.Prepare(mem, q, tn, h, scratch_.get());
  Mark(begin, end, segment);
  if (end - begin > q + 1 && h != 0.0) {
    TaylorCoefficients(q, tn, h, direct);
    EmitHorner(q, tn, h, begin, end);
  } else {
    double* tmp = N_VGetArrayPointer_Serial(scratch_.get());
    for (long k = begin; k < end; ++k) {
      const double t = out_.t[static_cast<std::size_t>(k)];
      if (direct) {
        history_.Dky(t, 0, tmp);
      } else {
        CVodeGetDky(mem, t, 0, scratch_.get());
      }
      out_.x.col(k) = Eigen::Map<const Vec>(tmp, n_);
    }
  }
  if (payload_) {
    for (long k = begin; k < end; ++k)
      payload_->Sample(k, out_.t[static_cast<std::size_t>(k)], out_.x.col(k).data());
  }
}

// coefficients_.col(k) = h^k / k! · ξ^(k)(t_n), so ξ(t) = Σ_k coefficients_.col(k) s^k,
// s = (t − t_n)/h: exactly the polynomial CVodeGetDky evaluates.
void Engine::TaylorCoefficients(int q, double tn, double h, bool direct) {
  coefficients_.resize(n_, q + 1);
  double* tmp = N_VGetArrayPointer_Serial(scratch_.get());
  double scale = 1.0;
  for (int k = 0; k <= q; ++k) {
    if (direct) {
      history_.DkyAtTn(k, tmp);
    } else {
      CVodeGetDky(cvode_.get(), tn, k, scratch_.get());
    }
    for (long i = 0; i < n_; ++i) coefficients_(i, k) = scale * tmp[i];
    scale *= h / static_cast<double>(k + 1);
  }
}

void Engine::EmitHorner(int q, double tn, double h, long begin, long end) {
  const double* c = coefficients_.data();  // column-major n × (q + 1)
  const long n = n_;
  for (long k = begin; k < end; ++k) {
    const double s = (out_.t[static_cast<std::size_t>(k)] - tn) / h;
    double* out = out_.x.col(k).data();
    if (n == 2) {  // the two chains side by side, in registers (the same operations per component)
      double v0 = c[q * 2], v1 = c[q * 2 + 1];
      for (int d = q - 1; d >= 0; --d) {
        v0 = v0 * s + c[d * 2];
        v1 = v1 * s + c[d * 2 + 1];
      }
      out[0] = v0;
      out[1] = v1;
    } else {
      for (long i = 0; i < n; ++i) {
        double v = c[q * n + i];
        for (int d = q - 1; d >= 0; --d) v = v * s + c[d * n + i];
        out[i] = v;
      }
    }
  }
}

bool Engine::Check(int flag, const char* function) {
  if (flag >= 0) return true;
  return Fail(SimStop::kSolverFailure,
              fmt::format("{} returned {}: {}", function, CVodeGetReturnFlagName(flag), data_.last_error));
}

bool Engine::Fail(SimStop stop, std::string message) {
  out_.status.stop = stop;
  out_.status.message = std::move(message);
  out_.status.t_reached = t_;
  return false;
}

void Engine::Complete() {
  out_.status.stop = SimStop::kCompleted;
  out_.status.t_reached = t_last_;
  out_.status.message = fmt::format("completed: {} samples, {} jumps", samples_.count, jumps());
}

void Engine::AccumulateCounters() {
  long v = 0;
  if (CVodeGetNumRhsEvals(cvode_.get(), &v) == CV_SUCCESS) rhs_evals_ += v;
  if (CVodeGetNumGEvals(cvode_.get(), &v) == CV_SUCCESS) root_evals_ += v;
}

Trajectory Engine::Finish() {
  if (cvode_) AccumulateCounters();
  out_.stats.steps = steps_;
  out_.stats.rhs_evals = rhs_evals_;
  out_.stats.root_evals = root_evals_;
  // The samples up to the first one not emitted.
  const long prefix = order_ == SampleOrder::kIncreasing
                          ? static_cast<long>(out_.t.size())
                          : std::find(filled_.begin(), filled_.end(), 0) - filled_.begin();
  out_.t.resize(static_cast<std::size_t>(prefix));
  out_.j.resize(static_cast<std::size_t>(prefix));
  if (several_modes_) out_.q.resize(static_cast<std::size_t>(prefix));
  out_.x.conservativeResize(n_, prefix);
  return std::move(out_);
}

}  // namespace hysid::hybrid
