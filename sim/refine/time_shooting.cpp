// Hybrid multiple shooting with nodes placed by time (sim/refine/time_shooting.hpp).
#include "sim/refine/time_shooting.hpp"

#include "sim/refine/budget.hpp"
#include "sim/refine/residual_tests.hpp"
#include "sim/refine/solver.hpp"
#include "sim/refine/start.hpp"
#include "sim/sensitivity/crlb.hpp"

#include <ceres/ceres.h>
#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <utility>

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
  bool off = false;           // does not simulate at the point reached (RepairNodes): left out of the solve
  long samples() const { return end - first; }
};

struct ShootingProblem {
  const Model* model = nullptr;
  Unknowns unknowns;        // α_u, β_u, γ_u and x0 (the node state)
  HybridParameters base;    // full vectors: the known entries
  std::vector<int> rows;    // measured rows
  Vec weight;               // per measured row: 1/σ
  Vec mad;                  // per measured row: σ's MAD estimate from the data's second differences
  Vec scale;                // per state: c_j (σ_j for a measured state)
  Vec link_weight;          // per state: 1/(ε c_j) at the current stage's ε
  bool tie_flat = false;    // FitByTimeShooting's tie_flat_hidden
  std::vector<bool> flat;   // per state: hidden, its node starts all equal (WeighHidden), tied at kFinalWidth
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
// last_steps: BudgetRun's.
bool SimulateSegment(const ShootingProblem& pr, const Segment& seg, const HybridParameters& at,
                     bool sensitivities, SensitivityTrajectory* out, Reading reading = Reading::kLabelled,
                     long last_steps = 0) {
  if (!Admissible(*pr.model, at, seg.inputs)) return false;
  SensitivityOptions o = pr.sens;
  o.sensitivities = sensitivities;
  BudgetRun(o, static_cast<long>(seg.times.size()), last_steps);
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

  // The run at (θ, node) made ahead of Ceres' call (SegmentRuns: every segment's on its own thread).
  void Prepare(const double* theta, const double* node) const { Run(pr_.shared > 0 ? theta : &kNone, node); }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const double* theta = pr_.shared > 0 ? parameters[0] : &kNone;
    const int b_s = pr_.shared > 0 ? 1 : 0;
    // With sensitivities whether or not Ceres asks for the Jacobian: the sensitivities take part in
    // CVODE's error test, so residuals from runs with and without them differ by the integration
    // error, and the costs Ceres compares must come from one integrator.
    if (!Run(theta, parameters[b_s])) return false;
    const SensitivityTrajectory& tr = run_;
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
  // The segment's run at (θ, node), kept for the next call at the same point: Ceres evaluates a
  // bounded problem's accepted point up to three times (its projected line search with the gradient,
  // the candidate's cost, the Jacobian of the step taken), and a run is deterministic.
  bool Run(const double* theta, const double* node) const {
    const auto p = static_cast<std::size_t>(pr_.shared), n = static_cast<std::size_t>(pr_.n);
    point_.resize(p + n);
    std::copy(theta, theta + p, point_.begin());
    std::copy(node, node + n, point_.begin() + static_cast<std::ptrdiff_t>(p));
    if (point_ == run_at_) return run_ok_;
    run_at_ = point_;
    run_ok_ = SimulateSegment(pr_, seg_, pr_.At(theta, node, seg_.mode), true, &run_, Reading::kLabelled,
                              completed_steps_);
    if (run_.trajectory.status.completed()) completed_steps_ = run_.trajectory.stats.steps;
    return run_ok_;
  }
  double Weight(int r, long k) const { return seg_.keep.size() ? pr_.weight[r] * seg_.keep(r, k) : pr_.weight[r]; }
  const ShootingProblem& pr_;
  const Segment& seg_;
  static constexpr double kNone = 0.0;
  mutable std::vector<double> point_, run_at_;
  mutable SensitivityTrajectory run_;
  mutable bool run_ok_ = false;
  mutable long completed_steps_ = 0;  // the CVODE steps of the last completed run (BudgetRun)
};

// A segment of chain `c` over samples [a, b): times from the node, measured rows and inputs copied;
// it continues (to the node at b) when the chain goes on.
Segment MakeSegment(const RefineChain& ch, std::size_t c, const std::vector<int>& rows, long a, long b) {
  const long K = static_cast<long>(ch.t.size());
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
  return s;
}

// The segments of the chains, nodes every `spacing` samples (a last piece shorter than half of it
// joins the one before).
std::vector<Segment> CutSegments(const std::vector<RefineChain>& chains, const std::vector<int>& rows, long spacing) {
  std::vector<Segment> out;
  for (std::size_t c = 0; c < chains.size(); ++c) {
    const long K = static_cast<long>(chains[c].t.size());
    for (long a = 0; a < K;) {
      long b = std::min(K, a + spacing);
      if (K - b < spacing / 2) b = K;
      out.push_back(MakeSegment(chains[c], c, rows, a, b));
      a = b;
    }
  }
  return out;
}

// Segment i's weighted squared residuals when simulated from (x, q) at θ; infinity when it does not simulate.
double SegmentFit(const ShootingProblem& pr, std::size_t i, const Vec& theta, const Vec& x, int q) {
  const Segment& seg = pr.segments[i];
  SensitivityTrajectory tr;
  if (!SimulateSegment(pr, seg, pr.At(theta.data(), x.data(), q), false, &tr, Reading::kOwn)) {
    return std::numeric_limits<double>::infinity();
  }
  double cost = 0.0;
  for (long k = 0; k < seg.samples(); ++k) {
    for (std::size_t r = 0; r < pr.rows.size(); ++r) {
      const double e =
          pr.weight[Eigen::Index(r)] * (tr.trajectory.x(pr.rows[r], k) - seg.y(Eigen::Index(r), k));
      if (std::isfinite(e)) cost += e * e;
    }
  }
  return cost;
}

// Per segment, its node's start: the measured rows from the data; the hidden rows from the previous
// segment simulated at the start, or their reconstruction where finite and its segment fits its
// samples better (a chain's first node: its reconstruction where finite, else the model's default
// state; a segment that cannot be simulated passes its node's rows on); modes from the chain's initial
// mode, then each previous segment's end.
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
    seg.mode =
        first ? ch.initial_mode
              : (have_prev && !prev.trajectory.q.empty() ? prev.trajectory.q.back() : segments[i - 1].mode);
    const Vec reconstructed = x;  // the hidden rows' reconstruction where finite
    bool any_reconstructed = false;
    for (int j = 0; j < pr.n; ++j) {
      if (std::find(pr.rows.begin(), pr.rows.end(), j) != pr.rows.end() && std::isfinite(x[j])) continue;
      if (have_prev) {
        any_reconstructed = any_reconstructed || std::isfinite(x[j]);
        x[j] = prev.trajectory.x(j, prev.trajectory.size() - 1);
      } else if (!std::isfinite(x[j])) {
        x[j] = first ? fallback[j] : s[i - 1][j];
      }
    }
    // The run from the start drifts from the data over a long record (a wrong β or γ puts every later
    // hidden state off): where the hidden rows have a reconstruction, the one of the two whose segment
    // fits its own samples better.
    if (any_reconstructed && seg.mode >= 0) {
      Vec local = x;
      for (int j = 0; j < pr.n; ++j) {
        if (std::isfinite(reconstructed[j])) local[j] = reconstructed[j];
      }
      if (SegmentFit(pr, i, theta, local, seg.mode) < SegmentFit(pr, i, theta, x, seg.mode)) x = local;
    }
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
    // A jump at the node itself, or several jumps between two samples (a chatter), cannot be read
    // matched: such a segment is read on its own run.
    std::vector<int> labels = tr.trajectory.j;
    if (!labels.empty() && labels.front() != 0) labels.clear();  // a jump at the node itself
    for (std::size_t k = 1; k < labels.size(); ++k) {
      if (labels[k] - labels[k - 1] > 1) {
        labels.clear();
        break;
      }
    }
    if (labels != seg.labels) {
      seg.labels = std::move(labels);
      ++changed;
    }
  }
  return changed;
}

