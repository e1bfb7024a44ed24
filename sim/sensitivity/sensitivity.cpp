#include "sim/sensitivity/sensitivity.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <set>
#include <stdexcept>
#include <type_traits>

#include <cvodes/cvodes.h>
#include <fmt/format.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sunnonlinsol/sunnonlinsol_fixedpoint.h>

#include "sim/sundials_ptr.hpp"

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
  u.x0 = with_x0;
  return u;
}

std::vector<std::string> Unknowns::Names(const Model& model) const {
  const ModelSpec& spec = model.spec();
  std::vector<std::string> names;
  for (int i : alpha) names.push_back(spec.alpha[static_cast<std::size_t>(i)].name);
  for (int i : beta) names.push_back(spec.beta[static_cast<std::size_t>(i)].name);
  if (x0) {
    for (const std::string& s : spec.state_names) names.push_back(fmt::format("x0[{}]", s));
  }
  return names;
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
  return check(alpha, model.alpha_size(), "alpha") && check(beta, model.beta_size(), "beta");
}

Vec HybridParameters::Theta(const Unknowns& u) const {
  Vec theta(u.size(static_cast<int>(x0.size())));
  Eigen::Index c = 0;
  for (int i : u.alpha) theta[c++] = alpha[i];
  for (int i : u.beta) theta[c++] = beta[i];
  if (u.x0) theta.tail(x0.size()) = x0;
  return theta;
}

HybridParameters HybridParameters::WithTheta(const Unknowns& u, const ConstVecRef& theta) const {
  HybridParameters out = *this;
  Eigen::Index c = 0;
  for (int i : u.alpha) out.alpha[i] = theta[c++];
  for (int i : u.beta) out.beta[i] = theta[c++];
  if (u.x0) out.x0 = theta.tail(x0.size());
  return out;
}

bool SensitivityOptions::IsValid(std::string* error) const { return sim.IsValid(error); }

namespace {

using namespace sundials_ptr;  // the owning SUNDIALS handles (sim/sundials_ptr.hpp)

// What the CVODE callbacks see.
struct CallbackData {
  const Model* model = nullptr;
  const Vec* alpha = nullptr;
  const std::vector<int>* alpha_unknown = nullptr;
  int n = 0;  // states; the integrated vector is ξ, or ξ and then S (n × p, column-major)
  int p = 0;  // sensitivities integrated with ξ (0: none)
  int guard_count = 0;
  bool nonfinite_rhs = false;
  Mat jac, phi;  // scratch, n × n and n × |α|
  std::string last_error;
};

// ξ' = f(ξ) = φ(ξ)α and, when the sensitivities are integrated with ξ, S' = (∂f/∂ξ) S + ∂f/∂θ:
// column i of ∂f/∂θ is column i of φ for α's unknowns, zero for β's and ξ0's.
int FlowRhs(sunrealtype /*t*/, N_Vector y, N_Vector ydot, void* user_data) {
  auto* data = static_cast<CallbackData*>(user_data);
  const Eigen::Index n = data->n, p = data->p;
  const Eigen::Map<const Vec> x(N_VGetArrayPointer_Serial(y), n);
  Eigen::Map<Vec> f(N_VGetArrayPointer_Serial(ydot), n);
  data->model->Flow(x, *data->alpha, f);
  if (!f.allFinite() || !x.allFinite()) {
    data->nonfinite_rhs = true;
    return -1;
  }
  if (p == 0) return 0;
  const Eigen::Map<const Mat> s(N_VGetArrayPointer_Serial(y) + n, n, p);
  Eigen::Map<Mat> sdot(N_VGetArrayPointer_Serial(ydot) + n, n, p);
  data->model->FlowJacobian(x, *data->alpha, data->jac);
  data->model->Phi(x, data->phi);
  sdot.noalias() = data->jac * s;
  const auto& au = *data->alpha_unknown;
  for (std::size_t i = 0; i < au.size(); ++i) sdot.col(static_cast<Eigen::Index>(i)) += data->phi.col(au[i]);
  return 0;
}

int GuardFunctions(sunrealtype /*t*/, N_Vector y, sunrealtype* gout, void* user_data) {
  auto* data = static_cast<CallbackData*>(user_data);
  const Eigen::Map<const Vec> x(N_VGetArrayPointer_Serial(y), data->n);
  Eigen::Map<Vec> h(gout, data->guard_count);
  data->model->Guards(x, h);
  return 0;
}

void CaptureError(int /*code*/, const char* module, const char* function, char* msg, void* user_data) {
  static_cast<CallbackData*>(user_data)->last_error = fmt::format("{}/{}: {}", module, function, msg);
}

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

enum class Leg { kForward, kBackward };

// One integration: owns the CVODE objects; plain or matched (segment_of_sample) mode.
class SensRun {
 public:
  SensRun(const Model& model, const HybridParameters& params, const Unknowns& unknowns,
          const SampleGrid& grid, const SensitivityOptions& options, const std::vector<int>* segments,
          const std::vector<double>* times = nullptr)
      : model_(model),
        params_(params),
        unknowns_(unknowns),
        options_(options),
        segments_(segments),
        n_(model.state_size()),
        p_(unknowns.size(model.state_size())),
        sens_(options.sensitivities) {
    times_ = times;
    sample_count_ = times ? static_cast<long>(times->size()) : grid.size();
    dt_ = times ? times->back() / static_cast<double>(std::max<long>(1, sample_count_ - 1)) : grid.dt;
    t_last_ = times ? times->back() : static_cast<double>(sample_count_ - 1) * dt_;
    Trajectory& tr = out_.trajectory;
    tr.dt = dt_;
    tr.t.assign(static_cast<std::size_t>(sample_count_), 0.0);
    tr.j.assign(static_cast<std::size_t>(sample_count_), 0);
    tr.x.resize(n_, sample_count_);
    out_.parameters = p_;
    if (sens_) out_.sensitivities.resize(static_cast<Eigen::Index>(n_) * p_, sample_count_);
    filled_.assign(static_cast<std::size_t>(sample_count_), 0);
    data_.model = &model_;
    data_.alpha = &params_.alpha;
    data_.alpha_unknown = &unknowns_.alpha;
    data_.n = n_;
    data_.p = sens_ ? p_ : 0;
    data_.guard_count = model_.guard_count();
    data_.jac.resize(n_, n_);
    data_.phi.resize(n_, model_.alpha_size());
  }

