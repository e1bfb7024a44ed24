#include "sim/refine/start.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <ceres/ceres.h>
#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/model/automaton.hpp"

namespace hysid {

std::string StartRepair::Summary() const {
  return fmt::format(
      "detections: {} dropped, {} moved, {} added; beta and x0 re-estimated from local flow fits", dropped,
      moved, added);
}

namespace {

struct LocalFit {
  bool ok = false;
  Vec z;  // the state at sample `ref`
  long ref = 0;
  double chi2 = 0.0;  // Σ (r/σ)² over the fitted samples
};

// Local fits of the flow with α̂ to blocks of samples.
class LocalFlows {
 public:
  LocalFlows(const Model& model, const Mat& y, double dt, const HybridParameters& p, const Vec& weight,
             const SensitivityOptions& options, int max_iterations)
      : model_(model),
        y_(y),
        dt_(dt),
        p_(p),
        weight_(weight),
        options_(options),
        max_iterations_(max_iterations) {
    unknowns_.x0 = true;
  }
  const Mat& y() const { return y_; }
  const Vec& weight() const { return weight_; }
  // Where C and D are evaluated: the start's guard parameters γ.
  Context At() const {
    return {.t = 0.0, .u = nullptr, .gamma = p_.GammaOr(model_).data(), .alpha = p_.alpha.data(), .beta = p_.beta.data()};
  }

  // The flow through z at sample `ref`, read at samples [lo, hi) (ref inside): forward with α̂,
  // backward as the forward flow of −α̂ (ξ' = φ(ξ)α reversed in time). s: ∂ξ_k/∂z (n·n per column).
  bool Through(const Vec& z, long ref, long lo, long hi, Mat* x, Mat* s) const {
    if (!z.allFinite() || (!model_.InFlowSet(z, At()) && !model_.InJumpSet(z, At()))) return false;
    const Eigen::Index n = z.size();
    x->resize(n, hi - lo);
    if (s) s->resize(n * n, hi - lo);
    x->col(ref - lo) = z;
    if (s) s->col(ref - lo) = Mat::Identity(n, n).reshaped();
    return Leg(p_.alpha, z, ref, hi - ref, 1, lo, x, s) && Leg(-p_.alpha, z, ref, ref - lo + 1, -1, lo, x, s);
  }

  // Least squares over the state at the sample nearest the middle of [lo, hi) whose measurement lies
  // in C or D.
  LocalFit Fit(long lo, long hi) const;

  // Σ (r/σ)² per sample of the flow through (z, ref) over [lo, hi); empty when it does not simulate.
  Vec SampleCosts(const LocalFit& f, long lo, long hi) const {
    Mat x;
    if (!f.ok || !Through(f.z, f.ref, lo, hi, &x, nullptr)) return Vec();
    return (weight_.asDiagonal() * (y_.middleCols(lo, hi - lo) - x)).colwise().squaredNorm().transpose();
  }
  Vec StateAt(const LocalFit& f, long k) const {
    Mat x;
    if (!f.ok || !Through(f.z, f.ref, std::min(k, f.ref), std::max(k, f.ref) + 1, &x, nullptr)) return Vec();
    return k <= f.ref ? Vec(x.col(0)) : Vec(x.col(x.cols() - 1));
  }

 private:
  // `count` samples from `ref` in direction `step`, written to column ref + step·i − lo.
  bool Leg(const Vec& alpha, const Vec& z, long ref, long count, long step, long lo, Mat* x, Mat* s) const {
    if (count < 2) return true;
    const SampleGrid grid{(static_cast<double>(count) - 0.5) * dt_, dt_};
    SensitivityOptions o = options_;
    o.sensitivities = s != nullptr;
    const std::vector<int> one_segment(static_cast<std::size_t>(count), 0);
    const SensitivityTrajectory t = SimulateSensitivitiesMatched(model_, HybridParameters{alpha, p_.beta, z, p_.gamma},
                                                                 unknowns_, grid, one_segment, o);
    if (!t.ok() || t.trajectory.x.cols() != count || !t.trajectory.x.allFinite()) return false;
    for (long i = 1; i < count; ++i) {
      x->col(ref + step * i - lo) = t.trajectory.x.col(i);
      if (s) s->col(ref + step * i - lo) = t.sensitivities.col(i);
    }
    return true;
  }