// A node beside a jump of the model's own runs on either side of it (within L/8 samples, at least 2)
// sits near a guard: a step of its state leaves C, and a step of θ moves the jump across the node, so
// that the continuity residual changes by the jump's size. Such a node moves, within the two
// segments it joins (each keeping at least L/4 samples), to the sample farthest from their jumps;
// its state and mode become the runs' there. The number of nodes moved.
int MoveNodesOffEvents(ShootingProblem& pr, const std::vector<RefineChain>& chains, const Vec& theta,
                       std::vector<Vec>& s, long spacing) {
  const long margin = std::max(2L, spacing / 8), shortest = std::max(2L * pr.n + 2, spacing / 4);
  int moved = 0;
  for (std::size_t i = 0; i + 1 < pr.segments.size(); ++i) {
    const Segment& left = pr.segments[i];
    const Segment& right = pr.segments[i + 1];
    if (!left.continues || right.chain != left.chain) continue;
    SensitivityTrajectory a, b;
    if (!SimulateSegment(pr, left, pr.At(theta.data(), s[i].data(), left.mode), false, &a, Reading::kOwn) ||
        !SimulateSegment(pr, right, pr.At(theta.data(), s[i + 1].data(), right.mode), false, &b, Reading::kOwn)) {
      continue;
    }
    std::vector<long> events;  // chain samples e with a jump in (t_{e−1}, t_e]
    const long node_sample = left.end;
    if (!b.trajectory.j.empty() && b.trajectory.j.front() != 0) events.push_back(node_sample);  // at the node
    for (const auto& [seg, run] : {std::pair{&left, &a}, std::pair{&right, &b}}) {
      const std::vector<int>& j = run->trajectory.j;
      for (std::size_t k = 1; k < j.size(); ++k) {
        if (j[k] != j[k - 1]) events.push_back(seg->first + static_cast<long>(k));
      }
    }
    auto distance = [&](long k) {
      long d = std::numeric_limits<long>::max();
      for (const long e : events) d = std::min(d, k >= e ? k - e : e - 1 - k);
      return d;
    };
    const long node = left.end;
    const long lo = left.first + shortest, hi = right.end - shortest;
    if (distance(node) >= margin || lo > hi) continue;
    long best = node, far = distance(node);
    for (long k = lo; k <= hi; ++k) {
      const long d = distance(k);
      if (d > far || (d == far && std::abs(k - node) < std::abs(best - node))) best = k, far = d;
    }
    if (best == node) continue;
    const SensitivityTrajectory& run = best < node ? a : b;
    const long at = best < node ? best - left.first : best - node;
    s[i + 1] = run.trajectory.x.col(at);
    const int mode_left = left.mode;
    const int mode_right = run.trajectory.q.empty() ? right.mode : run.trajectory.q[std::size_t(at)];
    const std::size_t c = left.chain;
    const long first = left.first, end = right.end;
    pr.segments[i] = MakeSegment(chains[c], c, pr.rows, first, best);
    pr.segments[i + 1] = MakeSegment(chains[c], c, pr.rows, best, end);
    pr.segments[i].mode = mode_left;
    pr.segments[i + 1].mode = mode_right;
    ++moved;
  }
  return moved;
}

// In `other` (rows × samples), 1 where a sample lies on the other side of a jump of the model's run
// `run` than the model: from each jump outwards while the weighted residual r is nearer the jump's
// size Δ (before the jump: r ≈ −Δ; after it: r ≈ Δ) than zero, in some row.
void MarkOtherSide(const ShootingProblem& pr, const Trajectory& run, const Mat& r, Mat& other) {
  const std::vector<int>& j = run.j;
  const long K = r.cols();
  for (long e = 1; e < K; ++e) {
    if (j[std::size_t(e)] == j[std::size_t(e - 1)]) continue;
    Vec delta(r.rows());
    for (Eigen::Index row = 0; row < r.rows(); ++row) {
      delta[row] = pr.weight[row] * (run.x(pr.rows[std::size_t(row)], e) - run.x(pr.rows[std::size_t(row)], e - 1));
    }
    auto walk = [&](long k, long step, double sign) {
      for (; k >= 0 && k < K && j[std::size_t(k)] == j[std::size_t(step < 0 ? e - 1 : e)]; k += step) {
        bool any = false;
        for (Eigen::Index row = 0; row < r.rows(); ++row) {
          if (std::abs(r(row, k) - sign * delta[row]) < std::abs(r(row, k))) {
            other(row, k) = 1.0;
            any = true;
          }
        }
        if (!any) break;
      }
    };
    walk(e - 1, -1, -1.0);
    walk(e, +1, +1.0);
  }
}

// Samples whose weighted residual on the model's own run exceeds kTrim robust standard deviations
// (1.4826 · the median |w r|, at least 1) are left out of the next solves: a sample on the wrong side
// of a jump in a measured state (its residual the jump's size) carries no information the
// sensitivities can use. At the final solve (`at_events_only`) only samples on the other side of a
// jump of the model are left out: from the jump outwards, the samples whose residual is nearer the
// jump's size (model after the jump minus model before) than zero.
void Trim(ShootingProblem& pr, const Vec& theta, const std::vector<Vec>& s, bool at_events_only = false) {
  std::vector<Mat> residual(pr.segments.size()), eligible(pr.segments.size());
  std::vector<double> all;
  for (std::size_t i = 0; i < pr.segments.size(); ++i) {
    const Segment& seg = pr.segments[i];
    SensitivityTrajectory tr;
    if (!SimulateSegment(pr, seg, pr.At(theta.data(), s[i].data(), seg.mode), false, &tr, Reading::kOwn)) continue;
    Mat& r = residual[i];
    r.resize(seg.y.rows(), seg.samples());
    for (long k = 0; k < seg.samples(); ++k) {
      for (Eigen::Index j = 0; j < r.rows(); ++j) {
        r(j, k) = pr.weight[j] * (tr.trajectory.x(pr.rows[std::size_t(j)], k) - seg.y(j, k));
        all.push_back(std::abs(r(j, k)));
      }
    }
    eligible[i] = Mat::Constant(r.rows(), r.cols(), at_events_only ? 0.0 : 1.0);
    if (at_events_only) MarkOtherSide(pr, tr.trajectory, r, eligible[i]);
  }
  if (all.empty()) return;
  std::nth_element(all.begin(), all.begin() + long(all.size() / 2), all.end());
  const double cut = kTrim * std::max(1.0, 1.4826 * all[all.size() / 2]);
  for (std::size_t i = 0; i < pr.segments.size(); ++i) {
    if (residual[i].size() == 0) continue;
    pr.segments[i].keep =
        (residual[i].array().abs() <= cut || eligible[i].array() == 0.0).cast<double>().matrix();
  }
}

// Nodes whose segment does not simulate with its sensitivities at θ (a state outside C and D in its
// mode after θ or a mode moved, a grazing crossing, labels the run no longer follows): its own run,
// another mode, else the end of the segment before in its chain. A segment that still does not
// simulate (the model sticks in D from there at θ) is left out of the next solve (`off`); its node
// follows the segment before. The number of such segments.
int RepairNodes(ShootingProblem& pr, const Vec& theta, std::vector<Vec>& s) {
  const int modes = ModeCount(pr.model->spec());
  int failing = 0;
  for (std::size_t i = 0; i < pr.segments.size(); ++i) {
    Segment& seg = pr.segments[i];
    SensitivityTrajectory tr;
    seg.off = false;
    if (SimulateSegment(pr, seg, pr.At(theta.data(), s[i].data(), seg.mode), true, &tr)) continue;
    seg.labels.clear();  // read on its own run from here
    if (SimulateSegment(pr, seg, pr.At(theta.data(), s[i].data(), seg.mode), true, &tr)) continue;
    bool repaired = false;
    for (int q = 0; q < modes && !repaired; ++q) {
      if (q == seg.mode || !SimulateSegment(pr, seg, pr.At(theta.data(), s[i].data(), q), true, &tr)) continue;
      seg.mode = q;
      repaired = true;
    }
    const bool first = i == 0 || pr.segments[i - 1].chain != seg.chain;
    if (!repaired && !first) {
      const Segment& before = pr.segments[i - 1];
      SensitivityTrajectory prev;
      if (SimulateSegment(pr, before, pr.At(theta.data(), s[i - 1].data(), before.mode), false, &prev, Reading::kOwn)) {
        const Vec x = prev.trajectory.x.col(prev.trajectory.size() - 1);
        const int q = prev.trajectory.q.empty() ? before.mode : prev.trajectory.q.back();
        if (SimulateSegment(pr, seg, pr.At(theta.data(), x.data(), q), true, &tr)) {
          s[i] = x;
          seg.mode = q;
          repaired = true;
        }
      }
    }
    seg.off = !repaired;
    failing += repaired ? 0 : 1;
  }
  return failing;
}

