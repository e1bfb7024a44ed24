// Hybrid multiple shooting with nodes placed by time (sim/refine/time_shooting.hpp).
#include "sim/refine/time_shooting.hpp"

#include "sim/refine/residual_tests.hpp"
#include "sim/refine/solver.hpp"

#include <ceres/ceres.h>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>

#include "core/model/automaton.hpp"
#include "core/model/noise_shape.hpp"

namespace hysid {
namespace {

// One segment: samples [first, end) of a chain, simulated from its node at sample `first`; when the
// chain goes on, the next node's time closes it (the continuity residuals).
struct Segment {
  std::size_t chain = 0;
  long first = 0, end = 0;
  bool continues = false;
  std::vector<double> times;  // from the node: the samples', then the next node's when it continues
  Mat y;                      // the measured rows of the samples (rows × (end − first))
  InputSignal inputs;         // over `times`; empty without inputs
  int mode = -1;              // q at the node
  std::vector<int> labels;    // per time: the model's jump count from the node at the last point (empty: none yet)
  Mat keep;                   // rows × samples: 1, or 0 for a sample trimmed (Trim); empty: all 1
  long samples() const { return end - first; }
};

struct ShootingProblem {
  const Model* model = nullptr;
  Unknowns unknowns;        // α_u, β_u, γ_u and x0 (the node state)
  HybridParameters base;    // full vectors: the known entries
  std::vector<int> rows;    // measured rows
  Vec weight;               // per measured row: 1/σ
  Vec scale;                // per state: c_j (σ_j for a measured state)
  Vec link_weight;          // per state: 1/(ε c_j) at the current stage's ε
  SensitivityOptions sens;
  std::vector<Segment> segments;
  int shared = 0;
  int n = 0;

  HybridParameters At(const double* theta, const double* s, int mode) const {
    HybridParameters p = base.WithTheta(Unknowns{unknowns.alpha, unknowns.beta, unknowns.gamma, false},
                                        Eigen::Map<const Vec>(theta, shared));
    p.x0 = Eigen::Map<const Vec>(s, n);
    p.initial_mode = mode;
    return p;
  }
};

// How a segment's samples are read: on the segments of its labels (matched: each flow continued past
// the model's jumps, so that no sample changes side as the point moves; the labels are the model's
// own at the last point, Relabel), or on the model's own run.
enum class Reading { kLabelled, kOwn };

// A segment simulated from its node at `at` with or without sensitivities; false when it cannot be.
bool SimulateSegment(const ShootingProblem& pr, const Segment& seg, const HybridParameters& at, bool sensitivities,
                     SensitivityTrajectory* out, Reading reading = Reading::kLabelled) {
  if (!Admissible(*pr.model, at, seg.inputs)) return false;
  SensitivityOptions o = pr.sens;
  o.sensitivities = sensitivities;
  try {
    *out = reading == Reading::kOwn || seg.labels.empty()
               ? SimulateSensitivities(*pr.model, at, pr.unknowns, seg.times, o, InputsOf(seg.inputs))
               : SimulateSensitivitiesMatched(*pr.model, at, pr.unknowns, seg.times, seg.labels, o,
                                              InputsOf(seg.inputs));
  } catch (const std::exception&) {
    return false;
  }
  return out->ok() && out->trajectory.size() == static_cast<long>(seg.times.size());
}

class SegmentCost final : public ceres::CostFunction {
 public:
  SegmentCost(const ShootingProblem& pr, std::size_t i) : pr_(pr), seg_(pr.segments[i]) {
    const auto m = static_cast<int>(pr.rows.size());
    set_num_residuals(m * static_cast<int>(seg_.samples()) + (seg_.continues ? pr.n : 0));
    if (pr.shared > 0) mutable_parameter_block_sizes()->push_back(pr.shared);
    mutable_parameter_block_sizes()->push_back(pr.n);
    if (seg_.continues) mutable_parameter_block_sizes()->push_back(pr.n);
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    static const double kNone = 0.0;
    const double* theta = pr_.shared > 0 ? parameters[0] : &kNone;
    const int b_s = pr_.shared > 0 ? 1 : 0;
    const HybridParameters at = pr_.At(theta, parameters[b_s], seg_.mode);
    SensitivityTrajectory tr;
    // With sensitivities whether or not Ceres asks for the Jacobian: the sensitivities take part in
    // CVODE's error test, so residuals from runs with and without them differ by the integration
    // error, and the costs Ceres compares must come from one integrator.
    if (!SimulateSegment(pr_, seg_, at, true, &tr)) return false;
    const auto m = static_cast<int>(pr_.rows.size());
    const int n = pr_.n, p = pr_.shared;
    const Mat& x = tr.trajectory.x;
    for (long k = 0; k < seg_.samples(); ++k) {
      for (int r = 0; r < m; ++r) {
        residuals[k * m + r] = Weight(r, k) * (x(pr_.rows[std::size_t(r)], k) - seg_.y(r, k));
      }
    }
    const long last = seg_.samples();
    if (seg_.continues) {
      const double* next = parameters[b_s + 1];
      for (int j = 0; j < n; ++j) residuals[last * m + j] = pr_.link_weight[j] * (x(j, last) - next[j]);
    }
    if (jacobians == nullptr) return true;
    // Row-major Jacobians: block b, residual row, column.
    auto fill = [&](long row, int state, double w, long k) {
      const auto S = tr.S(k);
      if (p > 0 && jacobians[0]) {
        for (int c = 0; c < p; ++c) jacobians[0][row * p + c] = w * S(state, c);
      }
      if (jacobians[b_s]) {
        for (int c = 0; c < n; ++c) jacobians[b_s][row * n + c] = w * S(state, p + c);
      }
    };
    for (long k = 0; k < seg_.samples(); ++k) {
      for (int r = 0; r < m; ++r) fill(k * m + r, pr_.rows[std::size_t(r)], Weight(r, k), k);
    }
    if (seg_.continues) {
      for (int j = 0; j < n; ++j) fill(last * m + j, j, pr_.link_weight[j], last);
      if (double* jn = jacobians[b_s + 1]) {
        std::fill(jn, jn + static_cast<std::size_t>(num_residuals()) * std::size_t(n), 0.0);
        for (int j = 0; j < n; ++j) jn[(last * m + j) * n + j] = -pr_.link_weight[j];
      }
    }
    return true;
  }

