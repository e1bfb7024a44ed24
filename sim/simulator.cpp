#include "sim/simulator.hpp"

#include <cmath>
#include <memory>
#include <stdexcept>
#include <type_traits>

#include <cvodes/cvodes.h>
#include <fmt/format.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sunnonlinsol/sunnonlinsol_fixedpoint.h>

#include "sim/nordsieck.hpp"
#include "sim/sundials_ptr.hpp"

namespace hysid {
namespace {

using namespace sundials_ptr;  // the owning SUNDIALS handles (sim/sundials_ptr.hpp)

// What CVODE's callbacks see.
struct CallbackData {
  const Model* model = nullptr;
  const Vec* alpha = nullptr;
  int guard_count = 0;
  bool nonfinite_rhs = false;
  std::string last_error;  // CVODE's last error message, for the status
};

int FlowRhs(sunrealtype /*t*/, N_Vector y, N_Vector ydot, void* user_data) {
  auto* data = static_cast<CallbackData*>(user_data);
  const Eigen::Index n = N_VGetLength_Serial(y);
  const Eigen::Map<const Eigen::VectorXd> x(N_VGetArrayPointer_Serial(y), n);
  Eigen::Map<Eigen::VectorXd> f(N_VGetArrayPointer_Serial(ydot), n);
  data->model->Flow(x, *data->alpha, f);
  if (!f.allFinite() || !x.allFinite()) {
    data->nonfinite_rhs = true;
    return -1;  // unrecoverable: CVODE stops with CV_RHSFUNC_FAIL
  }
  return 0;
}

int GuardFunctions(sunrealtype /*t*/, N_Vector y, sunrealtype* gout, void* user_data) {
  auto* data = static_cast<CallbackData*>(user_data);
  const Eigen::Index n = N_VGetLength_Serial(y);
  const Eigen::Map<const Eigen::VectorXd> x(N_VGetArrayPointer_Serial(y), n);
  Eigen::Map<Eigen::VectorXd> h(gout, data->guard_count);
  data->model->Guards(x, h);
  return 0;
}

void CaptureError(int /*error_code*/, const char* module, const char* function, char* msg, void* user_data) {
  static_cast<CallbackData*>(user_data)->last_error = fmt::format("{}/{}: {}", module, function, msg);
}

// One simulation: owns the CVODE objects and writes samples and jumps into the trajectory.
class Run {
 public:
  Run(const Model& model, const SampleGrid& grid, const SimOptions& options)
      : model_(model), options_(options), n_(model.state_size()) {
    sample_count_ = grid.size();
    dt_ = grid.dt;
    t_last_ = static_cast<double>(sample_count_ - 1) * dt_;
    out_.dt = dt_;
    out_.t.reserve(static_cast<std::size_t>(sample_count_));
    out_.j.reserve(static_cast<std::size_t>(sample_count_));
    out_.x.resize(n_, sample_count_);
    data_.model = &model_;
    data_.alpha = &model_.alpha();
    data_.guard_count = model_.guard_count();
  }