  const Model& model_;
  const Mat& y_;
  double dt_;
  HybridParameters p_;
  Vec weight_;
  SensitivityOptions options_;
  int max_iterations_;
  Unknowns unknowns_;
};

class LocalFlowCost final : public ceres::CostFunction {
 public:
  LocalFlowCost(const LocalFlows& flows, long ref, long lo, long hi)
      : flows_(flows), ref_(ref), lo_(lo), hi_(hi) {
    const auto n = static_cast<int>(flows.y().rows());
    set_num_residuals(n * static_cast<int>(hi - lo));
    mutable_parameter_block_sizes()->push_back(n);
  }
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const Eigen::Index n = flows_.y().rows();
    const Vec z = Eigen::Map<const Vec>(parameters[0], n);
    const bool jac = jacobians != nullptr && jacobians[0] != nullptr;
    Mat x, s;
    if (!flows_.Through(z, ref_, lo_, hi_, &x, jac ? &s : nullptr)) return false;
    Eigen::Map<Mat> r(residuals, n, hi_ - lo_);
    r = flows_.weight().asDiagonal() * (flows_.y().middleCols(lo_, hi_ - lo_) - x);
    if (!jac) return true;
    for (long k = 0; k < hi_ - lo_; ++k) {  // row-major rows k·n + i: −w_i ∂ξ_i/∂z
      for (Eigen::Index i = 0; i < n; ++i) {
        for (Eigen::Index c = 0; c < n; ++c) {
          jacobians[0][(k * n + i) * n + c] = -flows_.weight()[i] * s(c * n + i, k);
        }
      }
    }
    return true;
  }

 private:
  const LocalFlows& flows_;
  long ref_, lo_, hi_;
};

LocalFit LocalFlows::Fit(long lo, long hi) const {
  LocalFit f;
  const long mid = (lo + hi) / 2;
  for (long d = 0; d <= (hi - lo) / 2 && !f.ok; ++d) {
    for (const long k : {mid - d, mid + d}) {
      if (k >= lo && k < hi && !f.ok && model_.InFlowSet(y_.col(k), At())) {
        f.ref = k;
        f.ok = true;
      }
    }
  }
  if (!f.ok) return f;
  f.z = y_.col(f.ref);
  ceres::Problem::Options po;
  po.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  problem.AddResidualBlock(new LocalFlowCost(*this, f.ref, lo, hi), nullptr, f.z.data());
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = max_iterations_;
  so.function_tolerance = so.parameter_tolerance = 1e-10;
  so.logging_type = ceres::SILENT;
  so.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  f.ok = summary.IsSolutionUsable() && f.z.allFinite();
  f.chi2 = 2.0 * summary.final_cost;
  return f;
}

// A detection tested by the flows on each side of it.
struct JumpTest {
  bool tested = false;
  double gain = 0.0;  // χ²(one flow) − χ²(two flows)
  long at = 0;        // the best boundary (first sample after the jump)
  Vec pre, post;      // the left flow at at − 1, the right flow at at
  LocalFit right;     // the flow after the jump
};

// The boundary s in [d − search, d + search] ∩ (lo, hi) minimising Σ_{k<s} cl_k + Σ_{k≥s} cr_k.
long BestBoundary(const Vec& cl, const Vec& cr, long lo, long d, long hi, long search) {
  long at = d;
  double best = 0.0, run = 0.0;  // relative to the total at d
  for (long s = d + 1; s <= std::min(hi - 1, d + search); ++s) {
    run += cl[s - 1 - lo] - cr[s - 1 - lo];
    if (run < best) best = run, at = s;
  }
  run = 0.0;
  for (long s = d - 1; s >= std::max(lo + 1, d - search); --s) {
    run += cr[s - lo] - cl[s - lo];
    if (run < best) best = run, at = s;
  }
  return at;
}

// Fits both sides of d and the two as one flow; then moves the boundary to where the two fitted
// flows meet best, refitting the sides, until it stays (at most 4 moves).
JumpTest TestJump(const LocalFlows& flows, long lo, long d, long hi, long search) {
  JumpTest t;
  LocalFit left = flows.Fit(lo, d), right = flows.Fit(d, hi);
  if (!left.ok || !right.ok) return t;
  const LocalFit one = flows.Fit(lo, hi);
  t.gain = (one.ok ? one.chi2 : std::numeric_limits<double>::infinity()) - left.chi2 - right.chi2;
  t.at = d;
  for (int move = 0; move < 4; ++move) {
    const Vec cl = flows.SampleCosts(left, lo, hi), cr = flows.SampleCosts(right, lo, hi);
    if (cl.size() == 0 || cr.size() == 0) return t;
    const long at = BestBoundary(cl, cr, lo, t.at, hi, search);
    if (at == t.at) break;
    t.at = at;
    left = flows.Fit(lo, at);
    right = flows.Fit(at, hi);
    if (!left.ok || !right.ok) return t;
  }
  t.pre = flows.StateAt(left, t.at - 1);
  t.post = flows.StateAt(right, t.at);
  t.right = right;
  t.tested = t.pre.size() > 0 && t.post.size() > 0;
  return t;
}

struct Cleaned {
  std::vector<long> jumps;
  std::vector<Vec> pre, post;   // per jump: the fitted flows around it (empty: not tested)
  std::vector<LocalFit> right;  // per jump: the flow after it (not ok: not tested)
};

// Drops the detections the local flows do not need, moves the others to their best sample. The
// candidates in `predicted` (the model's, not the detector's) are searched `o.predicted_search` wide.
Cleaned Clean(const LocalFlows& flows, const std::vector<long>& candidates,
              const std::vector<long>& predicted, const StartRepairOptions& o) {
  Cleaned c;
  const long k_count = flows.y().cols();
  long prev = 0;
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    const long d = candidates[i];
    if (!c.jumps.empty() && d - c.jumps.back() < o.min_window) continue;  // the same jump again
    const long next = i + 1 < candidates.size() ? candidates[i + 1] : k_count;
    const long lo = std::max(prev, d - o.window);
    long hi = std::min(k_count, d + o.window);
    if (next - d >= o.min_window) hi = std::min(hi, next);
    const bool model_jump = std::binary_search(predicted.begin(), predicted.end(), d);
    // Sides of ≥ 1 sample (d > prev, d < K).
    const JumpTest t = TestJump(flows, lo, d, hi, model_jump ? o.predicted_search : o.search);
    if (t.tested && t.gain < o.split_threshold) continue;  // one flow explains the data
    const long at = t.tested ? t.at : d;
    if (!c.jumps.empty() && at - c.jumps.back() < o.min_window) continue;
    c.jumps.push_back(at);
    c.pre.push_back(t.tested ? t.pre : Vec());
    c.post.push_back(t.tested ? t.post : Vec());
    c.right.push_back(t.tested ? t.right : LocalFit{});
    prev = at;
  }
  return c;
}