// A hybrid automaton whose guards have unknown parameters γ: where the modes the data choose at two
// nodes of a chain (BestModes) differ and a jump map leads from the one to the other, the data
// switched inside the segment between them; where the model's own run does not make that switch, it
// is put at the sample that splits the
// segment's one-step trapezoid residuals best (the mode before, then the mode after), and γ moves by
// least-squares Newton steps that put these switches on their guards (AppendGuardRows,
// SolveGuardRows). A start whose guards the data never reach gives γ no gradient (the model never
// switches where the data do); this gives the model's own switches a start near the data's. Whether
// γ moved.
bool LocateSwitches(const ShootingProblem& pr, const std::vector<RefineChain>& chains, Vec& theta,
                    const std::vector<Vec>& s) {
  const Model& model = *pr.model;
  if (pr.unknowns.gamma.empty() || !IsAutomaton(model.spec())) return false;
  const std::vector<JumpMap> maps = JumpMaps(model.spec());
  const HybridParameters at = pr.At(theta.data(), s.front().data(), 0);
  const Vec alpha = at.alpha;
  Vec gamma = at.GammaOr(model);
  const int n = pr.n;
  std::vector<Mat> states(chains.size());  // measured rows from the data, hidden ones from the runs
  std::vector<std::vector<std::uint8_t>> labels(chains.size());
  std::vector<std::vector<int>> chain_maps(chains.size());
  std::vector<int> initial(chains.size(), -1);
  for (std::size_t c = 0; c < chains.size(); ++c) {
    states[c] = chains[c].y;
    labels[c].assign(chains[c].t.size(), 0);
  }
  for (std::size_t i = 0; i < pr.segments.size(); ++i) {
    const Segment& seg = pr.segments[i];
    if (initial[seg.chain] < 0) initial[seg.chain] = std::max(seg.mode, 0);
    SensitivityTrajectory tr;
    if (!SimulateSegment(pr, seg, pr.At(theta.data(), s[i].data(), seg.mode), false, &tr, Reading::kOwn)) continue;
    for (int j = 0; j < n; ++j) {
      if (std::find(pr.rows.begin(), pr.rows.end(), j) != pr.rows.end()) continue;
      states[seg.chain].row(j).segment(seg.first, seg.samples()) = tr.trajectory.x.row(j).head(seg.samples());
    }
  }
  Vec f0(n), f1(n);
  for (std::size_t i = 0; i + 1 < pr.segments.size(); ++i) {
    const Segment& seg = pr.segments[i];
    const Segment& next = pr.segments[i + 1];
    if (!seg.continues || next.chain != seg.chain || seg.mode == next.mode || seg.mode < 0 || next.mode < 0) continue;
    int map = -1;
    for (std::size_t m = 0; m < maps.size() && map < 0; ++m) {
      if ((maps[m].from == seg.mode || maps[m].from < 0) && maps[m].to == next.mode) map = static_cast<int>(m);
    }
    if (map < 0) continue;
    SensitivityTrajectory own;  // a switch the model makes itself is on its guard already
    if (SimulateSegment(pr, seg, pr.At(theta.data(), s[i].data(), seg.mode), false, &own, Reading::kOwn) &&
        !own.trajectory.q.empty() && own.trajectory.q.back() == next.mode) {
      continue;
    }
    const RefineChain& ch = chains[seg.chain];
    const Mat& x = states[seg.chain];
    // e_q(k): the weighted one-step trapezoid residual of the step k − 1 → k in mode q.
    auto step_residual = [&](long k, int q) {
      const auto a = static_cast<Eigen::Index>(k - 1), b = static_cast<Eigen::Index>(k);
      if (!x.col(a).allFinite() || !x.col(b).allFinite()) return 0.0;
      const double dt = ch.t[std::size_t(k)] - ch.t[std::size_t(k - 1)];
      Context ca{.t = ch.t[std::size_t(k - 1)], .u = ch.u.cols() ? ch.u.col(a).data() : nullptr, .gamma = gamma.data(),
                 .alpha = alpha.data(), .mode = q};
      Context cb = ca;
      cb.t = ch.t[std::size_t(k)];
      cb.u = ch.u.cols() ? ch.u.col(b).data() : nullptr;
      model.Flow(x.col(a), alpha, f0, ca);
      model.Flow(x.col(b), alpha, f1, cb);
      double e2 = 0.0;
      for (std::size_t r = 0; r < pr.rows.size(); ++r) {
        const int j = pr.rows[r];
        const double e = x(j, b) - x(j, a) - 0.5 * dt * (f0[j] + f1[j]);
        e2 += std::pow(pr.weight[Eigen::Index(r)] * e, 2);
      }
      return std::isfinite(e2) ? e2 : 0.0;
    };
    const long lo = seg.first + 1, hi = seg.end;  // the switch in (t_{k−1}, t_k], k ∈ [lo, hi]
    std::vector<double> before(std::size_t(hi - lo + 2), 0.0), after(std::size_t(hi - lo + 2), 0.0);
    for (long k = lo; k <= hi; ++k) before[std::size_t(k - lo + 1)] = before[std::size_t(k - lo)] + step_residual(k, seg.mode);
    for (long k = hi; k >= lo; --k) after[std::size_t(k - lo)] = after[std::size_t(k - lo + 1)] + step_residual(k, next.mode);
    long best = lo;
    double least = std::numeric_limits<double>::infinity();
    for (long k = lo; k <= hi; ++k) {
      const double cost = before[std::size_t(k - lo)] + after[std::size_t(k - lo)];
      if (cost < least) least = cost, best = k;
    }
    labels[seg.chain][std::size_t(best)] = 1;
    chain_maps[seg.chain].push_back(map);
  }
  const Vec gamma0 = gamma;
  for (int newton = 0; newton < 3; ++newton) {
    Mat rows(0, static_cast<Eigen::Index>(pr.unknowns.gamma.size()));
    Vec rhs(0);
    for (std::size_t c = 0; c < chains.size(); ++c) {
      AppendGuardRows(model, chains[c].t, states[c], labels[c], alpha, gamma, pr.unknowns, &rows, &rhs, chain_maps[c],
                      initial[c], chains[c].u);
    }
    gamma = SolveGuardRows(pr.unknowns, rows, rhs, gamma);
  }
  if (!gamma.allFinite() || gamma == gamma0) return false;
  const std::vector<const Parameter*> params = pr.unknowns.Parameters(model);
  const auto offset = static_cast<Eigen::Index>(pr.unknowns.alpha.size() + pr.unknowns.beta.size());
  for (std::size_t g = 0; g < pr.unknowns.gamma.size(); ++g) {
    const auto i = offset + static_cast<Eigen::Index>(g);
    theta[i] = std::clamp(gamma[pr.unknowns.gamma[g]], params[std::size_t(i)]->lower, params[std::size_t(i)]->upper);
  }
  return true;
}

// A hybrid automaton: each node's mode the one whose segment, simulated from the node's state at θ,
// fits the segment's samples best (the data's own say on a hidden mode; modes in which the state
// lies outside C and D are not candidates).
void BestModes(ShootingProblem& pr, const Vec& theta, const std::vector<Vec>& s) {
  const int modes = ModeCount(pr.model->spec());
  if (modes < 2) return;
  for (std::size_t i = 0; i < pr.segments.size(); ++i) {
    double best = std::numeric_limits<double>::infinity();
    for (int q = 0; q < modes; ++q) {
      const double cost = SegmentFit(pr, i, theta, s[i], q);
      if (cost < best) {
        best = cost;
        pr.segments[i].mode = q;
      }
    }
  }
}

// Whether the model follows the data segment by segment at (θ, s): on at least half the segments, the
// mean squared weighted residual per measured cell is at most kSegmentNoiseRatio (twice the noise's
// variance). The median, not the sum: a few segments a node in a wrong mode or an outlier leaves far
// off do not hide that the others fit to the noise; model error puts most segments off (the Cascaded
// Tanks: 5–10 times).
bool MostSegmentsAtNoise(const ShootingProblem& pr, const Vec& theta, const std::vector<Vec>& s) {
  std::vector<double> ratio;
  for (std::size_t i = 0; i < pr.segments.size(); ++i) {
    const auto cells = pr.segments[i].y.array().isFinite().count();
    if (cells > 0) ratio.push_back(SegmentFit(pr, i, theta, s[i], pr.segments[i].mode) / static_cast<double>(cells));
  }
  if (ratio.empty()) return false;
  const auto middle = ratio.begin() + static_cast<std::ptrdiff_t>(ratio.size() / 2);
  std::nth_element(ratio.begin(), middle, ratio.end());
  return *middle <= kSegmentNoiseRatio;
}

// At the point reached, each node's (state, mode) pair against the data's: its own state or the one
// with the measured rows at the node's sample, in each mode. A node the continuation left in a wrong
// mode with a state fitted to it (a state past a guard, where both modes run alike) is set right.
// The number of nodes changed.
int SetNodesFromData(ShootingProblem& pr, const Vec& theta, std::vector<Vec>& s) {
  const int modes = ModeCount(pr.model->spec());
  int changed = 0;
  for (std::size_t i = 0; i < pr.segments.size(); ++i) {
    Segment& seg = pr.segments[i];
    Vec data = s[i];
    for (std::size_t r = 0; r < pr.rows.size(); ++r) {
      if (std::isfinite(seg.y(Eigen::Index(r), 0))) data[pr.rows[r]] = seg.y(Eigen::Index(r), 0);
    }
    const double now = SegmentFit(pr, i, theta, s[i], seg.mode);
    double best = now;
    int mode = seg.mode;
    bool from_data = false;
    for (int q = 0; q < modes; ++q) {
      for (const bool d : {false, true}) {
        const double c = SegmentFit(pr, i, theta, d ? data : s[i], q);
        if (c < best) best = c, mode = q, from_data = d;
      }
    }
    // A clear improvement only: the node's own fitted pair is kept on a near tie.
    if (mode == seg.mode && !from_data) continue;
    if (!(best < now - 9.0)) continue;
    seg.mode = mode;
    if (from_data) s[i] = data;
    ++changed;
  }
  return changed;
}