 private:
  double Weight(int r, long k) const { return seg_.keep.size() ? pr_.weight[r] * seg_.keep(r, k) : pr_.weight[r]; }
  const ShootingProblem& pr_;
  const Segment& seg_;
};

// The segments of the chains, nodes every `spacing` samples (a last piece shorter than half of it
// joins the one before); times from each node, measured rows and inputs copied.
std::vector<Segment> CutSegments(const std::vector<RefineChain>& chains, const std::vector<int>& rows, long spacing) {
  std::vector<Segment> out;
  for (std::size_t c = 0; c < chains.size(); ++c) {
    const RefineChain& ch = chains[c];
    const long K = static_cast<long>(ch.t.size());
    for (long a = 0; a < K;) {
      long b = std::min(K, a + spacing);
      if (K - b < spacing / 2) b = K;
      Segment s;
      s.chain = c;
      s.first = a;
      s.end = b;
      s.continues = b < K;
      const long last = s.continues ? b : b - 1;
      for (long k = a; k <= last; ++k) s.times.push_back(ch.t[std::size_t(k)] - ch.t[std::size_t(a)]);
      s.y.resize(static_cast<Eigen::Index>(rows.size()), b - a);
      for (std::size_t r = 0; r < rows.size(); ++r) s.y.row(Eigen::Index(r)) = ch.y.row(rows[r]).segment(a, b - a);
      if (ch.u.rows() > 0) {
        s.inputs.times = s.times;
        s.inputs.values = ch.u.middleCols(a, last - a + 1);
      }
      out.push_back(std::move(s));
      a = b;
    }
  }
  return out;
}

// Per segment, its node's start: the measured rows from the data; the hidden rows from the previous
// segment simulated at the start (a chain's first node: its reconstruction where finite, else the
// model's default state; a segment that cannot be simulated passes its node's rows on); modes from
// the chain's initial mode, then each previous segment's end.
std::vector<Vec> StartNodes(const ShootingProblem& pr, const std::vector<RefineChain>& chains, const Vec& theta,
                            std::vector<Segment>& segments) {
  const Model& model = *pr.model;
  std::vector<Vec> s(segments.size());
  const Vec fallback = DefaultState(model);
  for (std::size_t i = 0; i < segments.size(); ++i) {
    Segment& seg = segments[i];
    const RefineChain& ch = chains[seg.chain];
    const bool first = i == 0 || segments[i - 1].chain != seg.chain;
    Vec x = ch.y.col(seg.first);
    SensitivityTrajectory prev;
    bool have_prev = false;
    if (!first) {
      const Segment& before = segments[i - 1];
      have_prev = SimulateSegment(pr, before, pr.At(theta.data(), s[i - 1].data(), before.mode), false, &prev,
                                  Reading::kOwn);
    }
    for (int j = 0; j < pr.n; ++j) {
      if (std::find(pr.rows.begin(), pr.rows.end(), j) != pr.rows.end() && std::isfinite(x[j])) continue;
      if (have_prev) {
        x[j] = prev.trajectory.x(j, prev.trajectory.size() - 1);
      } else if (!std::isfinite(x[j])) {
        x[j] = first ? fallback[j] : s[i - 1][j];
      }
    }
    seg.mode = first ? ch.initial_mode
                     : (have_prev && !prev.trajectory.q.empty() ? prev.trajectory.q.back() : segments[i - 1].mode);
    // A node the data put outside C and D (noise at a guard) starts where the segment before ends.
    HybridParameters at = pr.At(theta.data(), x.data(), seg.mode);
    if (have_prev && !Admissible(model, at, seg.inputs)) x = prev.trajectory.x.col(prev.trajectory.size() - 1);
    s[i] = x;
  }
  return s;
}

// The modes at the nodes from the fit: each segment's mode at its end for the next node of its chain.
// The number of nodes whose mode changed.
int SettleModes(ShootingProblem& pr, const Vec& theta, const std::vector<Vec>& s) {
  int changed = 0;
  for (std::size_t i = 0; i + 1 < pr.segments.size(); ++i) {
    const Segment& seg = pr.segments[i];
    if (!seg.continues) continue;
    SensitivityTrajectory tr;
    if (!SimulateSegment(pr, seg, pr.At(theta.data(), s[i].data(), seg.mode), false, &tr, Reading::kOwn)) continue;
    if (tr.trajectory.q.empty()) continue;
    const int q = tr.trajectory.q.back();
    if (q != pr.segments[i + 1].mode) {
      pr.segments[i + 1].mode = q;
      ++changed;
    }
  }
  return changed;
}

// Each segment's labels from its model's own run at (θ, s): the number of segments whose labels
// changed (a segment that does not simulate keeps its labels).
int Relabel(ShootingProblem& pr, const Vec& theta, const std::vector<Vec>& s) {
  int changed = 0;
  for (std::size_t i = 0; i < pr.segments.size(); ++i) {
    Segment& seg = pr.segments[i];
    SensitivityTrajectory tr;
    if (!SimulateSegment(pr, seg, pr.At(theta.data(), s[i].data(), seg.mode), false, &tr, Reading::kOwn)) continue;
    if (tr.trajectory.j != seg.labels) {
      seg.labels = tr.trajectory.j;
      ++changed;
    }
  }
  return changed;
}

// Samples whose weighted residual on the model's own run exceeds kTrim robust standard deviations
// (1.4826 · the median |w r|, at least 1) are left out of the next solves: a sample on the wrong side
// of a jump in a measured state (its residual the jump's size) carries no information the
// sensitivities can use. The final solve keeps every sample.
void Trim(ShootingProblem& pr, const Vec& theta, const std::vector<Vec>& s, bool at_events_only = false) {
  std::vector<Mat> residual(pr.segments.size());
  std::vector<double> all;
  for (std::size_t i = 0; i < pr.segments.size(); ++i) {
    const Segment& seg = pr.segments[i];
    SensitivityTrajectory tr;
    if (!SimulateSegment(pr, seg, pr.At(theta.data(), s[i].data(), seg.mode), false, &tr, Reading::kOwn)) continue;
    Mat& r = residual[i];
    r.resize(seg.y.rows(), seg.samples());
    const std::vector<int>& j_of = tr.trajectory.j;
    for (long k = 0; k < seg.samples(); ++k) {
      // Beside a jump of the model: the samples k − 1 and k around a change of the jump count.
      const bool beside = (k > 0 && j_of[std::size_t(k)] != j_of[std::size_t(k - 1)]) ||
                          (k + 1 < static_cast<long>(j_of.size()) && j_of[std::size_t(k + 1)] != j_of[std::size_t(k)]);
      for (Eigen::Index j = 0; j < r.rows(); ++j) {
        r(j, k) = pr.weight[j] * (tr.trajectory.x(pr.rows[std::size_t(j)], k) - seg.y(j, k));
        all.push_back(std::abs(r(j, k)));
        if (at_events_only && !beside) r(j, k) = 0.0;  // never trimmed
      }
    }
  }
  if (all.empty()) return;
  std::nth_element(all.begin(), all.begin() + long(all.size() / 2), all.end());
  const double cut = kTrim * std::max(1.0, 1.4826 * all[all.size() / 2]);
  for (std::size_t i = 0; i < pr.segments.size(); ++i) {
    if (residual[i].size() == 0) continue;
    pr.segments[i].keep = (residual[i].array().abs() <= cut).cast<double>().matrix();
  }
}

// A hybrid automaton: each node's mode the one whose segment, simulated from the node's state at θ,
// fits the segment's samples best (the data's own say on a hidden mode; modes in which the state
// lies outside C and D are not candidates).
void BestModes(ShootingProblem& pr, const Vec& theta, const std::vector<Vec>& s) {
  const int modes = ModeCount(pr.model->spec());
  if (modes < 2) return;
  for (std::size_t i = 0; i < pr.segments.size(); ++i) {
    Segment& seg = pr.segments[i];
    double best = std::numeric_limits<double>::infinity();
    for (int q = 0; q < modes; ++q) {
      SensitivityTrajectory tr;
      if (!SimulateSegment(pr, seg, pr.At(theta.data(), s[i].data(), q), false, &tr, Reading::kOwn)) continue;
      double cost = 0.0;
      for (long k = 0; k < seg.samples(); ++k) {
        for (std::size_t r = 0; r < pr.rows.size(); ++r) {
          cost += std::pow(pr.weight[Eigen::Index(r)] * (tr.trajectory.x(pr.rows[r], k) - seg.y(Eigen::Index(r), k)), 2);
        }
      }
      if (cost < best) {
        best = cost;
        seg.mode = q;
      }
    }
  }
}

ceres::Solver::Summary Solve(const ShootingProblem& pr, const RefineOptions& options, Vec& theta,
                             std::vector<Vec>& s) {
  ceres::Problem::Options po;
  po.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem cp(po);
  for (std::size_t i = 0; i < pr.segments.size(); ++i) {
    std::vector<double*> blocks;
    if (pr.shared > 0) blocks.push_back(theta.data());
    blocks.push_back(s[i].data());
    if (pr.segments[i].continues) blocks.push_back(s[i + 1].data());
    cp.AddResidualBlock(new SegmentCost(pr, i), nullptr, blocks);
  }
  const std::vector<const Parameter*> params = pr.unknowns.Parameters(*pr.model);
  for (int i = 0; i < pr.shared; ++i) {
    if (std::isfinite(params[std::size_t(i)]->lower)) cp.SetParameterLowerBound(theta.data(), i, params[std::size_t(i)]->lower);
    if (std::isfinite(params[std::size_t(i)]->upper)) cp.SetParameterUpperBound(theta.data(), i, params[std::size_t(i)]->upper);
  }
  ceres::Solver::Options so = LevenbergMarquardt(options);
  so.linear_solver_type = ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::SUITE_SPARSE)
                              ? ceres::SPARSE_NORMAL_CHOLESKY
                              : ceres::DENSE_QR;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &cp, &summary);
  return summary;
}