  SensitivityTrajectory Execute() {
    if (!Setup()) return Finish();
    t_ = 0.0;
    x_ = params_.x0;
    S_ = Mat::Zero(n_, p_);
    if (unknowns_.x0) S_.rightCols(n_).setIdentity();
    if (model_.InJumpSet(x_) && !JumpAt(-1, /*fixed_time=*/true)) return Finish();
    if (segments_ ? RunMatched() : RunPlain()) {
      out_.trajectory.status.stop = SimStop::kCompleted;
      out_.trajectory.status.t_reached = t_last_;
      out_.trajectory.status.message =
          fmt::format("completed: {} samples, {} jumps", sample_count_, out_.trajectory.jumps.size());
    }
    return Finish();
  }

 private:
  double SampleTime(long k) const {
    return times_ ? (*times_)[static_cast<std::size_t>(k)] : static_cast<double>(k) * dt_;
  }
  int jumps() const { return static_cast<int>(out_.trajectory.jumps.size()); }

  bool Setup() {
    SUNContext ctx = nullptr;
    if (SUNContext_Create(nullptr, &ctx) != 0)
      return Fail(SimStop::kSolverFailure, "SUNContext_Create failed");
    ctx_.reset(ctx);
    // With sensitivities, ξ and S (n × p, column-major) are integrated as one vector by CVODE: one
    // set of vector operations per step instead of CVODES' p + 1 (its simultaneous corrector), and
    // the error test covers S as CVODES' sensitivity error control does.
    y_.reset(N_VNew_Serial(sens_ ? n_ * (1 + p_) : n_, ctx_.get()));
    if (!y_) return Fail(SimStop::kSolverFailure, "N_VNew_Serial failed");
    // Fused vector kernels (off by default for serial vectors; clones inherit them): the Adams
    // updates and the dense output then run as one loop each.
    N_VEnableFusedOps_Serial(y_.get(), SUNTRUE);
    N_VConst(0.0, y_.get());
    Eigen::Map<Vec>(N_VGetArrayPointer_Serial(y_.get()), n_) = params_.x0;
    cvode_.reset(CVodeCreate(CV_ADAMS, ctx_.get()));
    if (!cvode_) return Fail(SimStop::kSolverFailure, "CVodeCreate failed");
    void* mem = cvode_.get();
    if (!Check(CVodeSetErrHandlerFn(mem, CaptureError, &data_), "CVodeSetErrHandlerFn") ||
        !Check(CVodeInit(mem, FlowRhs, 0.0, y_.get()), "CVodeInit") ||
        !Check(CVodeSStolerances(mem, options_.sim.rtol, options_.sim.atol), "CVodeSStolerances") ||
        !Check(CVodeSetUserData(mem, &data_), "CVodeSetUserData") ||
        !Check(CVodeSetMaxNumSteps(mem, -1), "CVodeSetMaxNumSteps")) {
      return false;
    }
    nls_.reset(SUNNonlinSol_FixedPoint(y_.get(), 0, ctx_.get()));
    return nls_ && Check(CVodeSetNonlinearSolver(mem, nls_.get()), "CVodeSetNonlinearSolver");
  }