  Trajectory Execute(const Vec& x0) {
    if (!Setup(x0)) return Finish();
    t_ = 0.0;
    x_ = x0;
    // HyEQ rule 1: an initial state in D jumps before it flows.
    if (model_.InJumpSet(x_)) {
      if (!JumpChain(-1)) return Finish();
      if (!ReInit()) return Finish();
    }
    EmitAt(t_, x_);  // sample 0
    while (next_sample_ < sample_count_) {
      if (stats_steps_ >= options_.max_steps) {
        return Fail(
            SimStop::kSolverFailure,
            fmt::format("step budget of {} CVODE steps exhausted at t = {:.17g}", options_.max_steps, t_));
      }
      sunrealtype tret = 0.0;
      const int flag = CVode(cvode_.get(), t_last_, y_.get(), &tret, CV_ONE_STEP);
      ++stats_steps_;
      if (flag < 0) {
        if (data_.nonfinite_rhs) {
          return Fail(SimStop::kNonFinite, fmt::format("flow map is not finite near t = {:.17g}", tret));
        }
        return Fail(SimStop::kSolverFailure,
                    fmt::format("CVode returned {} at t = {:.17g}: {}", CVodeGetReturnFlagName(flag), tret,
                                data_.last_error));
      }
      const Eigen::Map<const Eigen::VectorXd> y(N_VGetArrayPointer_Serial(y_.get()), n_);
      if (!y.allFinite()) {
        return Fail(SimStop::kNonFinite, fmt::format("state not finite at t = {:.17g}", tret));
      }
      if (flag == CV_ROOT_RETURN) {
        EmitInterpolated(tret, /*inclusive=*/false);
        t_ = tret;
        x_ = y;
        const int guard = FiredGuard();
        model_.ProjectOntoGuard(guard, x_);
        if (!JumpChain(guard)) return Finish();
        if (!CheckZenoAndBudget()) return Finish();
        if (!ReInit()) return Finish();
        continue;
      }
      // CV_SUCCESS (one step) or CV_TSTOP_RETURN (reached the last sample time).
      EmitInterpolated(tret, /*inclusive=*/true);
      t_ = tret;
      if (!model_.InFlowSet(y) && !model_.InJumpSet(y)) {
        return Fail(SimStop::kLeftDomain,
                    fmt::format("state left C and D at t = {:.17g} without a located crossing", tret));
      }
      if (flag == CV_TSTOP_RETURN) {
        // Samples at t_last (within rounding) are taken from the returned state.
        while (next_sample_ < sample_count_) EmitAt(SampleTime(next_sample_), y);
      }
    }
    out_.status.stop = SimStop::kCompleted;
    out_.status.t_reached = t_last_;
    out_.status.message = fmt::format("completed: {} samples, {} jumps", out_.size(), jumps_);
    return Finish();
  }

 private:
  double SampleTime(long k) const { return static_cast<double>(k) * dt_; }

  bool Setup(const Vec& x0) {
    SUNContext ctx = nullptr;
    if (SUNContext_Create(nullptr, &ctx) != 0) {
      return FailBool(SimStop::kSolverFailure, "SUNContext_Create failed");
    }
    ctx_.reset(ctx);
    y_.reset(N_VNew_Serial(n_, ctx_.get()));
    scratch_.reset(N_VNew_Serial(n_, ctx_.get()));
    if (!y_ || !scratch_) return FailBool(SimStop::kSolverFailure, "N_VNew_Serial failed");
    // Fused vector kernels (off by default for serial vectors): CVODE's Adams updates and
    // CVodeGetDky then run as one loop each instead of chains of N_VLinearSum calls.
    N_VEnableFusedOps_Serial(y_.get(), SUNTRUE);
    N_VEnableFusedOps_Serial(scratch_.get(), SUNTRUE);
    N_VEnableFusedOps_Serial(y_.get(), SUNTRUE);
    Eigen::Map<Eigen::VectorXd>(N_VGetArrayPointer_Serial(y_.get()), n_) = x0;
    cvode_.reset(CVodeCreate(CV_ADAMS, ctx_.get()));
    if (!cvode_) return FailBool(SimStop::kSolverFailure, "CVodeCreate failed");
    void* mem = cvode_.get();
    if (!Check(CVodeSetErrHandlerFn(mem, CaptureError, &data_), "CVodeSetErrHandlerFn")) return false;
    {
      const nordsieck::CloneRecorder recorder(y_.get());
      if (!Check(CVodeInit(mem, FlowRhs, 0.0, y_.get()), "CVodeInit")) return false;
      history_.Locate(mem, recorder.clones(), n_);
    }
    if (!Check(CVodeSStolerances(mem, options_.rtol, options_.atol), "CVodeSStolerances")) return false;
    nls_.reset(SUNNonlinSol_FixedPoint(y_.get(), 0, ctx_.get()));
    if (!nls_) return FailBool(SimStop::kSolverFailure, "SUNNonlinSol_FixedPoint failed");
    if (!Check(CVodeSetNonlinearSolver(mem, nls_.get()), "CVodeSetNonlinearSolver")) return false;
    if (!Check(CVodeSetUserData(mem, &data_), "CVodeSetUserData")) return false;
    if (!Check(CVodeSetStopTime(mem, t_last_), "CVodeSetStopTime")) return false;
    if (!Check(CVodeRootInit(mem, model_.guard_count(), GuardFunctions), "CVodeRootInit")) {
      return false;
    }
    std::vector<int> directions;
    for (const Guard& g : model_.spec().guards) directions.push_back(ToCvodeDirection(g.direction));
    if (!Check(CVodeSetRootDirection(mem, directions.data()), "CVodeSetRootDirection")) return false;
    if (!Check(CVodeSetNoInactiveRootWarn(mem), "CVodeSetNoInactiveRootWarn")) return false;
    return true;
  }