// The raw data residuals (model − data) per chain (rows × K) at the fit, from the states alone.
bool Residuals(const ShootingProblem& pr, const std::vector<RefineChain>& chains, const Vec& theta,
               const std::vector<Vec>& s, std::vector<Mat>* out) {
  const auto m = static_cast<Eigen::Index>(pr.rows.size());
  out->assign(chains.size(), Mat());
  for (std::size_t c = 0; c < chains.size(); ++c) (*out)[c] = Mat::Zero(m, Eigen::Index(chains[c].t.size()));
  for (std::size_t i = 0; i < pr.segments.size(); ++i) {
    const Segment& seg = pr.segments[i];
    SensitivityTrajectory tr;
    if (!SimulateSegment(pr, seg, pr.At(theta.data(), s[i].data(), seg.mode), false, &tr)) return false;
    for (long k = 0; k < seg.samples(); ++k) {
      for (Eigen::Index r = 0; r < m; ++r) {
        (*out)[seg.chain](r, seg.first + k) = tr.trajectory.x(pr.rows[std::size_t(r)], k) - seg.y(r, k);
      }
    }
  }
  return true;
}

// The Gauss–Newton normal matrix H = JᵀJ over (θ, s_0, s_1, …) at the fit, the data rows weighted by
// `weight` (1/σ per measured row), and when `scores` is given, per chain and sample the score
// g_k = Σ_r J_rkᵀ w_r r_rk of the raw residuals `residuals` (for the Newey–West meat).
bool NormalMatrix(const ShootingProblem& pr, const Vec& theta, const std::vector<Vec>& s, const Vec& weight,
                  const std::vector<Mat>& residuals, Mat* H, std::vector<std::vector<Vec>>* scores) {
  const int p = pr.shared, n = pr.n;
  const auto P = static_cast<Eigen::Index>(p + n * static_cast<int>(pr.segments.size()));
  const auto m = static_cast<Eigen::Index>(pr.rows.size());
  *H = Mat::Zero(P, P);
  if (scores) scores->assign(residuals.size(), {});
  Vec row(P);
  for (std::size_t i = 0; i < pr.segments.size(); ++i) {
    const Segment& seg = pr.segments[i];
    SensitivityTrajectory tr;
    if (!SimulateSegment(pr, seg, pr.At(theta.data(), s[i].data(), seg.mode), true, &tr)) return false;
    const auto node = static_cast<Eigen::Index>(p + n * static_cast<int>(i));
    auto fill = [&](long k, int state, double w) {
      row.setZero();
      const auto S = tr.S(k);
      for (int c = 0; c < p; ++c) row[c] = w * S(state, c);
      for (int c = 0; c < n; ++c) row[node + c] = w * S(state, p + c);
    };
    for (long k = 0; k < seg.samples(); ++k) {
      Vec score = scores ? Vec::Zero(P) : Vec();
      for (Eigen::Index r = 0; r < m; ++r) {
        fill(k, pr.rows[std::size_t(r)], weight[r]);
        H->selfadjointView<Eigen::Lower>().rankUpdate(row);
        if (scores) score += weight[r] * residuals[seg.chain](r, seg.first + k) * row;
      }
      if (scores) (*scores)[seg.chain].push_back(std::move(score));
    }
    if (seg.continues) {
      for (int j = 0; j < n; ++j) {
        fill(seg.samples(), j, pr.link_weight[j]);
        row[node + n + j] = -pr.link_weight[j];
        H->selfadjointView<Eigen::Lower>().rankUpdate(row);
      }
    }
  }
  *H = H->selfadjointView<Eigen::Lower>();
  return true;
}