  // Restarts the integration at (t_, x_, S_) towards `tstop`, with or without the guards.
  bool Start(double tstop, bool roots) {
    void* mem = cvode_.get();
    Eigen::Map<Vec>(N_VGetArrayPointer_Serial(y_.get()), n_) = x_;
    if (sens_) Eigen::Map<Mat>(N_VGetArrayPointer_Serial(y_.get()) + n_, n_, p_) = S_;
    AccumulateCounters();
    if (!Check(CVodeReInit(mem, t_, y_.get()), "CVodeReInit")) return false;
    if (!Check(CVodeSetStopTime(mem, tstop), "CVodeSetStopTime")) return false;
    if (sens_) {
      SetWindowEnd(window_b_, t_, x_, S_);
      window_a_ = window_b_;
    }
    return roots ? EnableRoots() : Check(CVodeRootInit(mem, 0, nullptr), "CVodeRootInit");
  }

  bool EnableRoots() {
    void* mem = cvode_.get();
    if (!Check(CVodeRootInit(mem, model_.guard_count(), GuardFunctions), "CVodeRootInit")) return false;
    std::vector<int> directions;
    for (const Guard& g : model_.spec().guards) directions.push_back(ToCvodeDirection(g.direction));
    return Check(CVodeSetRootDirection(mem, directions.data()), "CVodeSetRootDirection") &&
           Check(CVodeSetNoInactiveRootWarn(mem), "CVodeSetNoInactiveRootWarn");
  }

  bool DisableRoots() { return Check(CVodeRootInit(cvode_.get(), 0, nullptr), "CVodeRootInit"); }

  // One internal step; the flag (≥ 0) or −1 after recording the failure. *tret: the time reached.
  int Step(double tout, double* tret) {
    if (steps_ >= options_.sim.max_steps) {
      Fail(SimStop::kSolverFailure, fmt::format("step budget of {} CVODE steps exhausted near t = {:.17g}",
                                                options_.sim.max_steps, *tret));
      return -1;
    }
    ++steps_;
    const int flag = CVode(cvode_.get(), tout, y_.get(), tret, CV_ONE_STEP);
    if (flag < 0) {
      if (data_.nonfinite_rhs) {
        Fail(SimStop::kNonFinite, fmt::format("flow map is not finite near t = {:.17g}", *tret));
      } else {
        Fail(SimStop::kSolverFailure, fmt::format("CVode returned {} at t = {:.17g}: {}",
                                                  CVodeGetReturnFlagName(flag), *tret, data_.last_error));
      }
      return -1;
    }
    if (!Eigen::Map<const Vec>(N_VGetArrayPointer_Serial(y_.get()), n_).allFinite()) {
      Fail(SimStop::kNonFinite, fmt::format("state not finite at t = {:.17g}", *tret));
      return -1;
    }
    return flag;
  }