  bool ReInit() {
    AccumulateCounters();
    Eigen::Map<Eigen::VectorXd>(N_VGetArrayPointer_Serial(y_.get()), n_) = x_;
    // A jump at the last sample time leaves nothing to integrate.
    if (t_ >= t_last_) {
      while (next_sample_ < sample_count_) EmitAt(SampleTime(next_sample_), x_);
      return true;
    }
    return Check(CVodeReInit(cvode_.get(), t_, y_.get()), "CVodeReInit");
  }

  void AccumulateCounters() {
    long v = 0;
    if (CVodeGetNumRhsEvals(cvode_.get(), &v) == CV_SUCCESS) rhs_evals_ += v;
    if (CVodeGetNumGEvals(cvode_.get(), &v) == CV_SUCCESS) root_evals_ += v;
  }

  int FiredGuard() const { return sundials_ptr::FiredGuard(cvode_.get(), model_.guard_count()); }

  // Applies the jump map at t_ to x_, then again while ξ+ ∈ D (rule 1). False when stopped.
  bool JumpChain(int guard) {
    Vec post(n_);
    for (int chain = 0;; ++chain) {
      if (chain >= options_.max_jumps_at_one_time) {
        out_.status.zeno_time = t_;
        return FailBool(SimStop::kZeno,
                        fmt::format("Zeno: {} jumps at t = {:.17g} (the jump map keeps the state "
                                    "in D); estimated accumulation time {:.17g}",
                                    chain, t_, t_));
      }
      model_.Jump(x_, model_.beta(), post);
      ++jumps_;
      out_.jumps.push_back(JumpRecord{jumps_, t_, chain == 0 ? guard : -1, x_, post});
      x_ = post;
      if (!x_.allFinite()) {
        return FailBool(SimStop::kNonFinite,
                        fmt::format("jump map gave a non-finite state at t = {:.17g}", t_));
      }
      if (!model_.InJumpSet(x_)) return true;
    }
  }

  // Intervals count as shrinking only when each is below this fraction of the one before: constant
  // intervals (a stiff spring's half-periods) equal up to rounding are not an accumulation.
  static constexpr double kZenoMaxRatio = 1.0 - 1e-3;

  bool CheckZenoAndBudget() {
    const auto& jumps = out_.jumps;
    const int window = options_.zeno_window;
    const std::size_t m = jumps.size();
    if (m >= static_cast<std::size_t>(window) + 2) {
      const double last = jumps[m - 1].t - jumps[m - 2].t;
      bool shrinking = last < options_.zeno_interval;
      for (int i = 0; shrinking && i < window; ++i) {
        const double newer = jumps[m - 1 - i].t - jumps[m - 2 - i].t;
        const double older = jumps[m - 2 - i].t - jumps[m - 3 - i].t;
        shrinking = newer < kZenoMaxRatio * older;
      }
      if (shrinking) {
        const double prev = jumps[m - 2].t - jumps[m - 3].t;
        const double rho = last / prev;  // geometric ratio of the intervals
        const double tz = jumps[m - 1].t + last * rho / (1.0 - rho);
        out_.status.zeno_time = tz;
        return FailBool(SimStop::kZeno,
                        fmt::format("Zeno: jump interval {:.3g} s and shrinking (ratio {:.6g}) "
                                    "after {} jumps; estimated accumulation time {:.17g}",
                                    last, rho, m, tz));
      }
    }
    if (jumps_ >= options_.max_jumps) {
      return FailBool(SimStop::kJumpBudget, fmt::format("jump budget of {} jumps exhausted at t = {:.17g}",
                                                        options_.max_jumps, t_));
    }
    return true;
  }