// The Newey–West meat Σ_k g_k g_kᵀ + Σ_{l=1}^{L} (1 − l/(L+1)) Σ_k (g_k g_{k−l}ᵀ + g_{k−l} g_kᵀ) within
// chains, L = ⌊4 (N/100)^{2/9}⌋.
Mat NeweyWest(const std::vector<std::vector<Vec>>& scores, Eigen::Index P) {
  long N = 0;
  for (const auto& c : scores) N += static_cast<long>(c.size());
  const int L = static_cast<int>(std::floor(4.0 * std::pow(static_cast<double>(N) / 100.0, 2.0 / 9.0)));
  Mat meat = Mat::Zero(P, P);
  for (const auto& g : scores) {
    const auto K = static_cast<Eigen::Index>(g.size());
    Mat G(P, K);
    for (Eigen::Index k = 0; k < K; ++k) G.col(k) = g[std::size_t(k)];
    meat.noalias() += G * G.transpose();
    for (int l = 1; l <= L && l < K; ++l) {
      const Mat cross = G.rightCols(K - l) * G.leftCols(K - l).transpose();
      meat.noalias() += (1.0 - l / (L + 1.0)) * (cross + cross.transpose());
    }
  }
  return meat;
}

}  // namespace

long TimeShootingNodeSpacing(long samples, int n) {
  return std::clamp(samples / 48, static_cast<long>(4 * n + 4), 2000L);
}