  // Sample k on segment `segment`: the state from CVODE's interpolating polynomial, S_k by cubic
  // Hermite interpolation between the last two returns (S and S' at both ends; error ~h⁴/384·|S⁗|,
  // about 1e-9 relative on the §5 system at rtol 1e-12): cheaper per sample than the polynomial of
  // all n(1 + p) entries.
  void Emit(long k, int segment) {
    const double t = SampleTime(k);
    InterpolateState(t, out_.trajectory.x.col(k).data());
    MarkSample(k, segment);
    if (!sens_) return;
    double* s = out_.sensitivities.col(k).data();
    const Eigen::Index size = static_cast<Eigen::Index>(n_) * p_;
    const double h = window_b_.t - window_a_.t;
    if (h == 0.0) {
      std::copy_n(window_b_.s.data(), size, s);
      return;
    }
    const double u = (t - window_a_.t) / h, u2 = u * u, u3 = u2 * u;
    const double ca = 2 * u3 - 3 * u2 + 1, cda = (u3 - 2 * u2 + u) * h, cb = -2 * u3 + 3 * u2,
                 cdb = (u3 - u2) * h;
    const double *sa = window_a_.s.data(), *da = window_a_.d.data(), *sb = window_b_.s.data(),
                 *db = window_b_.d.data();
    for (Eigen::Index i = 0; i < size; ++i) s[i] = ca * sa[i] + cda * da[i] + cb * sb[i] + cdb * db[i];
  }

  void MarkSample(long k, int segment) {
    out_.trajectory.t[static_cast<std::size_t>(k)] = SampleTime(k);
    out_.trajectory.j[static_cast<std::size_t>(k)] = segment;
    filled_[static_cast<std::size_t>(k)] = 1;
  }

  // S and S' = (∂f/∂ξ)S + ∂f/∂θ at one end of the interpolation window.
  struct WindowEnd {
    double t = 0.0;
    Mat s, d;
  };
  void SetWindowEnd(WindowEnd& end, double t, const Vec& x, const Mat& s) {
    end.t = t;
    end.s = s;
    model_.FlowJacobian(x, params_.alpha, data_.jac);
    model_.Phi(x, data_.phi);
    end.d.noalias() = data_.jac * s;
    for (std::size_t i = 0; i < unknowns_.alpha.size(); ++i) {
      end.d.col(static_cast<Eigen::Index>(i)) += data_.phi.col(unknowns_.alpha[i]);
    }
  }
  // ξ(t) into out[0..n) from the last step's polynomial: CVodeGetDky for a few samples per step; for many,
  // its q + 1 Taylor coefficients at t_n once (as Simulate) and Horner's rule per sample.
  void InterpolateState(double t, double* out) {
    void* mem = cvode_.get();
    if (coefficients_state_ == 0) {
      int q = 0;
      sunrealtype tn = 0.0, h = 0.0;
      CVodeGetLastOrder(mem, &q);
      CVodeGetCurrentTime(mem, &tn);
      CVodeGetLastStep(mem, &h);
      coefficients_state_ = 1;
      if (h != 0.0 && std::abs(h) > (q + 1) * dt_) {
        coefficients_.resize(n_, q + 1);
        double scale = 1.0;
        for (int k = 0; k <= q; ++k) {
          CVodeGetDky(mem, tn, k, y_scratch());
          coefficients_.col(k) = scale * Eigen::Map<const Vec>(N_VGetArrayPointer_Serial(y_scratch()), n_);
          scale *= h / static_cast<double>(k + 1);
        }
        horner_tn_ = tn;
        horner_h_ = h;
        coefficients_state_ = 2;
      }
    }
    if (coefficients_state_ == 1) {
      CVodeGetDky(mem, t, 0, y_scratch());
      std::copy_n(N_VGetArrayPointer_Serial(y_scratch()), n_, out);
      return;
    }
    const double u = (t - horner_tn_) / horner_h_;
    const Eigen::Index q = coefficients_.cols() - 1;
    const double* c = coefficients_.data();  // column-major n × (q + 1)
    for (int i = 0; i < n_; ++i) {
      double v = c[q * n_ + i];
      for (Eigen::Index d = q - 1; d >= 0; --d) v = v * u + c[d * n_ + i];
      out[i] = v;
    }
  }