  void EmitAt(double t, ConstVecRef x) {
    out_.t.push_back(t);
    out_.j.push_back(jumps_);
    out_.x.col(next_sample_) = x;
    ++next_sample_;
  }

  // Samples with t_k < t_hi (or ≤ when inclusive) from the last step's interpolating polynomial.
  // Few samples: y(t_k) each, as CVodeGetDky(t_k, 0). Many: the polynomial's q + 1 Taylor
  // coefficients at t_n once (as CVodeGetDky(t_n, k), k = 0..q), then Horner's rule per sample. Both
  // read CVODE's Nordsieck array directly when history_ allows (the same bits, sim/nordsieck.hpp).
  void EmitInterpolated(double t_hi, bool inclusive) {
    long end = next_sample_;
    while (end < sample_count_ && (inclusive ? SampleTime(end) <= t_hi : SampleTime(end) < t_hi)) {
      ++end;
    }
    const long count = end - next_sample_;
    if (count == 0) return;
    void* mem = cvode_.get();
    int q = 0;
    sunrealtype tn = 0.0, h = 0.0;
    CVodeGetLastOrder(mem, &q);
    CVodeGetCurrentTime(mem, &tn);
    CVodeGetLastStep(mem, &h);
    const bool direct = history_.Prepare(mem, q, tn, h, scratch_.get());
    double* tmp = N_VGetArrayPointer_Serial(scratch_.get());
    if (count <= q + 1 || h == 0.0) {
      for (long k = next_sample_; k < end; ++k) {
        const double t = std::min(SampleTime(k), t_hi);
        if (direct) {
          history_.Dky(t, 0, tmp);
        } else {
          CVodeGetDky(mem, t, 0, scratch_.get());
        }
        EmitAt(SampleTime(k), Eigen::Map<const Eigen::VectorXd>(tmp, n_));
      }
      return;
    }
    TaylorCoefficients(q, tn, h, direct);
    EmitHorner(q, tn, h, t_hi, end);
  }