// The rows of ψ(ξ⁻)β = ξ⁺ on the identified jump rows, for β's unknown entries (the known entries
// moved to the right side).
void JumpRows(const Model& model, const Unknowns& u, const Cleaned& c, const Vec& beta, StartRepair* out) {
  const std::vector<int>& rows = model.spec().jump_rows;
  const auto tested = std::count_if(c.pre.begin(), c.pre.end(), [](const Vec& v) { return v.size() > 0; });
  const auto m = static_cast<Eigen::Index>(tested) * static_cast<Eigen::Index>(rows.size());
  const auto q = static_cast<Eigen::Index>(u.beta.size());
  Mat& a = out->jump_rows;
  Vec& b = out->jump_rhs;
  a.resize(m, q);
  b.resize(m);
  Mat psi(model.state_size(), model.beta_size());
  Vec known = beta;
  for (int i : u.beta) known[i] = 0.0;
  Eigen::Index row = 0;
  for (std::size_t j = 0; j < c.pre.size(); ++j) {
    if (c.pre[j].size() == 0) continue;
    model.Psi(c.pre[j], psi);
    for (int r : rows) {
      for (Eigen::Index col = 0; col < q; ++col) a(row, col) = psi(r, u.beta[static_cast<std::size_t>(col)]);
      b[row++] = c.post[j][r] - psi.row(r).dot(known);
    }
  }
}

// The first jump the model makes inside each segment between `jumps`, simulated from the fitted flow
// after the segment's start (`first` for the segment before the first jump), where no jump is:
// candidates for a missed detection.
std::vector<long> MissedJumps(const Model& model, const HybridParameters& p, const Cleaned& c,
                              const LocalFit& first, double dt, const SensitivityOptions& options,
                              const StartRepairOptions& o, long k_count) {
  std::vector<long> out;
  SensitivityOptions plain = options;
  plain.sensitivities = false;
  for (std::size_t s = 0; s <= c.jumps.size(); ++s) {
    const LocalFit& from = s == 0 ? first : c.right[s - 1];
    const long begin = s == 0 ? 0 : c.jumps[s - 1];
    const long end = s < c.jumps.size() ? c.jumps[s] : k_count;
    const Context at{.t = 0.0, .u = nullptr, .gamma = p.GammaOr(model).data(), .alpha = p.alpha.data(),
                     .beta = p.beta.data()};
    if (!from.ok || end - from.ref < 2 || (!model.InFlowSet(from.z, at) && !model.InJumpSet(from.z, at))) continue;
    const SampleGrid grid{(static_cast<double>(end - from.ref) - 0.5) * dt, dt};
    const SensitivityTrajectory t =
        SimulateSensitivities(model, HybridParameters{p.alpha, p.beta, from.z, p.gamma}, Unknowns{}, grid, plain);
    if (t.trajectory.jumps.empty()) continue;
    const long k = from.ref + static_cast<long>(std::ceil(t.trajectory.jumps.front().t / dt));
    const long margin = std::max(o.min_window, o.predicted_search);  // away from the detected jumps
    if (k - begin > margin && end - k > margin) out.push_back(k);
  }
  return out;
}