  // After a return at tret: the window becomes (previous return, tret).
  void Advance(double tret) {
    coefficients_state_ = 0;
    if (!sens_) return;
    std::swap(window_a_, window_b_);
    returned_s_ = Eigen::Map<const Mat>(N_VGetArrayPointer_Serial(y_.get()) + n_, n_, p_);
    SetWindowEnd(window_b_, tret, Eigen::Map<const Vec>(N_VGetArrayPointer_Serial(y_.get()), n_),
                 returned_s_);
  }

  // Sample k set to the given state (and S_ when sens), on segment `segment`.
  void StoreSample(long k, int segment, const ConstVecRef& x, const Mat* s) {
    Trajectory& tr = out_.trajectory;
    tr.t[static_cast<std::size_t>(k)] = SampleTime(k);
    tr.j[static_cast<std::size_t>(k)] = segment;
    tr.x.col(k) = x;
    if (s && sens_) out_.sensitivities.col(k) = Eigen::Map<const Vec>(s->data(), s->size());
    filled_[static_cast<std::size_t>(k)] = 1;
  }

  N_Vector y_scratch() {
    if (!scratch_) scratch_.reset(N_VClone(y_.get()));
    return scratch_.get();
  }

  // The state and S at the last return (the root, at a root return).
  void ReadReturned(Vec* x, Mat* s) {
    *x = Eigen::Map<const Vec>(N_VGetArrayPointer_Serial(y_.get()), n_);
    if (sens_) *s = window_b_.s;  // read by Advance at this return
  }

  int FiredGuard() const { return sundials_ptr::FiredGuard(cvode_.get(), model_.guard_count()); }

  // ---- plain mode: as Simulate ------------------------------------------------------------------
  bool RunPlain() {
    long next = 0;
    for (;;) {
      if (t_ >= t_last_) {  // a jump at the last sample time leaves nothing to integrate
        for (; next < sample_count_; ++next) StoreSample(next, jumps(), x_, &S_);
        return true;
      }
      if (!Start(t_last_, /*roots=*/true)) return false;
      if (next == 0) StoreSample(next++, jumps(), x_, &S_);
      for (;;) {
        double tret = t_;
        const int flag = Step(t_last_, &tret);
        if (flag < 0) return false;
        Advance(tret);
        const bool root = flag == CV_ROOT_RETURN;
        for (; next < sample_count_ && (root ? SampleTime(next) < tret : SampleTime(next) <= tret); ++next) {
          Emit(next, jumps());
        }
        if (flag == CV_TSTOP_RETURN) {
          for (; next < sample_count_; ++next) Emit(next, jumps());
          return true;
        }
        if (root) {
          t_ = tret;
          ReadReturned(&x_, &S_);
          if (!JumpAt(FiredGuard(), false) || !CheckZenoAndBudget()) return false;
          break;
        }
      }
    }
  }

  // ---- matched mode ---------------------------------------------------------------------------
  bool RunMatched() {
    const std::vector<int>& seg = *segments_;
    const int last = seg.back();
    long lo = 0;
    for (int j = 0; j <= last; ++j) {
      long hi = lo;
      while (hi + 1 < sample_count_ && seg[static_cast<std::size_t>(hi + 1)] == j) ++hi;
      long first_forward = lo;
      while (first_forward <= hi && SampleTime(first_forward) < t_) ++first_forward;
      if (first_forward > lo && !RunLeg(Leg::kBackward, j, lo, first_forward - 1, false)) return false;
      if (!RunLeg(Leg::kForward, j, first_forward, hi, j < last)) return false;
      lo = hi + 1;
    }
    return true;
  }