// Before each of Ceres' evaluations (the point is then in theta and s), every segment's run, the
// segments side by side: each run is its own, so the residuals and the cost Ceres sums in its order
// do not depend on the threads.
class SegmentRuns final : public ceres::EvaluationCallback {
 public:
  SegmentRuns(const Vec& theta, const std::vector<Vec>& s) : theta_(theta), s_(s) {}
  void Add(std::size_t segment, const SegmentCost* cost) { costs_.emplace_back(segment, cost); }
  void PrepareForEvaluation(bool /*evaluate_jacobians*/, bool /*new_evaluation_point*/) override {
    tbb::parallel_for(std::size_t{0}, costs_.size(), [&](std::size_t k) {
      costs_[k].second->Prepare(theta_.data(), s_[costs_[k].first].data());
    });
  }

 private:
  const Vec& theta_;
  const std::vector<Vec>& s_;
  std::vector<std::pair<std::size_t, const SegmentCost*>> costs_;
};

// The cost ½·m·N of m measured rows over N samples at the noise: the scale of Ceres' relative
// function tolerance.
double ExpectedCost(const ShootingProblem& pr) {
  long samples = 0;
  for (const Segment& seg : pr.segments) samples += seg.samples();
  return std::max(1.0, 0.5 * static_cast<double>(pr.rows.size()) * static_cast<double>(samples));
}

// Ends a solve at its best point after kStalledSteps rejected steps in a row at a cost of at most
// `near` (kStallCostRatio).
class StallStop final : public ceres::IterationCallback {
 public:
  explicit StallStop(double near) : near_(near) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& it) override {
    if (it.iteration == 0 || it.step_is_successful) {
      cost_ = it.cost;  // a rejected step's summary holds the cost of the point it tried
      rejected_ = 0;
      return ceres::SOLVER_CONTINUE;
    }
    return ++rejected_ >= kStalledSteps && cost_ <= near_ ? ceres::SOLVER_TERMINATE_SUCCESSFULLY
                                                          : ceres::SOLVER_CONTINUE;
  }

 private:
  double near_, cost_ = 0.0;
  int rejected_ = 0;
};

ceres::Solver::Summary Solve(const ShootingProblem& pr, const RefineOptions& options, Vec& theta,
                             std::vector<Vec>& s) {
  SegmentRuns runs(theta, s);
  ceres::Problem::Options po;
  po.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  po.evaluation_callback = &runs;
  ceres::Problem cp(po);
  for (std::size_t i = 0; i < pr.segments.size(); ++i) {
    if (pr.segments[i].off) continue;
    std::vector<double*> blocks;
    if (pr.shared > 0) blocks.push_back(theta.data());
    blocks.push_back(s[i].data());
    if (pr.segments[i].continues) blocks.push_back(s[i + 1].data());
    auto* cost = new SegmentCost(pr, i);
    runs.Add(i, cost);
    cp.AddResidualBlock(cost, nullptr, blocks);
  }
  // Every segment off (none simulates at the point, or its runs were stopped): nothing to solve, and
  // the default summary's FAILURE says so.
  if (cp.NumResidualBlocks() == 0) return {};
  const std::vector<const Parameter*> params = pr.unknowns.Parameters(*pr.model);
  for (int i = 0; i < pr.shared; ++i) {
    if (std::isfinite(params[std::size_t(i)]->lower)) cp.SetParameterLowerBound(theta.data(), i, params[std::size_t(i)]->lower);
    if (std::isfinite(params[std::size_t(i)]->upper)) cp.SetParameterUpperBound(theta.data(), i, params[std::size_t(i)]->upper);
  }
  ceres::Solver::Options so = LevenbergMarquardt(options);
  so.function_tolerance = std::max(so.function_tolerance, kCostResolution / ExpectedCost(pr));
  so.linear_solver_type = ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::SUITE_SPARSE)
                              ? ceres::SPARSE_NORMAL_CHOLESKY
                              : ceres::DENSE_QR;
  StallStop stall(kStallCostRatio * ExpectedCost(pr));
  so.callbacks.push_back(&stall);
  ceres::Solver::Summary summary;
  ceres::Solve(so, &cp, &summary);
  return summary;
}

// The raw data residuals (model − data) per chain (rows × K) at the fit, from the states alone (a
// segment whose labels its run no longer follows read on its own run).
bool Residuals(const ShootingProblem& pr, const std::vector<RefineChain>& chains, const Vec& theta,
               const std::vector<Vec>& s, std::vector<Mat>* out) {
  const auto m = static_cast<Eigen::Index>(pr.rows.size());
  out->assign(chains.size(), Mat());
  for (std::size_t c = 0; c < chains.size(); ++c) (*out)[c] = Mat::Zero(m, Eigen::Index(chains[c].t.size()));
  for (std::size_t i = 0; i < pr.segments.size(); ++i) {
    const Segment& seg = pr.segments[i];
    SensitivityTrajectory tr;
    const HybridParameters at = pr.At(theta.data(), s[i].data(), seg.mode);
    if (!SimulateSegment(pr, seg, at, false, &tr) && !SimulateSegment(pr, seg, at, false, &tr, Reading::kOwn)) {
      return false;
    }
    for (long k = 0; k < seg.samples(); ++k) {
      for (Eigen::Index r = 0; r < m; ++r) {
        (*out)[seg.chain](r, seg.first + k) = tr.trajectory.x(pr.rows[std::size_t(r)], k) - seg.y(r, k);
      }
    }
  }
  return true;
}

// The information of the fit with its continuity exact: the fit's point as a function of θ and the
// states of the free nodes (each chain's first), every later node the run from the one before,
// linearised there. Over r = (θ, the free nodes' states), with the data rows weighted by `weight`
// (1/σ per measured row): the Gauss–Newton information M = Σ_k J_kᵀ J_k of the data alone, the map
// T from r to (θ, s_0, s_1, …) (s_{i+1} = ∂x(τ_{i+1})/∂(θ, s_i) · T_i r), and when `scores` is
// given, per chain and sample the score g_k = Σ_r J_rkᵀ w_r r_rk of the raw residuals `residuals`
// (for the Newey–West meat). The continuity rows do not enter: soft at any width ε, they would let
// each node move by about ε·c_j as if the state were kicked there, and a parameter told by its effect
// accumulated over many segments would get a larger standard error than the bound's (the hopper's
// drag, cli.identify.accumulated_drag).
struct Information {
  Mat M, T;
  std::vector<std::vector<Vec>> scores;
};

bool ExactInformation(const ShootingProblem& pr, const Vec& theta, const std::vector<Vec>& s, const Vec& weight,
                      const std::vector<Mat>& residuals, Information* out, bool scores) {
  const int p = pr.shared, n = pr.n;
  const auto segments = static_cast<Eigen::Index>(pr.segments.size());
  const auto m = static_cast<Eigen::Index>(pr.rows.size());
  Eigen::Index free_nodes = 0;
  for (Eigen::Index i = 0; i < segments; ++i) free_nodes += i == 0 || !pr.segments[std::size_t(i - 1)].continues;
  const Eigen::Index R = p + n * free_nodes;
  out->T = Mat::Zero(p + n * segments, R);
  out->T.topLeftCorner(p, p).setIdentity();
  out->M = Mat::Zero(R, R);
  out->scores.assign(residuals.size(), {});
  Mat local(p + n, p + n), at_node(p + n, R);
  Vec row(p + n);
  Eigen::Index next_free = p;
  for (Eigen::Index i = 0; i < segments; ++i) {
    const Segment& seg = pr.segments[std::size_t(i)];
    SensitivityTrajectory tr;
    const HybridParameters at = pr.At(theta.data(), s[std::size_t(i)].data(), seg.mode);
    if (!SimulateSegment(pr, seg, at, true, &tr) && !SimulateSegment(pr, seg, at, true, &tr, Reading::kOwn)) {
      return false;
    }
    const Eigen::Index node = p + n * i;
    if (i == 0 || !pr.segments[std::size_t(i - 1)].continues) {
      out->T.block(node, next_free, n, n).setIdentity();
      next_free += n;
    }
    at_node << out->T.topRows(p), out->T.middleRows(node, n);
    local.setZero();
    for (long k = 0; k < seg.samples(); ++k) {
      Vec score = scores ? Vec::Zero(p + n) : Vec();
      for (Eigen::Index r = 0; r < m; ++r) {
        if (seg.keep.size() && seg.keep(r, k) == 0.0) continue;  // left out of the final solve
        row = weight[r] * tr.S(k).row(pr.rows[std::size_t(r)]).transpose();
        local.selfadjointView<Eigen::Lower>().rankUpdate(row);
        const double residual = residuals[seg.chain](r, seg.first + k);
        if (scores && std::isfinite(residual)) score += weight[r] * residual * row;
      }
      if (scores) out->scores[seg.chain].push_back(at_node.transpose() * score);
    }
    out->M += at_node.transpose() * Mat(local.selfadjointView<Eigen::Lower>()) * at_node;
    if (seg.continues) out->T.middleRows(node + n, n) = tr.S(seg.samples()) * at_node;
  }
  return out->M.allFinite() && out->T.allFinite();
}