// Counts of dropped, moved and added detections: `after` against `before`, matched within `search`.
void CountChanges(const std::vector<long>& before, const std::vector<long>& after, long search,
                  StartRepair* out) {
  auto near = [&](const std::vector<long>& in, long k) {
    const auto it = std::lower_bound(in.begin(), in.end(), k - search);
    return it != in.end() && *it <= k + search ? *it : -1;
  };
  for (long k : before) out->dropped += near(after, k) < 0;
  for (long k : after) {
    const long m = near(before, k);
    out->added += m < 0;
    out->moved += m >= 0 && m != k;
  }
}

}  // namespace

StartRepair RepairStart(const Model& model, const Mat& y, double dt, const std::vector<std::uint8_t>& gamma,
                        const HybridParameters& recursive, const Unknowns& unknowns, const Vec& weight,
                        const SensitivityOptions& options, const StartRepairOptions& repair) {
  StartRepair out;
  const long k_count = y.cols();
  const LocalFlows flows(model, y, dt, recursive, weight, options, repair.max_iterations);
  std::vector<long> candidates;
  for (long k = 1; k < k_count; ++k) {
    if (gamma[static_cast<std::size_t>(k)] != 0) candidates.push_back(k);
  }
  std::vector<long> predicted;
  Cleaned c = Clean(flows, candidates, predicted, repair);
  out.start = recursive;
  for (int round = 0;; ++round) {
    JumpRows(model, unknowns, c, recursive.beta, &out);
    out.start.beta = SolveJumpRows(unknowns, out.jump_rows, out.jump_rhs, recursive.beta);
    const LocalFit first = flows.Fit(0, std::min(c.jumps.empty() ? k_count : c.jumps.front(), repair.window));
    const Vec x0 = flows.StateAt(first, 0);
    const Context at{.t = 0.0, .u = nullptr, .gamma = recursive.GammaOr(model).data()};
    out.start.x0 = x0.size() > 0 && (model.InFlowSet(x0, at) || model.InJumpSet(x0, at)) ? x0 : recursive.x0;
    if (round == repair.max_rounds) break;
    std::vector<long> missed = MissedJumps(model, out.start, c, first, dt, options, repair, k_count);
    std::erase_if(missed, [&](long k) { return std::binary_search(predicted.begin(), predicted.end(), k); });
    if (missed.empty()) break;
    predicted.insert(predicted.end(), missed.begin(), missed.end());
    std::sort(predicted.begin(), predicted.end());
    missed.insert(missed.end(), c.jumps.begin(), c.jumps.end());
    std::sort(missed.begin(), missed.end());
    c = Clean(flows, missed, predicted, repair);
  }
  CountChanges(candidates, c.jumps, repair.search, &out);
  out.gamma.assign(gamma.size(), 0);
  for (long k : c.jumps) out.gamma[static_cast<std::size_t>(k)] = 1;
  out.ok = true;
  return out;
}

Vec SolveJumpRows(const Unknowns& unknowns, const Mat& rows, const Vec& rhs, const Vec& beta) {
  const auto q = static_cast<Eigen::Index>(unknowns.beta.size());
  if (q == 0 || rows.rows() < q) return beta;
  const Eigen::ColPivHouseholderQR<Mat> qr(rows);
  if (qr.rank() < q) return beta;
  const Vec solved = qr.solve(rhs);
  if (!solved.allFinite()) return beta;
  Vec out = beta;
  for (Eigen::Index col = 0; col < q; ++col) out[unknowns.beta[static_cast<std::size_t>(col)]] = solved[col];
  return out;
}