  // Samples [from, to] of segment j, forward (from t_ up; `need_jump`: then jump at the model's next
  // guard crossing) or backward (from t_ down to `from`).
  bool RunLeg(Leg leg, int j, long from, long to, bool need_jump) {
    if (leg == Leg::kForward && t_ >= t_last_) {
      for (long k = from; k <= to; ++k) StoreSample(k, j, x_, &S_);
      if (need_jump) return Missing(j);
      return true;
    }
    const double tstop = leg == Leg::kForward ? t_last_ : SampleTime(from);
    if (!Start(tstop, leg == Leg::kForward)) return false;
    const Vec x_start = x_;
    const Mat s_start = S_;
    long next = leg == Leg::kForward ? from : to;
    auto pending = [&] { return leg == Leg::kForward ? next <= to : next >= from; };
    bool jumped = false;
    double t_jump = 0.0;
    Vec x_jump;
    Mat s_jump;
    int guard = 0;
    while (pending() || (need_jump && !jumped)) {
      double tret = t_;
      const int flag = Step(tstop, &tret);
      if (flag < 0) return false;
      Advance(tret);
      if (leg == Leg::kForward) {
        for (; next <= to && SampleTime(next) <= tret; ++next) Emit(next, j);
      } else {
        for (; next >= from && SampleTime(next) >= tret; --next) Emit(next, j);
      }
      if (flag == CV_ROOT_RETURN) {
        if (!need_jump) {
          ++out_.extra_jumps;
          continue;
        }
        if (!jumped) {
          jumped = true;
          t_jump = tret;
          ReadReturned(&x_jump, &s_jump);
          guard = FiredGuard();
          if (!DisableRoots()) return false;
        }
      }
      if (flag == CV_TSTOP_RETURN) {
        for (; pending(); leg == Leg::kForward ? ++next : --next) Emit(next, j);
        if (need_jump && !jumped) return Missing(j);
        break;
      }
    }
    if (!jumped) {
      x_ = x_start;  // a backward leg or the last segment leaves the segment's start in place
      S_ = s_start;
      return true;
    }
    t_ = t_jump;
    x_ = x_jump;
    S_ = s_jump;
    return JumpAt(guard, false) && CheckZenoAndBudget();
  }

  bool Missing(int j) {
    out_.missing_jumps = segments_->back() - j;
    return Fail(SimStop::kCompleted,  // the status says completed; missing_jumps says what is wrong
                fmt::format("the model makes {} jump(s) before the last sample time; the data show {}", j,
                            segments_->back()));
  }

  // ---- jumps ------------------------------------------------------------------------------------
  // Applies the jump map (and the saltation rule) at t_ to x_, S_, again while ξ+ ∈ D.
  // `fixed_time`: the initial state lies in D (the jump time is 0 whatever θ).
  bool JumpAt(int guard, bool fixed_time) {
    if (guard >= 0) model_.ProjectOntoGuard(guard, x_);
    Vec f_minus(n_), f_plus(n_);
    model_.Flow(x_, params_.alpha, f_minus);
    Eigen::RowVectorXd dt_dtheta = Eigen::RowVectorXd::Zero(p_);
    if (sens_ && !fixed_time && guard >= 0) {
      const Eigen::RowVectorXd grad = GuardGradient(guard, x_);
      const double rate = grad.dot(f_minus);
      if (!(std::abs(rate) > 1e-14 * std::max(1.0, grad.norm() * f_minus.norm()))) {
        return Fail(SimStop::kSolverFailure,
                    fmt::format("grazing guard crossing at t = {:.17g}: the jump time has no "
                                "sensitivity",
                                t_));
      }
      dt_dtheta = -(grad * S_) / rate;
    }
    Mat total = S_ + f_minus * dt_dtheta;
    for (int chain = 0;; ++chain) {
      if (chain >= options_.sim.max_jumps_at_one_time) {
        out_.trajectory.status.zeno_time = t_;
        return Fail(SimStop::kZeno, fmt::format("Zeno: {} jumps at t = {:.17g}", chain, t_));
      }
      Vec post(n_);
      model_.Jump(x_, params_.beta, post);
      if (sens_) total = JumpSensitivity(x_, total);
      out_.trajectory.jumps.push_back(JumpRecord{jumps() + 1, t_, chain == 0 ? guard : -1, x_, post});
      if (sens_) out_.jump_time_gradients.conservativeResize(p_, jumps());
      if (sens_) out_.jump_time_gradients.col(jumps() - 1) = dt_dtheta.transpose();
      x_ = post;
      if (!x_.allFinite()) {
        return Fail(SimStop::kNonFinite, fmt::format("jump map gave a non-finite state at t = {:.17g}", t_));
      }
      if (!model_.InJumpSet(x_)) break;
    }
    model_.Flow(x_, params_.alpha, f_plus);
    if (sens_) S_ = total - f_plus * dt_dtheta;
    return true;
  }