namespace {

// The problem's weights and tolerances (FitWeighting): σ given or the MAD estimate of each measured
// row, from the chains' samples read in place; the measured states' continuity scales c_j = σ_j (a
// hidden state's: WeighHidden).
void Weigh(const std::vector<RefineChain>& chains, const RefineOptions& options, ShootingProblem& pr) {
  const auto m = static_cast<Eigen::Index>(pr.rows.size());
  Vec mad(m), largest = Vec::Zero(m);
  long samples = 0;
  for (const RefineChain& c : chains) samples += static_cast<long>(c.y.cols());
  for (Eigen::Index r = 0; r < m; ++r) {
    const int j = pr.rows[std::size_t(r)];
    std::vector<double> d;
    for (const RefineChain& c : chains) {
      const Eigen::Index K = c.y.cols();
      if (K > 0) largest[r] = std::max(largest[r], c.y.row(j).cwiseAbs().maxCoeff());
      for (Eigen::Index k = 1; k + 1 < K; ++k) d.push_back(c.y(j, k + 1) - 2.0 * c.y(j, k) + c.y(j, k - 1));
    }
    mad[r] = d.size() >= 2 ? NoiseSigmaFromSecondDifferences(d) : 0.0;
  }
  RefineOptions o = options;
  if (o.sigma.size() == pr.n && m < pr.n) o.sigma = Vec(options.sigma(pr.rows));
  FitWeighting(largest, samples, o, mad, &pr.sens, &pr.weight);
  pr.scale = Vec::Constant(pr.n, 1.0 / pr.weight.maxCoeff());
  for (Eigen::Index r = 0; r < m; ++r) pr.scale[pr.rows[std::size_t(r)]] = 1.0 / pr.weight[r];
}

// Hidden states' continuity weights from their own range over the node starts.
void WeighHidden(const std::vector<Vec>& s, ShootingProblem& pr) {
  if (s.empty()) return;
  double measured_range = 0.0, measured_sigma = 0.0;
  for (std::size_t r = 0; r < pr.rows.size(); ++r) {
    double lo = s[0][pr.rows[r]], hi = lo;
    for (const Vec& x : s) lo = std::min(lo, x[pr.rows[r]]), hi = std::max(hi, x[pr.rows[r]]);
    if (hi - lo > measured_range) {
      measured_range = hi - lo;
      measured_sigma = 1.0 / pr.weight[Eigen::Index(r)];
    }
  }
  for (int j = 0; j < pr.n; ++j) {
    if (std::find(pr.rows.begin(), pr.rows.end(), j) != pr.rows.end()) continue;
    double lo = s[0][j], hi = lo;
    for (const Vec& x : s) lo = std::min(lo, x[j]), hi = std::max(hi, x[j]);
    const double scale = measured_range > 0.0 ? measured_sigma * std::max(hi - lo, 1e-12) / measured_range : 1.0;
    pr.scale[j] = scale;
  }
}

// Covariance, residual statistics and tests at the fit; the status.
void Judge(const ShootingProblem& pr, const std::vector<RefineChain>& chains, const Vec& theta,
           const std::vector<Vec>& s, const RefineOptions& options, RefineResult& r) {
  std::vector<Mat> residuals;
  if (!Residuals(pr, chains, theta, s, &residuals)) {
    Fail(r, RefineStatus::kNotConverged, "the fit does not simulate");
    return;
  }
  const auto m = static_cast<Eigen::Index>(pr.rows.size());
  const auto P = static_cast<double>(pr.shared + pr.n * static_cast<int>(pr.segments.size()));
  long N = 0;
  Vec squares = Vec::Zero(m);
  for (const Mat& res : residuals) {
    squares += res.rowwise().squaredNorm();
    N += static_cast<long>(res.cols());
  }
  const double dof = std::max(1.0, static_cast<double>(N) - P / static_cast<double>(m));
  r.sigma_estimated = options.sigma.size() == 0;
  const Vec sigma = r.sigma_estimated ? Vec((squares / dof).cwiseSqrt()) : Vec(pr.weight.cwiseInverse());
  r.sigma = Vec::Zero(pr.n);
  r.sigma(pr.rows) = sigma;
  const ResidualTestResult tests = ResidualTests(residuals, sigma, !r.sigma_estimated, P, options.residual_test_size);
  r.normalized_rms = std::sqrt(tests.level_statistic);
  r.lag1 = tests.lag1;
  Mat H;
  std::vector<std::vector<Vec>> scores;
  if (!NormalMatrix(pr, theta, s, sigma.cwiseInverse(), residuals, &H, tests.white ? nullptr : &scores)) {
    Fail(r, RefineStatus::kNotConverged, "the fit does not simulate with sensitivities");
    return;
  }
  const Eigen::LDLT<Mat> ldlt(H);
  const double largest = ldlt.vectorD().cwiseAbs().maxCoeff();
  if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().array() > 1e-13 * largest).all()) {
    Fail(r, RefineStatus::kSingularFisher, "the information matrix of the fit is singular");
    return;
  }
  const Mat Hinv = ldlt.solve(Mat::Identity(H.rows(), H.cols()));
  const Mat cov = tests.white ? Hinv : Mat(Hinv * NeweyWest(scores, H.rows()) * Hinv);
  std::vector<Eigen::Index> idx;  // θ, then the first chain's first node state
  for (int i = 0; i < pr.shared + pr.n; ++i) idx.push_back(i);
  r.covariance = cov(idx, idx);
  r.standard_errors = r.covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
  r.reported = true;
  if (!tests.level_ok) {
    Fail(r, RefineStatus::kResidualRms,
         fmt::format("the residuals are not at the given noise: Σ(r/σ)²/(N − p) = {:.4g} (a χ² test of size {:g} "
                     "refuses it); the estimates are reported",
                     tests.level_statistic, options.residual_test_size / 2));
  } else if (!tests.white) {
    Fail(r, RefineStatus::kResidualCorrelation,
         fmt::format("the residuals are not white: lag-1 autocorrelation {:.3g}, √N·ρ₁ = {:.3g} (a test of size {:g} "
                     "refuses it): the model fits but not to the noise; the estimates are reported with "
                     "standard errors from the Newey–West sandwich",
                     tests.lag1, tests.worst_z, options.residual_test_size / 2));
  }
}