// The Gauss–Newton step of the single-shooting cost at (θ, s), with the fit's weights: δ = −M⁻¹g over
// θ and the free nodes (M and g = Σ_k g_k from ExactInformation: the data rows, the continuity exact),
// its change of θ and every node, T·δ, in *change, and its length in the information's metric,
// λ = √(gᵀM⁻¹g) (standard errors at σ = 1/w), in *lambda, and the data rows' cost ½Σ(w·r)² (the
// continuity's left out) in *data_cost. False when the point does not simulate or M is singular.
bool GaussNewtonStep(const ShootingProblem& pr, const std::vector<RefineChain>& chains, const Vec& theta,
                     const std::vector<Vec>& s, Vec* change, double* lambda, double* data_cost) {
  std::vector<Mat> residuals;
  Information info;
  if (!Residuals(pr, chains, theta, s, &residuals) ||
      !ExactInformation(pr, theta, s, pr.weight, residuals, &info, /*scores=*/true)) {
    return false;
  }
  *data_cost = 0.0;
  for (const Segment& seg : pr.segments) {
    for (long k = 0; k < seg.samples(); ++k) {
      for (Eigen::Index r = 0; r < pr.weight.size(); ++r) {
        const double residual = residuals[seg.chain](r, seg.first + k);
        if ((seg.keep.size() == 0 || seg.keep(r, k) != 0.0) && std::isfinite(residual)) {
          *data_cost += 0.5 * std::pow(pr.weight[r] * residual, 2);
        }
      }
    }
  }
  Vec g = Vec::Zero(info.M.rows());
  for (const std::vector<Vec>& chain : info.scores) {
    for (const Vec& score : chain) g += score;
  }
  const Vec scale = info.M.diagonal().cwiseMax(std::numeric_limits<double>::min()).cwiseSqrt().cwiseInverse();
  const Eigen::LDLT<Mat> ldlt(scale.asDiagonal() * info.M * scale.asDiagonal());
  if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().array() > 1e-13 * ldlt.vectorD().cwiseAbs().maxCoeff()).all()) {
    return false;
  }
  const Vec delta = -(scale.asDiagonal() * ldlt.solve(scale.asDiagonal() * g));
  *lambda = std::sqrt(std::max(0.0, -g.dot(delta)));
  *change = info.T * delta;
  return change->allFinite() && std::isfinite(*lambda);
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
  pr.mad = mad;
  pr.scale = Vec::Constant(pr.n, 1.0 / pr.weight.maxCoeff());
  for (Eigen::Index r = 0; r < m; ++r) pr.scale[pr.rows[std::size_t(r)]] = 1.0 / pr.weight[r];
}

// A hidden state's continuity scale from what it does to the measured rows: c_j with
// 1/c_j² the mean over the segments' samples of Σ_r (S_rj(t_k)/σ_r)², S_rj the measured row r's
// sensitivity to the node's state j, run from the node starts at θ. A mismatch of c_j at a node then
// moves the measured rows by about one noise sd per sample, as a measured state's σ_j does. 0 when
// no segment simulates or the state does not reach the measured rows.
double HiddenScaleFromSensitivities(const ShootingProblem& pr, const Vec& theta, const std::vector<Vec>& s, int j) {
  double sum = 0.0;
  long samples = 0;
  for (std::size_t i = 0; i < pr.segments.size(); ++i) {
    const Segment& seg = pr.segments[i];
    SensitivityTrajectory tr;
    if (!SimulateSegment(pr, seg, pr.At(theta.data(), s[i].data(), seg.mode), true, &tr, Reading::kOwn)) {
      continue;
    }
    for (long k = 0; k < seg.samples(); ++k) {
      const auto S = tr.S(k);
      for (std::size_t r = 0; r < pr.rows.size(); ++r) {
        const double e = pr.weight[Eigen::Index(r)] * S(pr.rows[r], pr.shared + j);
        if (std::isfinite(e)) sum += e * e;
      }
      ++samples;
    }
  }
  return sum > 0.0 ? std::sqrt(static_cast<double>(samples) / sum) : 0.0;
}

// Hidden states' continuity weights from their own range over the node starts, against the measured
// state's of the widest range; a hidden state whose node starts do not vary (a constant, or a start
// that leaves it so) from its sensitivities (HiddenScaleFromSensitivities), and with tie_flat `flat`:
// tied at kFinalWidth from the first width on.
void WeighHidden(const Vec& theta, const std::vector<Vec>& s, ShootingProblem& pr) {
  pr.flat.assign(std::size_t(pr.n), false);
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
    double scale = measured_range > 0.0 ? measured_sigma * std::max(hi - lo, kFlatRange) / measured_range : 1.0;
    if (hi - lo < kFlatRange) {
      if (const double c = HiddenScaleFromSensitivities(pr, theta, s, j); c > 0.0) scale = c;
      pr.flat[std::size_t(j)] = pr.tie_flat;
    }
    pr.scale[j] = scale;
  }
}

// The smallest eigenvalue of the symmetric a by inverse iteration on its factorization, and its
// eigenvector in *v: a direction the model cannot tell apart (a hidden state's scale against the
// gains that read it) has an eigenvalue at rounding, while the pivots of a large matrix's
// factorization can all stay orders above it. 0 when a solve is not finite.
double SmallestEigenvalue(const Mat& a, const Eigen::LDLT<Mat>& ldlt, Vec* v) {
  *v = Vec::LinSpaced(a.rows(), 1.0, 2.0).normalized();
  for (int k = 0; k < 6; ++k) {
    const Vec w = ldlt.solve(*v);
    if (!w.allFinite() || w.norm() == 0.0) return 0.0;
    *v = w.normalized();
  }
  return v->dot(a * *v);
}