  Eigen::RowVectorXd GuardGradient(int guard, const Vec& x) const {
    const int m = model_.guard_count();
    const Mat jac = CentralDifference([&](const Vec& z, Vec& h) { model_.Guards(z, h); }, x, m);
    return jac.row(guard);
  }

  // (∂g/∂ξ)·total + ∂g/∂θ at the pre-jump state x.
  Mat JumpSensitivity(const Vec& x, const Mat& total) const {
    const Mat g_x = CentralDifference([&](const Vec& z, Vec& g) { model_.Jump(z, params_.beta, g); }, x, n_);
    Mat out = g_x * total;
    Mat psi(n_, model_.beta_size());
    model_.Psi(x, psi);
    const auto offset = static_cast<Eigen::Index>(unknowns_.alpha.size());
    for (std::size_t i = 0; i < unknowns_.beta.size(); ++i) {
      out.col(offset + static_cast<Eigen::Index>(i)) += psi.col(unknowns_.beta[i]);
    }
    return out;
  }

  // The Zeno rule and the jump budget of SimOptions (as Simulate).
  bool CheckZenoAndBudget() {
    const auto& jumps = out_.trajectory.jumps;
    const int window = options_.sim.zeno_window;
    const std::size_t m = jumps.size();
    if (m >= static_cast<std::size_t>(window) + 2) {
      const double last = jumps[m - 1].t - jumps[m - 2].t;
      bool shrinking = last < options_.sim.zeno_interval;
      for (int i = 0; shrinking && i < window; ++i) {
        shrinking = jumps[m - 1 - i].t - jumps[m - 2 - i].t < jumps[m - 2 - i].t - jumps[m - 3 - i].t;
      }
      if (shrinking) {
        const double rho = last / (jumps[m - 2].t - jumps[m - 3].t);
        out_.trajectory.status.zeno_time = jumps[m - 1].t + last * rho / (1.0 - rho);
        return Fail(SimStop::kZeno,
                    fmt::format("Zeno: jump interval {:.3g} s and shrinking after {} jumps; estimated "
                                "accumulation time {:.17g}",
                                last, m, out_.trajectory.status.zeno_time));
      }
    }
    if (static_cast<int>(m) >= options_.sim.max_jumps) {
      return Fail(SimStop::kJumpBudget, fmt::format("jump budget of {} jumps exhausted at t = {:.17g}",
                                                    options_.sim.max_jumps, t_));
    }
    return true;
  }

  // ---- bookkeeping ------------------------------------------------------------------------------
  void AccumulateCounters() {
    long v = 0;
    if (CVodeGetNumRhsEvals(cvode_.get(), &v) == CV_SUCCESS) rhs_evals_ += v;
    if (CVodeGetNumGEvals(cvode_.get(), &v) == CV_SUCCESS) root_evals_ += v;
  }

  bool Check(int flag, const char* function) {
    if (flag >= 0) return true;
    return Fail(SimStop::kSolverFailure,
                fmt::format("{} returned {}: {}", function, CVodeGetReturnFlagName(flag), data_.last_error));
  }

  // Records why the run stopped (kCompleted with a message: matched mode's missing segments, which
  // SensitivityTrajectory::missing_jumps reports). Always false.
  bool Fail(SimStop stop, std::string message) {
    SimStatus& st = out_.trajectory.status;
    st.stop = stop;
    st.message = std::move(message);
    st.t_reached = t_;
    failed_ = true;
    return false;
  }

  SensitivityTrajectory Finish() {
    if (cvode_) AccumulateCounters();
    Trajectory& tr = out_.trajectory;
    tr.stats.steps = steps_;
    tr.stats.rhs_evals = rhs_evals_;
    tr.stats.root_evals = root_evals_;
    if (failed_) {  // keep the prefix of samples that were computed
      long prefix = 0;
      while (prefix < sample_count_ && filled_[static_cast<std::size_t>(prefix)]) ++prefix;
      tr.t.resize(static_cast<std::size_t>(prefix));
      tr.j.resize(static_cast<std::size_t>(prefix));
      tr.x.conservativeResize(n_, prefix);
      if (sens_) out_.sensitivities.conservativeResize(Eigen::NoChange, prefix);
    }
    return std::move(out_);
  }