RefineResult FitChainsByTime(const Model& model, const std::vector<RefineChain>& chains, const HybridParameters& start,
                             const RefineOptions& options, ShootingProblem& pr, long total);

}  // namespace

RefineResult FitByTimeShooting(const Model& model, const std::vector<RefineChain>& chains,
                               const HybridParameters& start, const RefineOptions& options) {
  RefineResult r;
  r.route = "multiple shooting by time";
  r.unknowns = Unknowns::Of(model);
  r.names = r.unknowns.Names(model);
  r.start = r.refined = r.estimate = start;
  ShootingProblem pr;
  pr.model = &model;
  pr.n = model.state_size();
  pr.unknowns = r.unknowns;
  pr.shared = r.unknowns.shared();
  pr.base = start;
  if (pr.base.gamma.size() == 0) pr.base.gamma = model.gamma();
  pr.rows = MeasuredRows(options, pr.n);
  // Chains of fewer than 2n + 2 samples are left out (as by the labelled routes).
  std::vector<RefineChain> fit;
  std::vector<std::size_t> index;
  long total = 0;
  for (std::size_t c = 0; c < chains.size(); ++c) {
    if (static_cast<long>(chains[c].t.size()) < 2L * pr.n + 2) continue;
    fit.push_back(chains[c]);
    index.push_back(c);
    total += static_cast<long>(chains[c].t.size());
  }
  if (fit.empty() || total < pr.shared + 2 * pr.n + 2) {
    Fail(r, RefineStatus::kTooFewSamples,
         fmt::format("{} samples in chains of at least {} for {} unknowns", total, 2 * pr.n + 2, pr.shared + pr.n));
    return r;
  }
  r = FitChainsByTime(model, fit, start, options, pr, total);
  // Back to the caller's chains: the ones left out have no initial state and no samples.
  std::vector<Vec> x0(chains.size());
  std::vector<long> used(chains.size(), 0);
  std::vector<int> mode(chains.size(), -1);
  for (std::size_t i = 0; i < index.size() && i < r.chain_x0.size(); ++i) {
    x0[index[i]] = r.chain_x0[i];
    used[index[i]] = r.chain_samples_used[i];
    mode[index[i]] = r.chain_mode[i];
  }
  r.chain_x0 = std::move(x0);
  r.chain_samples_used = std::move(used);
  r.chain_mode = std::move(mode);
  r.chains_skipped = static_cast<long>(chains.size() - index.size());
  return r;
}