// Covariance, residual statistics and tests at the fit; the status. `full`: the covariance of θ and
// every node state (pr.segments' order), when reported.
void Judge(const ShootingProblem& pr, const std::vector<RefineChain>& chains, const Vec& theta,
           const std::vector<Vec>& s, const RefineOptions& options, RefineResult& r, Mat* full) {
  std::vector<Mat> residuals;
  if (!Residuals(pr, chains, theta, s, &residuals)) {
    Fail(r, RefineStatus::kNotConverged, "the fit does not simulate");
    return;
  }
  const auto m = static_cast<Eigen::Index>(pr.rows.size());
  // The parameters the residuals spend: θ and one initial state per chain (the continuity rows tie
  // every other node to the segment before, to within ε).
  const auto P = static_cast<double>(pr.shared + pr.n * static_cast<int>(chains.size()));
  // The samples the final solve left out (beside a fitted jump, on its other side) are left out of
  // the tests and the information too.
  long left_out = 0;
  for (const Segment& seg : pr.segments) {
    if (seg.keep.size() == 0) continue;
    for (long k = 0; k < seg.samples(); ++k) {
      for (Eigen::Index j = 0; j < m; ++j) {
        if (seg.keep(j, k) != 0.0) continue;
        residuals[seg.chain](j, seg.first + k) = std::numeric_limits<double>::quiet_NaN();
        ++left_out;
      }
    }
  }
  long N = 0;
  Vec squares = Vec::Zero(m);
  for (const Mat& res : residuals) {
    for (Eigen::Index j = 0; j < m; ++j) {
      for (Eigen::Index k = 0; k < res.cols(); ++k) {
        if (std::isfinite(res(j, k))) squares[j] += res(j, k) * res(j, k);
      }
    }
    N += static_cast<long>(res.cols());
  }
  N -= left_out / std::max<Eigen::Index>(m, 1);
  r.left_out = left_out;
  const double dof = std::max(1.0, static_cast<double>(N) - P / static_cast<double>(m));
  r.sigma_estimated = options.sigma.size() == 0;
  // Residuals at the integration accuracy in every row (noise-free data) get no test, σ the accuracy.
  Vec magnitude = Vec::Zero(m);
  for (const RefineChain& c : chains) {
    for (Eigen::Index j = 0; j < m && c.y.cols() > 0; ++j) {
      magnitude[j] = std::max(magnitude[j], c.y.row(pr.rows[std::size_t(j)]).cwiseAbs().maxCoeff());
    }
  }
  const Vec floor = NumericalFloor(magnitude, pr.sens.sim);
  const Vec sigma_hat = (squares / dof).cwiseSqrt();
  const bool numerical = (sigma_hat.array() < floor.array()).all();
  const Vec sigma = (r.sigma_estimated ? sigma_hat : Vec(pr.weight.cwiseInverse())).cwiseMax(1e-3 * floor);
  r.sigma = Vec::Zero(pr.n);
  r.sigma(pr.rows) = sigma;
  ResidualTestResult tests = ResidualTests(residuals, sigma, !r.sigma_estimated, P, options.residual_test_size);
  if (numerical) tests.level_ok = tests.white = true;
  r.normalized_rms = std::sqrt(tests.level_statistic);
  r.lag1 = tests.lag1;
  // σ estimated: σ̂ against the data's own noise, as on the labelled routes (JudgeResiduals), the
  // normalised RMS reported.
  const double over_mad = r.sigma_estimated && !numerical ? SigmaOverMad(sigma_hat, pr.mad, floor) : 0.0;
  if (over_mad > 0.0) r.normalized_rms = over_mad;
  Information info;
  if (!ExactInformation(pr, theta, s, sigma.cwiseInverse(), residuals, &info, !tests.white)) {
    Fail(r, RefineStatus::kNotConverged, "the fit does not simulate with sensitivities");
    return;
  }
  const Mat& H = info.M;
  // The singularity test on the Jacobi-scaled matrix S H S (S = diag(H_ii^−½)): the units a parameter
  // is written in scale its row and column, not its information.
  const Vec scale = H.diagonal().cwiseMax(std::numeric_limits<double>::min()).cwiseSqrt().cwiseInverse();
  const Mat scaled = scale.asDiagonal() * H * scale.asDiagonal();
  const Eigen::LDLT<Mat> ldlt(scaled);
  const double largest = ldlt.vectorD().cwiseAbs().maxCoeff();
  Vec weakest;
  const bool pivots = ldlt.info() == Eigen::Success && (ldlt.vectorD().array() > 1e-13 * largest).all();
  if (SmallestEigenvalue(scaled, ldlt, &weakest) <= 1e-13 * largest || !pivots) {
    Fail(r, RefineStatus::kSingularFisher,
         weakest.allFinite()
             ? fmt::format("the information matrix of the fit is singular ({} of the scaled parameters)",
                           Direction(weakest.head(std::min<Eigen::Index>(weakest.size(),
                                                                         Eigen::Index(r.names.size()))),
                                     r.names))
             : std::string("the information matrix of the fit is singular"));
    const bool at_the_noise = tests.level_ok && tests.white && !(over_mad > options.rms_high);
    if (at_the_noise && H.rows() <= RefineResult::kMaxDeterminedSize) {
      const Vec sd = DeterminedSd(H);
      if (sd.size() != 0) r.determined_standard_errors = sd.head(pr.shared + pr.n);
    }
    return;
  }
  const Mat Hinv = scale.asDiagonal() * ldlt.solve(Mat::Identity(H.rows(), H.cols())) * scale.asDiagonal();
  const Mat cov = tests.white ? Hinv : Mat(Hinv * NeweyWestMeat(info.scores, H.rows()) * Hinv);
  // θ, then the first chain's first node state (the first free node).
  r.covariance = cov.topLeftCorner(pr.shared + pr.n, pr.shared + pr.n);
  *full = info.T * cov * info.T.transpose();
  r.standard_errors = r.covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
  r.reported = true;
  if (!tests.level_ok) {
    Fail(r, RefineStatus::kResidualRms,
         fmt::format("the residuals are not at the given noise: Σ(r/σ)²/(N − p) = {:.4g} (a χ² test of size {:g} "
                     "refuses it); the estimates are reported",
                     tests.level_statistic, options.residual_test_size / 2));
  } else if (over_mad > options.rms_high) {
    Fail(r, RefineStatus::kResidualRms,
         fmt::format(
             "residual sigma over the MAD estimate {:.4g} > {:g}: the residuals are not at the data's own "
             "noise (outliers, or model error); the estimates are reported",
             over_mad, options.rms_high));
  } else if (!tests.white) {
    Fail(r, RefineStatus::kResidualCorrelation,
         fmt::format("the residuals are not white: lag-1 autocorrelation {:.3g}, √N·ρ₁ = {:.3g} (a test of size {:g} "
                     "refuses it): the model fits but not to the noise; the estimates are reported with "
                     "standard errors from the Newey–West sandwich",
                     tests.lag1, tests.worst_z, options.residual_test_size / 2));
  }
}

// A caller's chain's initial state as the fit reaches it: from a node's state, and its derivative
// by (θ, that state) (n × (shared + n); empty when the run from the node does not reach it).
struct NodeReach {
  std::size_t node = 0;
  Mat derivative;
};

// Per caller's chain: the covariance of θ and its initial state, J C Jᵀ with C the block of `full`
// for θ and the node's state and J = [I 0; ∂x/∂θ ∂x/∂s] (empty where the derivative is).
std::vector<Mat> ChainCovariances(const ShootingProblem& pr, const std::vector<NodeReach>& reach, const Mat& full) {
  std::vector<Mat> out;
  const int p = pr.shared, n = pr.n;
  for (const NodeReach& to : reach) {
    if (to.derivative.size() == 0) {
      out.emplace_back();
      continue;
    }
    std::vector<Eigen::Index> idx;
    for (int i = 0; i < p; ++i) idx.push_back(i);
    for (int i = 0; i < n; ++i) idx.push_back(p + n * static_cast<Eigen::Index>(to.node) + i);
    Mat J = Mat::Zero(p + n, p + n);
    J.topLeftCorner(p, p).setIdentity();
    J.bottomRows(n) = to.derivative;
    out.push_back(J * full(idx, idx) * J.transpose());
  }
  return out;
}

// A caller's chain within a joined one: the joined chain and its first sample there.
struct ChainStart {
  std::size_t chain = 0;
  long offset = 0;
};

RefineResult FitChainsByTime(const Model& model, const std::vector<RefineChain>& chains, const HybridParameters& start,
                             const RefineOptions& options, ShootingProblem& pr, long total,
                             const std::vector<ChainStart>& starts);

// A chain and the ones after it in its run after gaps, as one chain (times, samples, inputs joined).
RefineChain Joined(const std::vector<RefineChain>& chains, std::size_t first, std::size_t end) {
  std::vector<double> t;
  std::vector<std::uint8_t> gamma;
  std::vector<int> maps;
  Eigen::Index cols = 0;
  for (std::size_t c = first; c < end; ++c) cols += static_cast<Eigen::Index>(chains[c].t.size());
  Mat y(chains[first].y.rows(), cols), u(chains[first].u.rows(), chains[first].u.rows() ? cols : 0);
  Eigen::Index at = 0;
  for (std::size_t c = first; c < end; ++c) {
    const RefineChain& ch = chains[c];
    const auto k = static_cast<Eigen::Index>(ch.t.size());
    t.insert(t.end(), ch.t.begin(), ch.t.end());
    gamma.insert(gamma.end(), ch.gamma.begin(), ch.gamma.end());
    maps.insert(maps.end(), ch.maps.begin(), ch.maps.end());
    y.middleCols(at, k) = ch.y;
    if (u.cols()) u.middleCols(at, k) = ch.u;
    at += k;
  }
  RefineChain out = RefineChain::Of(std::move(t), std::move(y), std::move(gamma), std::move(u));
  out.maps = std::move(maps);
  out.initial_mode = chains[first].initial_mode;
  return out;
}

ShootingProblem ProblemOf(const Model& model, const HybridParameters& start, const RefineOptions& options) {
  ShootingProblem pr;
  pr.model = &model;
  pr.n = model.state_size();
  pr.unknowns = Unknowns::Of(model);
  pr.shared = pr.unknowns.shared();
  pr.base = start;
  if (pr.base.gamma.size() == 0) pr.base.gamma = model.gamma();
  pr.rows = MeasuredRows(options, pr.n);
  return pr;
}

// The value of γ entry `entry` that puts x on guard g (Newton on h_g(x, γ) = 0 from γ), or NaN.
double GammaOnGuard(const Model& model, const Vec& x, Context ctx, Vec gamma, int g, int entry) {
  Vec h(model.guard_count());
  Mat dh(model.guard_count(), model.gamma_size());
  for (int step = 0; step < 20; ++step) {
    ctx.gamma = gamma.data();
    model.Guards(x, h, ctx);
    model.GuardGammaJacobian(x, ctx, dh);
    const double slope = dh(g, entry);
    if (!std::isfinite(h[g]) || !std::isfinite(slope) || slope == 0.0) return std::numeric_limits<double>::quiet_NaN();
    const double move = h[g] / slope;
    gamma[entry] -= move;
    if (std::abs(move) <= 1e-10 * (1.0 + std::abs(gamma[entry]))) return gamma[entry];
  }
  return std::numeric_limits<double>::quiet_NaN();
}

// Per jump map, over the segments' runs: whether one switches by it, and the values of the one unknown
// γ entry its guard reads that put each run sample in the map's mode on the guard.
struct GuardReach {
  std::vector<std::uint8_t> switched;
  std::vector<std::vector<double>> on_guard;
  std::vector<int> entry;  // the γ entry (−1: none, or the guard reads several)
};