void AppendGuardRows(const Model& model, const std::vector<double>& t, const Mat& y,
                     const std::vector<std::uint8_t>& labels, const Vec& alpha, const Vec& gamma0,
                     const Unknowns& unknowns, Mat* rows, Vec* rhs, const std::vector<int>& maps,
                     int initial_mode, const Eigen::Ref<const Mat>& u) {
  const auto q = static_cast<Eigen::Index>(unknowns.gamma.size());
  const int n = model.state_size(), guards = model.guard_count();
  if (q == 0 || guards == 0) return;
  const std::vector<JumpMap> all_maps = JumpMaps(model.spec());
  Vec f(n), h(guards);
  Mat dh(guards, model.gamma_size());
  int mode = std::max(initial_mode, 0);
  std::size_t event = 0;  // index into maps
  for (std::size_t k = 1; k < labels.size(); ++k) {
    if (labels[k] == 0) continue;
    const int map = event < maps.size() ? maps[event++] : -1;
    const int leaves = mode;
    if (map >= 0) mode = ModeAfter(model.spec(), mode, map);
    const auto pre = static_cast<Eigen::Index>(k - 1);
    if (!y.col(pre).allFinite()) continue;
    if (u.cols() > 0 && !u.col(pre).allFinite()) continue;
    const Context ctx{.t = t[k - 1],
                      .u = u.cols() > 0 ? u.col(pre).data() : nullptr,
                      .gamma = gamma0.data(),
                      .alpha = alpha.data(),
                      .mode = leaves};
    model.Flow(y.col(pre), alpha, f, ctx);
    const Vec moved = y.col(pre) + 0.5 * (t[k] - t[k - 1]) * f;
    model.Guards(moved, h, ctx);
    model.GuardGammaJacobian(moved, ctx, dh);
    Eigen::Index fired = 0;
    h.cwiseAbs().minCoeff(&fired);
    if (map >= 0 && all_maps[std::size_t(map)].guard >= 0) fired = all_maps[std::size_t(map)].guard;
    if (!h.allFinite() || !dh.row(fired).allFinite()) continue;
    const Eigen::Index m = rows->rows();
    rows->conservativeResize(m + 1, q);
    rhs->conservativeResize(m + 1);
    for (Eigen::Index c = 0; c < q; ++c) (*rows)(m, c) = dh(fired, unknowns.gamma[static_cast<std::size_t>(c)]);
    (*rhs)[m] = -h[fired];
  }
}

Vec SolveGuardRows(const Unknowns& unknowns, const Mat& rows, const Vec& rhs, const Vec& gamma0) {
  Vec out = gamma0;
  if (rows.rows() == 0) return out;
  std::vector<Eigen::Index> used;  // the columns some row involves
  for (Eigen::Index c = 0; c < rows.cols(); ++c) {
    if (rows.col(c).cwiseAbs().maxCoeff() > 0.0) used.push_back(c);
  }
  const auto q = static_cast<Eigen::Index>(used.size());
  if (q == 0 || rows.rows() < q) return out;
  Mat a(rows.rows(), q);
  for (Eigen::Index c = 0; c < q; ++c) a.col(c) = rows.col(used[static_cast<std::size_t>(c)]);
  const Eigen::ColPivHouseholderQR<Mat> qr(a);
  if (qr.rank() < q) return out;
  const Vec step = qr.solve(rhs);
  if (!step.allFinite()) return out;
  for (Eigen::Index c = 0; c < q; ++c) {
    out[unknowns.gamma[static_cast<std::size_t>(used[static_cast<std::size_t>(c)])]] += step[c];
  }
  return out;
}

namespace {

// The radical inverse of k in base b: k's digits in base b mirrored about the point.
double RadicalInverse(int k, int base) {
  double x = 0.0, scale = 1.0;
  for (int m = k; m > 0; m /= base) {
    scale /= base;
    x += (m % base) * scale;
  }
  return x;
}

std::vector<int> FirstPrimes(std::size_t count) {
  std::vector<int> primes;
  for (int p = 2; primes.size() < count; ++p) {
    if (std::none_of(primes.begin(), primes.end(), [p](int q) { return p % q == 0; })) primes.push_back(p);
  }
  return primes;
}

}  // namespace

std::vector<HybridParameters> DesignStarts(const Model& model, const HybridParameters& center, int count,
                                           double factor) {
  const Unknowns unknowns = Unknowns::Of(model);
  const std::vector<int> primes = FirstPrimes(unknowns.alpha.size() + unknowns.beta.size());
  std::vector<HybridParameters> out;
  for (int k = 1; k <= count; ++k) {
    HybridParameters p = center;
    std::size_t dim = 0;
    auto move = [&](Vec& values, int j, const Parameter& param) {
      const double h = RadicalInverse(k, primes[dim++]);
      values[j] = std::clamp(values[j] * std::pow(factor, 2.0 * h - 1.0), param.lower, param.upper);
    };
    for (const int j : unknowns.alpha) move(p.alpha, j, model.spec().alpha[std::size_t(j)]);
    for (const int j : unknowns.beta) move(p.beta, j, model.spec().beta[std::size_t(j)]);
    out.push_back(std::move(p));
  }
  return out;
}

}  // namespace hysid