namespace {

RefineResult FitChainsByTime(const Model& model, const std::vector<RefineChain>& chains, const HybridParameters& start,
                             const RefineOptions& options, ShootingProblem& pr, long total) {
  RefineResult r;
  r.route = "multiple shooting by time";
  r.unknowns = pr.unknowns;
  r.names = r.unknowns.Names(model);
  r.start = r.refined = r.estimate = start;
  Weigh(chains, options, pr);
  pr.segments = CutSegments(chains, pr.rows, TimeShootingNodeSpacing(total, pr.n));
  Vec theta = start.Theta(Unknowns{r.unknowns.alpha, r.unknowns.beta, r.unknowns.gamma, false});
  const std::vector<const Parameter*> params = r.unknowns.Parameters(model);
  for (int i = 0; i < pr.shared; ++i) theta[i] = std::clamp(theta[i], params[std::size_t(i)]->lower, params[std::size_t(i)]->upper);
  std::vector<Vec> s = StartNodes(pr, chains, theta, pr.segments);
  WeighHidden(s, pr);
  BestModes(pr, theta, s);
  // Continuation in the continuity's width: nearly free segments first (θ fit to each segment's own
  // data, where a far start cannot lead the whole record astray), then continuity tightened to ε.
  ceres::Solver::Summary summary;
  for (const double width : kContinuationWidths) {
    pr.link_weight = (width * pr.scale).cwiseInverse();
    for (int round = 0; round < kModeRounds; ++round) {
      summary = Solve(pr, options, theta, s);
      r.iterations += static_cast<int>(summary.iterations.size());
      if (r.initial_cost == 0.0) r.initial_cost = summary.initial_cost;
      if (options.stopped() || !summary.IsSolutionUsable()) break;
      Trim(pr, theta, s);
      if (SettleModes(pr, theta, s) == 0) break;
    }
    if (options.stopped() || !summary.IsSolutionUsable()) break;
  }
  // The final solve on every sample, read on the model's own events at the point reached (labels),
  // so that the cost is smooth there; again while the labels move.
  for (int round = 0; round < kModeRounds && summary.IsSolutionUsable() && !options.stopped(); ++round) {
    Trim(pr, theta, s, /*at_events_only=*/true);
    if (Relabel(pr, theta, s) == 0 && round > 0) break;
    summary = Solve(pr, options, theta, s);
    r.iterations += static_cast<int>(summary.iterations.size());
  }
  r.final_cost = summary.final_cost;
  r.samples_used = total;
  r.chains_used = static_cast<long>(chains.size());
  r.refined = pr.At(theta.data(), s.front().data(), pr.segments.front().mode);
  r.chain_x0.clear();
  r.chain_samples_used.clear();
  r.chain_mode.clear();
  for (std::size_t i = 0; i < pr.segments.size(); ++i) {
    if (i > 0 && pr.segments[i - 1].chain == pr.segments[i].chain) continue;
    r.chain_x0.push_back(s[i]);
    r.chain_mode.push_back(pr.segments[i].mode);
  }
  r.initial_mode = pr.segments.front().mode >= 0 ? pr.segments.front().mode : model.spec().default_mode;
  for (const RefineChain& c : chains) r.chain_samples_used.push_back(static_cast<long>(c.t.size()));
  const bool converged = summary.termination_type == ceres::CONVERGENCE || summary.termination_type == ceres::USER_SUCCESS;
  if (!converged || !theta.allFinite()) {
    Fail(r, RefineStatus::kNotConverged, fmt::format("multiple shooting by time: {}", summary.message));
    return r;
  }
  Judge(pr, chains, theta, s, options, r);
  r.mended = fmt::format("multiple shooting by time over {} segments", pr.segments.size());
  r.estimate = r.reported ? r.refined : r.start;
  return r;
}

}  // namespace
}  // namespace hysid