  // coefficients_.col(k) = h^k / k! · y^(k)(t_n), so y(t) = Σ_k coefficients_.col(k) s^k,
  // s = (t − t_n)/h: exactly the polynomial CVodeGetDky evaluates.
  void TaylorCoefficients(int q, double tn, double h, bool direct) {
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

  void EmitHorner(int q, double tn, double h, double t_hi, long end) {
    const double* c = coefficients_.data();  // column-major n × (q + 1)
    const long n = n_;
    for (long k = next_sample_; k < end; ++k) {
      const double s = (std::min(SampleTime(k), t_hi) - tn) / h;
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
      out_.t.push_back(SampleTime(k));
      out_.j.push_back(jumps_);
    }
    next_sample_ = end;
  }

  bool Check(int flag, const char* function) {
    if (flag >= 0) return true;
    return FailBool(SimStop::kSolverFailure, fmt::format("{} returned {}: {}", function,
                                                         CVodeGetReturnFlagName(flag), data_.last_error));
  }

  bool FailBool(SimStop stop, std::string message) {
    out_.status.stop = stop;
    out_.status.message = std::move(message);
    out_.status.t_reached = t_;
    return false;
  }

  Trajectory Fail(SimStop stop, std::string message) {
    FailBool(stop, std::move(message));
    return Finish();
  }

  Trajectory Finish() {
    if (cvode_) AccumulateCounters();
    out_.stats.steps = stats_steps_;
    out_.stats.rhs_evals = rhs_evals_;
    out_.stats.root_evals = root_evals_;
    out_.x.conservativeResize(n_, next_sample_);
    return std::move(out_);
  }

  const Model& model_;
  SimOptions options_;
  int n_ = 0;
  long sample_count_ = 0;
  double dt_ = 0.0;
  double t_last_ = 0.0;
  long next_sample_ = 0;
  int jumps_ = 0;
  double t_ = 0.0;
  Vec x_;
  Mat coefficients_;
  nordsieck::History history_;
  long stats_steps_ = 0;
  long rhs_evals_ = 0;
  long root_evals_ = 0;
  CallbackData data_;
  Trajectory out_;
  // Declared in creation order; destroyed in reverse.
  ContextPtr ctx_;
  NVectorPtr y_;
  NVectorPtr scratch_;
  NonlinearSolverPtr nls_;
  CvodePtr cvode_;
};

}  // namespace

long SampleGrid::size() const { return static_cast<long>(std::floor(t_end / dt + 1e-9)) + 1; }

bool SampleGrid::IsValid(std::string* error) const {
  auto fail = [&](const std::string& what) {
    if (error) *error = what;
    return false;
  };
  if (!std::isfinite(dt) || !(dt > 0.0)) {
    return fail(fmt::format("SampleGrid::dt = {}. Violated constraint: dt > 0 and finite", dt));
  }
  if (!std::isfinite(t_end) || !(t_end > 0.0)) {
    return fail(fmt::format("SampleGrid::t_end = {}. Violated constraint: t_end > 0 and finite", t_end));
  }
  if (t_end / dt > 1e9) {
    return fail(
        fmt::format("SampleGrid: t_end/dt = {:.3g}. Violated constraint: at most 1e9 "
                    "samples",
                    t_end / dt));
  }
  return true;
}

bool SimOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& what) {
    if (error) *error = what;
    return false;
  };
  if (!(rtol > 0.0) || !std::isfinite(rtol)) {
    return fail(fmt::format("SimOptions::rtol = {}. Violated constraint: rtol > 0", rtol));
  }
  if (!(atol > 0.0) || !std::isfinite(atol)) {
    return fail(fmt::format("SimOptions::atol = {}. Violated constraint: atol > 0", atol));
  }
  if (max_steps < 1) {
    return fail(fmt::format("SimOptions::max_steps = {}. Violated constraint: max_steps >= 1", max_steps));
  }
  if (max_jumps < 1) {
    return fail(fmt::format("SimOptions::max_jumps = {}. Violated constraint: max_jumps >= 1", max_jumps));
  }
  if (!(zeno_interval >= 0.0)) {
    return fail(fmt::format("SimOptions::zeno_interval = {}. Violated constraint: zeno_interval >= 0",
                            zeno_interval));
  }
  if (zeno_window < 1) {
    return fail(
        fmt::format("SimOptions::zeno_window = {}. Violated constraint: zeno_window >= 1", zeno_window));
  }
  if (max_jumps_at_one_time < 1) {
    return fail(fmt::format("SimOptions::max_jumps_at_one_time = {}. Violated constraint: >= 1",
                            max_jumps_at_one_time));
  }
  return true;
}

const char* ToString(SimStop stop) {
  switch (stop) {
    case SimStop::kCompleted: return "completed";
    case SimStop::kZeno: return "zeno";
    case SimStop::kJumpBudget: return "jump-budget";
    case SimStop::kSolverFailure: return "solver-failure";
    case SimStop::kNonFinite: return "non-finite";
    case SimStop::kLeftDomain: return "left-domain";
  }
  return "unknown";
}

Trajectory Simulate(const Model& model, const Vec& x0, const SampleGrid& grid, const SimOptions& options) {
  std::string error;
  if (!grid.IsValid(&error) || !options.IsValid(&error)) throw std::invalid_argument(error);
  if (x0.size() != model.state_size()) {
    throw std::invalid_argument(fmt::format("x0 has {} entries; model '{}' has {} states", x0.size(),
                                            model.name(), model.state_size()));
  }
  if (!x0.allFinite()) throw std::invalid_argument("x0 is not finite");
  if (!model.InFlowSet(x0) && !model.InJumpSet(x0)) {
    throw std::invalid_argument(fmt::format("x0 lies outside C and D of model '{}'", model.name()));
  }
  Run run(model, grid, options);
  return run.Execute(x0);
}

}  // namespace hysid