GuardReach ReachOfRuns(const ShootingProblem& pr, const std::vector<RefineChain>& chains, const Vec& theta,
                       const std::vector<Vec>& s) {
  const Model& model = *pr.model;
  const std::vector<JumpMap> maps = JumpMaps(model.spec());
  const HybridParameters at0 = pr.At(theta.data(), s.front().data(), 0);
  const Vec gamma = at0.GammaOr(model);
  GuardReach reach{std::vector<std::uint8_t>(maps.size(), 0), std::vector<std::vector<double>>(maps.size()),
                   std::vector<int>(maps.size(), -1)};
  Mat dh(model.guard_count(), model.gamma_size());
  for (std::size_t i = 0; i < pr.segments.size(); ++i) {
    const Segment& seg = pr.segments[i];
    SensitivityTrajectory tr;
    if (!SimulateSegment(pr, seg, pr.At(theta.data(), s[i].data(), seg.mode), false, &tr, Reading::kOwn)) continue;
    const Trajectory& run = tr.trajectory;
    const RefineChain& ch = chains[seg.chain];
    for (long k = 0; k < std::min<long>(seg.samples(), run.size()); ++k) {
      const int q = run.q.empty() ? std::max(seg.mode, 0) : run.q[std::size_t(k)];
      const int before = k > 0 && !run.q.empty() ? run.q[std::size_t(k - 1)] : q;
      const auto col = static_cast<Eigen::Index>(seg.first + k);
      const Context ctx{.t = ch.t[std::size_t(col)], .u = ch.u.cols() ? ch.u.col(col).data() : nullptr,
                        .gamma = gamma.data(), .alpha = at0.alpha.data(), .mode = q};
      const Vec x = run.x.col(k);
      model.GuardGammaJacobian(x, ctx, dh);
      for (std::size_t m = 0; m < maps.size(); ++m) {
        if (before != q && (maps[m].from == before || maps[m].from < 0) && maps[m].to == q) reach.switched[m] = 1;
        if (maps[m].guard < 0 || (maps[m].from >= 0 && maps[m].from != q)) continue;
        int entry = -1, depends = 0;
        for (const int j : pr.unknowns.gamma) {
          if (dh(maps[m].guard, j) != 0.0) entry = j, ++depends;
        }
        if (depends != 1) continue;
        const double value = GammaOnGuard(model, x, ctx, gamma, maps[m].guard, entry);
        if (std::isfinite(value)) reach.on_guard[m].push_back(value), reach.entry[m] = entry;
      }
    }
  }
  return reach;
}

}  // namespace

std::optional<Vec> GammaReachingGuards(const Model& model, const std::vector<RefineChain>& chains,
                                       const HybridParameters& start, const RefineOptions& options) {
  if (!IsAutomaton(model.spec()) || chains.empty()) return std::nullopt;
  ShootingProblem pr = ProblemOf(model, start, options);
  if (pr.unknowns.gamma.empty()) return std::nullopt;
  Weigh(chains, options, pr);
  long total = 0;
  for (const RefineChain& c : chains) total += static_cast<long>(c.t.size());
  pr.segments = CutSegments(chains, pr.rows, TimeShootingNodeSpacing(total, pr.n));
  Vec theta = start.Theta(Unknowns{pr.unknowns.alpha, pr.unknowns.beta, pr.unknowns.gamma, false});
  const std::vector<const Parameter*> params = pr.unknowns.Parameters(model);
  for (int i = 0; i < pr.shared; ++i) theta[i] = std::clamp(theta[i], params[std::size_t(i)]->lower, params[std::size_t(i)]->upper);
  const std::vector<Vec> s = StartNodes(pr, chains, theta, pr.segments);
  GuardReach reach = ReachOfRuns(pr, chains, theta, s);
  // Each γ entry of a guard no run reaches: the quantile kGuardReach, from the side of its start, of
  // the values that put the runs' samples on the guard.
  const Vec gamma = pr.At(theta.data(), s.front().data(), 0).GammaOr(model);
  Vec out = gamma;
  for (std::size_t m = 0; m < reach.switched.size(); ++m) {
    std::vector<double>& v = reach.on_guard[m];
    const int j = reach.entry[m];
    if (reach.switched[m] || v.empty() || j < 0) continue;
    std::sort(v.begin(), v.end());
    const double q = gamma[j] > v[v.size() / 2] ? 1.0 - kGuardReach : kGuardReach;
    const Parameter& p = model.spec().guard_params[std::size_t(j)];
    out[j] = std::clamp(v[std::size_t(q * double(v.size() - 1))], p.lower, p.upper);
  }
  if (out == gamma) return std::nullopt;
  return out;
}

RefineResult FitByTimeShooting(const Model& model, const std::vector<RefineChain>& chains,
                               const HybridParameters& start, const RefineOptions& options, bool tie_flat_hidden) {
  RefineResult r;
  r.route = "multiple shooting by time";
  r.unknowns = Unknowns::Of(model);
  r.names = r.unknowns.Names(model);
  r.start = r.refined = r.estimate = start;
  ShootingProblem pr = ProblemOf(model, start, options);
  pr.tie_flat = tie_flat_hidden;
  // The chains of a run joined through their gaps; joined chains of fewer than 2n + 2 samples are
  // left out (as by the labelled routes). Per caller's chain: its joined chain and first sample there.
  std::vector<RefineChain> fit;
  std::vector<ChainStart> starts;
  std::vector<std::size_t> index;
  long total = 0;
  for (std::size_t c = 0; c < chains.size();) {
    std::size_t end = c + 1;
    while (end < chains.size() && chains[end].after_gap) ++end;
    RefineChain joined = end == c + 1 ? chains[c] : Joined(chains, c, end);
    if (static_cast<long>(joined.t.size()) >= 2L * pr.n + 2) {
      long offset = 0;
      for (std::size_t k = c; k < end; ++k) {
        starts.push_back({fit.size(), offset});
        index.push_back(k);
        offset += static_cast<long>(chains[k].t.size());
      }
      total += static_cast<long>(joined.t.size());
      fit.push_back(std::move(joined));
    }
    c = end;
  }
  if (fit.empty() || total < pr.shared + 2 * pr.n + 2) {
    Fail(r, RefineStatus::kTooFewSamples,
         fmt::format("{} samples in chains of at least {} for {} unknowns", total, 2 * pr.n + 2, pr.shared + pr.n));
    return r;
  }
  r = FitChainsByTime(model, fit, start, options, pr, total, starts);
  // Back to the caller's chains: the ones left out have no initial state and no samples.
  std::vector<Vec> x0(chains.size());
  std::vector<long> used(chains.size(), 0);
  std::vector<int> mode(chains.size(), -1);
  std::vector<Mat> covariance(r.chain_covariance.empty() ? 0 : chains.size());
  for (std::size_t i = 0; i < index.size() && i < r.chain_x0.size(); ++i) {
    x0[index[i]] = r.chain_x0[i];
    used[index[i]] = static_cast<long>(chains[index[i]].t.size());
    mode[index[i]] = r.chain_mode[i];
    if (i < r.chain_covariance.size()) covariance[index[i]] = r.chain_covariance[i];
  }
  r.chain_covariance = std::move(covariance);
  r.chain_x0 = std::move(x0);
  r.chain_samples_used = std::move(used);
  r.chain_span_reason.assign(chains.size(), "");  // no span is cut
  r.chain_mode = std::move(mode);
  r.chains_skipped = static_cast<long>(chains.size() - index.size());
  r.chains_used = static_cast<long>(index.size());
  r.gaps_joined = static_cast<long>(index.size() - fit.size());
  return r;
}