  const Model& model_;
  HybridParameters params_;
  Unknowns unknowns_;
  SensitivityOptions options_;
  const std::vector<int>* segments_;
  int n_ = 0, p_ = 0;
  bool sens_ = true;
  long sample_count_ = 0;
  double dt_ = 0.0, t_last_ = 0.0;              // with times_: dt_ is the mean step
  const std::vector<double>* times_ = nullptr;  // sample times (irregular sampling), or null: k·dt_
  double t_ = 0.0;
  Vec x_;
  Mat S_;
  std::vector<char> filled_;
  long steps_ = 0, rhs_evals_ = 0, root_evals_ = 0;
  bool failed_ = false;
  WindowEnd window_a_, window_b_;
  int coefficients_state_ = 0;  // 0: not read for this step, 1: per-sample CVodeGetDky, 2: Horner
  Mat coefficients_;
  double horner_tn_ = 0.0, horner_h_ = 1.0;
  Mat returned_s_;
  CallbackData data_;
  SensitivityTrajectory out_;
  // Declared in creation order; destroyed in reverse.
  ContextPtr ctx_;
  NVectorPtr y_;
  NVectorPtr scratch_;
  NonlinearSolverPtr nls_;
  CvodePtr cvode_;
};

void CheckInputs(const Model& model, const HybridParameters& params, const Unknowns& unknowns,
                 const SampleGrid& grid, const SensitivityOptions& options) {
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
  if (!model.InFlowSet(params.x0) && !model.InJumpSet(params.x0)) {
    throw std::invalid_argument(fmt::format("x0 lies outside C and D of model '{}'", model.name()));
  }
}

}  // namespace

SensitivityTrajectory SimulateSensitivities(const Model& model, const HybridParameters& params,
                                            const Unknowns& unknowns, const SampleGrid& grid,
                                            const SensitivityOptions& options) {
  CheckInputs(model, params, unknowns, grid, options);
  SensRun run(model, params, unknowns, grid, options, nullptr);
  return run.Execute();
}

namespace {

void CheckSegments(const std::vector<int>& segment_of_sample, std::size_t k_count) {
  if (segment_of_sample.size() != k_count) {
    throw std::invalid_argument(fmt::format("segment_of_sample has {} entries; the grid has {} samples",
                                            segment_of_sample.size(), k_count));
  }
  for (std::size_t k = 0; k < k_count; ++k) {
    const int prev = k == 0 ? 0 : segment_of_sample[k - 1];
    const int step = segment_of_sample[k] - prev;
    if (step != 0 && !(step == 1 && k > 0)) {
      throw std::invalid_argument(
          fmt::format("segment_of_sample[{}] = {} after {}: must start at 0 and grow by 0 or 1 per sample", k,
                      segment_of_sample[k], prev));
    }
  }
}

}  // namespace

SensitivityTrajectory SimulateSensitivitiesMatched(const Model& model, const HybridParameters& params,
                                                   const Unknowns& unknowns, const SampleGrid& grid,
                                                   const std::vector<int>& segment_of_sample,
                                                   const SensitivityOptions& options) {
  CheckInputs(model, params, unknowns, grid, options);
  CheckSegments(segment_of_sample, static_cast<std::size_t>(grid.size()));
  SensRun run(model, params, unknowns, grid, options, &segment_of_sample);
  return run.Execute();
}

SensitivityTrajectory SimulateSensitivitiesMatched(const Model& model, const HybridParameters& params,
                                                   const Unknowns& unknowns, const std::vector<double>& times,
                                                   const std::vector<int>& segment_of_sample,
                                                   const SensitivityOptions& options) {
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
  const SampleGrid grid{.t_end = times.back(), .dt = times.back() / static_cast<double>(times.size() - 1)};
  CheckInputs(model, params, unknowns, grid, options);
  CheckSegments(segment_of_sample, times.size());
  SensRun run(model, params, unknowns, grid, options, &segment_of_sample, &times);
  return run.Execute();
}

}  // namespace hysid