namespace {

RefineResult FitChainsByTime(const Model& model, const std::vector<RefineChain>& chains, const HybridParameters& start,
                             const RefineOptions& options, ShootingProblem& pr, long total,
                             const std::vector<ChainStart>& starts) {
  RefineResult r;
  r.route = "multiple shooting by time";
  r.unknowns = pr.unknowns;
  r.names = r.unknowns.Names(model);
  r.start = r.refined = r.estimate = start;
  Weigh(chains, options, pr);
  const long spacing = TimeShootingNodeSpacing(total, pr.n);
  pr.segments = CutSegments(chains, pr.rows, spacing);
  Vec theta = start.Theta(Unknowns{r.unknowns.alpha, r.unknowns.beta, r.unknowns.gamma, false});
  const std::vector<const Parameter*> params = r.unknowns.Parameters(model);
  for (int i = 0; i < pr.shared; ++i) theta[i] = std::clamp(theta[i], params[std::size_t(i)]->lower, params[std::size_t(i)]->upper);
  std::vector<Vec> s = StartNodes(pr, chains, theta, pr.segments);
  WeighHidden(theta, s, pr);
  BestModes(pr, theta, s);
  MoveNodesOffEvents(pr, chains, theta, s, spacing);
  // Continuation in the continuity's width: nearly free segments first (θ fit to each segment's own
  // data, where a far start cannot lead the whole record astray), then continuity tightened to ε.
  ceres::Solver::Summary summary;
  // The route's budget: kIterationBudget solves' worth of iterations in all.
  const int budget = kIterationBudget * options.max_iterations;
  // A stage that fit the data to the noise (its cost at most twice the expected ½mN) whose next
  // width costs more than kWidthCostGrowth times as much has left its basin: that width's solve is
  // dropped, and the fit goes on from the stage's point at a width a shorter step away (the step's
  // square root).
  const double noise_level_cost = static_cast<double>(total) * static_cast<double>(pr.rows.size());
  double width = kFirstWidth, step = kWidthStep, width_before = width, cost_before = 0.0;
  Vec theta_before = theta;
  std::vector<Vec> s_before = s;
  std::vector<Segment> segments_before = pr.segments;
  for (bool first = true;; first = false) {
    pr.link_weight = (width * pr.scale).cwiseInverse();
    for (int j = 0; j < pr.n; ++j) {  // a flat hidden state tied at every width (kFinalWidth)
      if (pr.flat[std::size_t(j)]) pr.link_weight[j] = 1.0 / (kFinalWidth * pr.scale[j]);
    }
    for (int round = 0; round < kModeRounds && r.iterations < budget; ++round) {
      RepairNodes(pr, theta, s);
      summary = Solve(pr, options, theta, s);
      r.iterations += static_cast<int>(summary.iterations.size());
      if (r.initial_cost == 0.0) r.initial_cost = summary.initial_cost;
      if (options.stopped() || !summary.IsSolutionUsable()) break;
      if (first && round == 0) {  // α fit to the segments: the data's switches
        const Vec before = theta;
        const std::vector<Segment> segments = pr.segments;
        BestModes(pr, theta, s);
        if (LocateSwitches(pr, chains, theta, s)) {
          if (RepairNodes(pr, theta, s) == 0) continue;
          theta = before;
          pr.segments = segments;
        }
      }
      Trim(pr, theta, s);
      const int settled = SettleModes(pr, theta, s);
      if (MoveNodesOffEvents(pr, chains, theta, s, spacing) + settled == 0) break;
    }
    if (options.stopped() || !summary.IsSolutionUsable()) break;
    if (first) r.segments_fit_noise = MostSegmentsAtNoise(pr, theta, s);
    if (!first && cost_before <= noise_level_cost && summary.final_cost > kWidthCostGrowth * cost_before &&
        step > kShortestWidthStep && r.iterations < budget) {
      theta = theta_before;
      s = s_before;
      pr.segments = segments_before;
      step = std::sqrt(step);
      width = width_before / step;
      continue;
    }
    if (width <= kLastWidth) break;
    theta_before = theta;
    s_before = s;
    segments_before = pr.segments;
    cost_before = summary.final_cost;
    width_before = width;
    width = width / step > kLastWidth * kWidthRounding ? width / step : kLastWidth;
  }
  // The nodes against the data at the point reached (SetNodesFromData), and the last width solved
  // again; kept when its cost is lower.
  if (summary.IsSolutionUsable() && !options.stopped() && r.iterations < budget) {
    const Vec theta_before = theta;
    const std::vector<Vec> s_before = s;
    const std::vector<Segment> segments_before = pr.segments;
    if (SetNodesFromData(pr, theta, s) > 0) {
      RepairNodes(pr, theta, s);
      const ceres::Solver::Summary next = Solve(pr, options, theta, s);
      r.iterations += static_cast<int>(next.iterations.size());
      if (next.IsSolutionUsable() && next.final_cost < summary.final_cost) {
        summary = next;
      } else {
        theta = theta_before;
        s = s_before;
        pr.segments = segments_before;
      }
    }
  }
  // The final solve on every sample, read on the model's own events at the point reached (labels),
  // so that the cost is smooth there; again while the labels move; its continuity at kFinalWidth. A
  // solve that fails leaves the point of the one before.
  pr.link_weight = (kFinalWidth * pr.scale).cwiseInverse();
  auto final_solves = [&] {
    for (int round = 0; round < kModeRounds && summary.IsSolutionUsable() && !options.stopped() && r.iterations < budget;
         ++round) {
      Trim(pr, theta, s, /*at_events_only=*/true);
      if (Relabel(pr, theta, s) == 0 && round > 0) break;
      RepairNodes(pr, theta, s);
      const ceres::Solver::Summary next = Solve(pr, options, theta, s);
      r.iterations += static_cast<int>(next.iterations.size());
      if (!next.IsSolutionUsable()) break;
      summary = next;
    }
  };
  final_solves();
  // The final solve can end short of the optimum: at the final width a step of θ has to move every
  // node with it, and the continuity residuals, at the integration's own error there, make the cost
  // rough enough to stop Levenberg–Marquardt. The single-shooting Gauss–Newton step says how far
  // (GaussNewtonStep): longer than kOptimumStep, θ and the nodes take it together and the final solve
  // runs again from there, kept when its cost is lower; at most kOptimumSteps times. Only near the
  // noise's level (the data rows' cost at most kStallCostRatio times the expected ½mN; the
  // continuity rows' share of the final cost is the integration's error, not the fit's): a fit far
  // above it is refused by its residual tests whatever its step, and its steps are measured against
  // a σ its residuals do not have.
  double to_optimum = 0.0;
  for (int step = 0; step <= kOptimumSteps && summary.IsSolutionUsable() && !options.stopped(); ++step) {
    Vec change;
    double data_cost = 0.0;
    if (!GaussNewtonStep(pr, chains, theta, s, &change, &to_optimum, &data_cost) ||
        data_cost > kStallCostRatio * ExpectedCost(pr)) {
      to_optimum = 0.0;
      break;
    }
    if (to_optimum <= kOptimumStep || step == kOptimumSteps || r.iterations >= budget) break;
    const Vec theta_before = theta;
    const std::vector<Vec> s_before = s;
    const std::vector<Segment> segments_before = pr.segments;
    const ceres::Solver::Summary summary_before = summary;
    theta += change.head(pr.shared);
    for (int i = 0; i < pr.shared; ++i) theta[i] = std::clamp(theta[i], params[std::size_t(i)]->lower, params[std::size_t(i)]->upper);
    for (std::size_t i = 0; i < s.size(); ++i) s[i] += change.segment(pr.shared + pr.n * Eigen::Index(i), pr.n);
    final_solves();
    if (!summary.IsSolutionUsable() || summary.final_cost >= summary_before.final_cost) {
      theta = theta_before;
      s = s_before;
      pr.segments = segments_before;
      summary = summary_before;
      break;
    }
  }
  r.final_cost = summary.final_cost;
  r.samples_used = total;
  r.chains_used = static_cast<long>(chains.size());
  r.refined = pr.At(theta.data(), s.front().data(), pr.segments.front().mode);
  r.chain_x0.clear();
  r.chain_mode.clear();
  // Per caller's chain: its first node, or after a gap the state and mode the fit runs through there,
  // with that state's derivative by (θ, the node's state) for its covariance.
  std::vector<NodeReach> reach;
  for (const ChainStart& at : starts) {
    std::size_t i = 0;
    while (i + 1 < pr.segments.size() &&
           (pr.segments[i].chain != at.chain || pr.segments[i].end <= at.offset)) {
      ++i;
    }
    const Segment& seg = pr.segments[i];
    Vec x = s[i];
    int mode = seg.mode;
    NodeReach to{.node = i, .derivative = Mat::Zero(pr.n, pr.shared + pr.n)};
    to.derivative.rightCols(pr.n).setIdentity();
    SensitivityTrajectory tr;
    if (at.offset > seg.first) {
      const long k = at.offset - seg.first;
      if (SimulateSegment(pr, seg, pr.At(theta.data(), s[i].data(), seg.mode), true, &tr, Reading::kOwn) &&
          tr.trajectory.size() > k) {
        x = tr.trajectory.x.col(k);
        if (!tr.trajectory.q.empty()) mode = tr.trajectory.q[std::size_t(k)];
        to.derivative = tr.S(k);
      } else {
        to.derivative.resize(0, 0);
      }
    }
    r.chain_x0.push_back(x);
    r.chain_mode.push_back(mode);
    reach.push_back(std::move(to));
  }
  r.initial_mode = pr.segments.front().mode >= 0 ? pr.segments.front().mode : model.spec().default_mode;
  const bool converged = summary.termination_type == ceres::CONVERGENCE || summary.termination_type == ceres::USER_SUCCESS;
  if (r.iterations >= budget) {
    Fail(r, RefineStatus::kNotConverged,
         fmt::format("multiple shooting by time: its budget of {} iterations is spent", budget));
    return r;
  }
  if (!converged || !theta.allFinite()) {
    Fail(r, RefineStatus::kNotConverged, fmt::format("multiple shooting by time: {}", summary.message));
    return r;
  }
  if (to_optimum > kOptimumStep) {
    Fail(r, RefineStatus::kNotConverged,
         fmt::format("multiple shooting by time: the solve ended {:.3g} standard errors from the optimum its "
                     "Gauss–Newton step points to",
                     to_optimum));
    return r;
  }
  Mat full;
  Judge(pr, chains, theta, s, options, r, &full);
  if (r.reported) r.chain_covariance = ChainCovariances(pr, reach, full);
  r.mended = fmt::format("multiple shooting by time over {} segments", pr.segments.size());
  for (int j = 0; j < pr.n; ++j) {
    if (pr.flat[std::size_t(j)]) r.mended += fmt::format(" ({} held continuous)", model.spec().state_names[std::size_t(j)]);
  }
  r.estimate = r.reported ? r.refined : r.start;
  return r;
}

}  // namespace
}  // namespace hysid
