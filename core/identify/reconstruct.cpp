// Reconstruction of unmeasured states: the plan from the flow's structure, kinks as jumps, and
// Savitzky–Golay slopes per flow segment (core/identify/reconstruct.hpp).
#include "core/identify/reconstruct.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <Eigen/Dense>
#include <fmt/format.h>

#include "core/model/noise_shape.hpp"

namespace hysid {

bool ReconstructOptions::IsValid(std::string* error) const {
  auto fail = [&](std::string what) {
    if (error) *error = std::move(what);
    return false;
  };
  if (!(kink_threshold > 0.0) || !std::isfinite(kink_threshold)) {
    return fail(fmt::format("ReconstructOptions::kink_threshold = {}: must be finite and > 0", kink_threshold));
  }
  if (chord < 1) return fail(fmt::format("ReconstructOptions::chord = {}: must be >= 1", chord));
  if (!(kink_precision > 0.0) || !std::isfinite(kink_precision)) {
    return fail(fmt::format("ReconstructOptions::kink_precision = {}: must be finite and > 0", kink_precision));
  }
  if (median_window < 3 || median_window % 2 == 0) {
    return fail(fmt::format("ReconstructOptions::median_window = {}: must be odd and >= 3", median_window));
  }
  if (min_window < 3 || min_window % 2 == 0) {
    return fail(fmt::format("ReconstructOptions::min_window = {}: must be odd and >= 3", min_window));
  }
  if (!(slope_precision > 0.0) || !std::isfinite(slope_precision)) {
    return fail(fmt::format("ReconstructOptions::slope_precision = {}: must be finite and > 0", slope_precision));
  }
  if (!(max_window_share > 0.0) || !(max_window_share <= 1.0)) {
    return fail(fmt::format("ReconstructOptions::max_window_share = {}: must be in (0, 1]", max_window_share));
  }
  return true;
}

namespace {

// States at which the flow's structure is probed: the default initial state and deterministic
// perturbations of it.
std::vector<Vec> ProbeStates(const Model& model) {
  const int n = model.state_size();
  const std::vector<double>& d = model.spec().default_x0;
  const Vec base = static_cast<int>(d.size()) == n ? Vec(Eigen::Map<const Vec>(d.data(), n)) : Vec(Vec::Zero(n));
  std::vector<Vec> states{base};
  for (const double s : {0.37, -0.61, 1.3}) {
    Vec x = base;
    for (int i = 0; i < n; ++i) x[i] += s * (1.0 + 0.5 * i) * (1.0 + std::abs(base[i]));
    states.push_back(x);
  }
  return states;
}

// Row j of the flow at the probe states: (i, c, d) when f_j = c ξ_i + d for one unmeasured i.
bool IntegratorRow(const Model& model, const std::vector<Vec>& probes, const std::vector<int>& measured, int j,
                   int* i_out, double* c_out, double* d_out) {
  const int n = model.state_size();
  Mat jac(n, n);
  Vec f(n);
  int source = -1;
  double c = 0.0, d = 0.0;
  const std::vector<double> u(model.spec().inputs.size(), 0.0);  // inputs at 0: d must not depend on u
  const Context at{.t = 0.0, .u = u.empty() ? nullptr : u.data(), .gamma = nullptr};
  for (std::size_t p = 0; p < probes.size(); ++p) {
    model.FlowJacobian(probes[p], model.alpha(), jac, at);
    model.Flow(probes[p], model.alpha(), f, at);
    int nonzero = -1;
    for (int i = 0; i < n; ++i) {
      if (jac(j, i) == 0.0) continue;
      if (nonzero >= 0) return false;
      nonzero = i;
    }
    if (nonzero < 0 || std::count(measured.begin(), measured.end(), nonzero) > 0) return false;
    const double cp = jac(j, nonzero), dp = f[j] - cp * probes[p][nonzero];
    const double tol = 1e-9 * (1.0 + std::abs(cp) + std::abs(dp));
    if (p > 0 && (nonzero != source || std::abs(cp - c) > tol || std::abs(dp - d) > tol)) return false;
    source = nonzero;
    c = cp;
    d = dp;
  }
  *i_out = source;
  *c_out = c;
  *d_out = d;
  return true;
}

}  // namespace

ReconstructionPlan PlanReconstruction(const Model& model, const std::vector<int>& measured) {
  const int n = model.state_size();
  ReconstructionPlan plan;
  plan.measured = measured;
  std::sort(plan.measured.begin(), plan.measured.end());
  for (std::size_t a = 0; a < plan.measured.size(); ++a) {
    if (plan.measured[a] < 0 || plan.measured[a] >= n || (a > 0 && plan.measured[a] == plan.measured[a - 1])) {
      throw std::invalid_argument(fmt::format("measured state index {}: out of range [0, {}) or repeated",
                                              plan.measured[a], n));
    }
  }
  plan.source.assign(static_cast<std::size_t>(n), -1);
  plan.scale = Vec::Ones(n);
  plan.offset = Vec::Zero(n);
  if (static_cast<int>(plan.measured.size()) == n) return plan;  // nothing to reconstruct
  const std::vector<Vec> probes = ProbeStates(model);
  const std::vector<int>& rows = model.spec().flow_rows;
  for (const int j : plan.measured) {
    int i = -1;
    double c = 0.0, d = 0.0;
    if (std::count(rows.begin(), rows.end(), j) > 0 || !IntegratorRow(model, probes, plan.measured, j, &i, &c, &d))
      continue;
    if (plan.source[static_cast<std::size_t>(i)] >= 0) continue;  // the first measured partner
    plan.source[static_cast<std::size_t>(i)] = j;
    plan.scale[i] = c;
    plan.offset[i] = d;
  }
  for (int i = 0; i < n; ++i) {
    if (std::count(plan.measured.begin(), plan.measured.end(), i) > 0) continue;
    plan.reconstructed.push_back(i);
    if (plan.source[static_cast<std::size_t>(i)] < 0 && plan.error.empty()) {
      plan.error = fmt::format(
          "state '{}' is not measured and cannot be reconstructed: no measured state y has y' = c·{} + d "
          "with c, d known",
          model.spec().state_names[static_cast<std::size_t>(i)], model.spec().state_names[static_cast<std::size_t>(i)]);
    }
  }
  return plan;
}

double LocalSlope(const std::vector<double>& t, const double* y, long first, long size, long k) {
  const auto tk = t[static_cast<std::size_t>(k)];
  double h = 0.0;
  for (long i = first; i < first + size; ++i) h = std::max(h, std::abs(t[static_cast<std::size_t>(i)] - tk));
  const int degree = size >= 3 ? 2 : 1;
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (long i = first; i < first + size; ++i) {
    const double u = (t[static_cast<std::size_t>(i)] - tk) / h;
    const Eigen::Vector3d basis(1.0, u, u * u);
    a += basis * basis.transpose();
    b += basis * y[i];
  }
  const int m = degree + 1;
  const Eigen::VectorXd c = a.topLeftCorner(m, m).ldlt().solve(b.head(m));
  return c[1] / h;
}

void SavitzkyGolaySlope(const std::vector<double>& t, const double* y, long begin, long end, int window,
                        double* slope) {
  const long length = end - begin;
  if (length == 1) {
    slope[begin] = 0.0;
    return;
  }
  const long w = std::min<long>(window, length);
  // Uniform steps: the centred window's slope is Σ i y_{k+i} / (δt Σ i²) (the τ² column is
  // orthogonal to τ on a symmetric grid), one dot product instead of a 3 × 3 solve.
  const double step = (t[static_cast<std::size_t>(end - 1)] - t[static_cast<std::size_t>(begin)]) / double(length - 1);
  bool uniform = w % 2 == 1;
  for (long k = begin + 1; k < end && uniform; ++k) {
    uniform = std::abs(t[static_cast<std::size_t>(k)] - t[static_cast<std::size_t>(k - 1)] - step) <= 1e-9 * step;
  }
  const long half = w / 2;
  const double norm = step * static_cast<double>(half * (half + 1) * (2 * half + 1)) / 3.0;
  for (long k = begin; k < end; ++k) {
    const long first = std::clamp(k - half, begin, end - w);
    if (uniform && first == k - half) {
      double sum = 0.0;
      for (long i = 1; i <= half; ++i) sum += static_cast<double>(i) * (y[k + i] - y[k - i]);
      slope[k] = sum / norm;
    } else {
      slope[k] = LocalSlope(t, y, first, w, k);
    }
  }
}

namespace {

// The running median of v over windows of `window` entries (clipped at the ends), taken every
// window/16 entries (and at the last) and interpolated linearly between (it follows the flow's
// curvature, which is smooth on that scale).
std::vector<double> RunningMedian(const std::vector<double>& v, int window) {
  std::vector<double> out(v.size()), buffer;
  const auto size = static_cast<long>(v.size());
  const long stride = std::max(1, window / 16);
  auto median = [&](long k) {
    const long lo = std::max(0L, k - window / 2), hi = std::min(size, k + window / 2 + 1);
    buffer.assign(v.begin() + lo, v.begin() + hi);
    const auto mid = buffer.begin() + static_cast<long>(buffer.size() / 2);
    std::nth_element(buffer.begin(), mid, buffer.end());
    return *mid;
  };
  long previous = 0;
  double at_previous = size > 0 ? median(0) : 0.0;
  for (long k = 0; k < size; k = previous) {
    const long next = std::min(size - 1, previous + stride);
    const double at_next = next == previous ? at_previous : median(next);
    for (long i = previous; i <= next; ++i) {
      const double f = next == previous ? 0.0 : static_cast<double>(i - previous) / static_cast<double>(next - previous);
      out[static_cast<std::size_t>(i)] = (1.0 - f) * at_previous + f * at_next;
    }
    if (next == previous) break;
    previous = next;
    at_previous = at_next;
  }
  return out;
}

// 1.4826 · median |v| (0 for an empty v).
double MadScale(std::vector<double> v) {
  if (v.empty()) return 0.0;
  for (double& x : v) x = std::abs(x);
  const auto mid = v.begin() + static_cast<long>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return 1.4826 * *mid;
}

// The statistic of the intervals of chain [a, b) for row r: z[k + 1 − a] for the interval (t_k, t_{k+1}].
// `known`: kinks found already (increasing samples), whose chords' statistics are left out of the floor.
void ChainKinkStatistic(const std::vector<double>& t, const double* y, long a, long b, double sigma, long w,
                        const std::vector<long>& known, const ReconstructOptions& options,
                        std::vector<double>& z) {
  if (b - a < 2 * w + 2) return;
  auto span = [&](long from, long to) { return t[static_cast<std::size_t>(to)] - t[static_cast<std::size_t>(from)]; };
  auto chord = [&](long from, long to) { return (y[to] - y[from]) / span(from, to); };
  std::vector<double> ds, sd;
  double scale = 0.0;
  for (long k = a + w; k + 1 + w < b; ++k) {  // the interval (t_k, t_{k+1}]
    ds.push_back(chord(k + 1, k + 1 + w) - chord(k - w, k));
    const double before = span(k - w, k), after = span(k + 1, k + 1 + w);
    sd.push_back(sigma * std::sqrt(2.0 / (before * before) + 2.0 / (after * after)));
    scale = std::max(scale, std::abs(chord(k - w, k)));
  }
  // Wider than the 2w + 1 statistics a kink raises, so that the median stays the flow's.
  const std::vector<double> median = RunningMedian(ds, std::max<int>(options.median_window, 4 * static_cast<int>(w) + 1));
  std::vector<double> residual(ds.size()), quiet;
  for (std::size_t i = 0; i < ds.size(); ++i) {
    residual[i] = ds[i] - median[i];
    const long k = a + w + 1 + static_cast<long>(i);
    const auto near = std::lower_bound(known.begin(), known.end(), k - w - 1);
    if (near == known.end() || *near > k + w + 1) quiet.push_back(residual[i]);
  }
  // Noise-free data: the spread of the flow's own curvature (and rounding) is the scale, taken
  // away from the kinks known (their statistics are not the flow's) while a tenth of them remain.
  const bool enough = quiet.size() >= std::max<std::size_t>(20, ds.size() / 10);
  const double floor = std::max(MadScale(enough ? quiet : residual), 1e-12 * scale + 1e-300);
  for (std::size_t i = 0; i < ds.size(); ++i) {
    const auto at = static_cast<std::size_t>(w + 1) + i;
    z[at] = std::max(z[at], std::abs(residual[i]) / std::max(sd[i], floor));
  }
}

// The chord (samples) of chain [a, b) for a row with noise σ: at least options.chord, and long enough
// that the statistic's sd 2σ/(w δt) is at most kink_precision × the row's slope scale (its range over
// the chain's duration); at most a tenth of the chain.
long ChordLength(const std::vector<double>& t, const double* y, long a, long b, double sigma,
                 const ReconstructOptions& options) {
  const long cap = std::max<long>(options.chord, (b - a) / 10);
  const double duration = t[static_cast<std::size_t>(b - 1)] - t[static_cast<std::size_t>(a)];
  const auto [lo, hi] = std::minmax_element(y + a, y + b);
  const double scale = (*hi - *lo) / duration, dt = duration / static_cast<double>(b - a - 1);
  if (!(scale > 0.0) || !(sigma > 0.0) || b - a < 2) return options.chord;
  const double w = std::ceil(2.0 * sigma / (options.kink_precision * scale * dt));
  return std::clamp(static_cast<long>(std::min(w, 1e9)), static_cast<long>(options.chord), cap);
}

// The residual sum of squares of the continuous kink at time tj fitted to samples [from, to) of a
// row: y ≈ c0 + c1 τ + c2 τ² + c3 max(τ, 0), τ = t − tj.
double KinkFit(const std::vector<double>& t, const double* y, long from, long to, double tj) {
  const double h = std::max(tj - t[static_cast<std::size_t>(from)], t[static_cast<std::size_t>(to - 1)] - tj);
  Eigen::Matrix4d a = Eigen::Matrix4d::Zero();
  Eigen::Vector4d b = Eigen::Vector4d::Zero();
  double yy = 0.0;
  for (long i = from; i < to; ++i) {
    const double u = (t[static_cast<std::size_t>(i)] - tj) / h;
    const Eigen::Vector4d basis(1.0, u, u * u, std::max(u, 0.0));
    a += basis * basis.transpose();
    b += basis * y[i];
    yy += y[i] * y[i];
  }
  const Eigen::Vector4d c = a.ldlt().solve(b);
  return yy - c.dot(b);  // RSS at the least-squares solution
}

// The kink's fit over the rows at time tj.
double KinkRss(const std::vector<double>& t, const Mat& rows, long from, long to, double tj) {
  double rss = 0.0;
  for (Eigen::Index r = 0; r < rows.cols(); ++r) rss += KinkFit(t, rows.col(r).data(), from, to, tj);
  return rss;
}

// The jump sample near k (the interval (t_{j−1}, t_j] holding the kink): the kink time that fits the
// rows best over the samples within ±2w of k (one window for every candidate; the chords locate a
// kink only to within a few samples when w is long), first among the sample times within ±w of k
// (every max(1, w/8)-th), then between the best one's neighbours there (golden section).
long LocateKink(const std::vector<double>& t, const Mat& rows, long a, long b, long k, long w) {
  const long from = std::max(a, k - 2 * w), to = std::min(b, k + 2 * w + 1);
  const long lo = std::max(from + 2, k - w), hi = std::min(to - 3, k + w);
  if (to - from < 6 || lo > hi) return k;
  const long stride = std::max(1L, w / 8);
  long s = lo;
  double best = std::numeric_limits<double>::infinity();
  for (long j = lo; j <= hi; j += stride) {
    const double rss = KinkRss(t, rows, from, to, t[static_cast<std::size_t>(j)]);
    if (rss < best) {
      best = rss;
      s = j;
    }
  }
  double left = t[static_cast<std::size_t>(std::max(lo, s - stride))];
  double right = t[static_cast<std::size_t>(std::min(hi, s + stride))];
  const double ratio = 0.5 * (std::sqrt(5.0) - 1.0);
  for (int it = 0; it < 40 && right - left > 1e-6 * (t[static_cast<std::size_t>(s + 1)] - t[static_cast<std::size_t>(s)]); ++it) {
    const double m1 = right - ratio * (right - left), m2 = left + ratio * (right - left);
    if (KinkRss(t, rows, from, to, m1) <= KinkRss(t, rows, from, to, m2)) {
      right = m2;
    } else {
      left = m1;
    }
  }
  const double tau = 0.5 * (left + right);
  return std::lower_bound(t.begin() + lo, t.begin() + hi + 1, tau) - t.begin();
}

// [begin, end) of each chain of K samples cut at chain_start.
std::vector<std::pair<long, long>> Chains(long size, const std::vector<std::uint8_t>& chain_start) {
  std::vector<std::pair<long, long>> chains;
  long begin = 0;
  for (long k = 1; k <= size; ++k) {
    if (k == size || (!chain_start.empty() && chain_start[static_cast<std::size_t>(k)] != 0)) {
      chains.emplace_back(begin, k);
      begin = k;
    }
  }
  return chains;
}

bool StopRaised(const ReconstructOptions& options) {
  return options.stop != nullptr && options.stop->load(std::memory_order_relaxed);
}
constexpr long kStopPoll = 4096;  // samples between two looks at ReconstructOptions::stop

// The chords a chain's kinks are looked for with, shortest first: the longest (ChordLength) and
// each half of the one before, down to the shortest.
std::vector<long> ChordLadder(long longest, long shortest) {
  std::vector<long> ladder{longest};
  while (ladder.back() > shortest) ladder.push_back(std::max(shortest, ladder.back() / 2));
  std::reverse(ladder.begin(), ladder.end());
  return ladder;
}

// The kinks of one chain [a, b) seen with chord w: the statistic and the samples where it exceeds
// the threshold and is the largest within ±w (the chords of the neighbouring intervals share the kink).
struct ChainKinks {
  std::vector<double> statistic;  // per sample of the chain
  std::vector<long> peaks;        // increasing
  bool stopped = false;
};

ChainKinks ChainKinksAt(const std::vector<double>& t, const Mat& rows, long a, long b, long w,
                        const Vec& sigma, const std::vector<long>& known, const ReconstructOptions& options) {
  ChainKinks c;
  c.statistic.assign(static_cast<std::size_t>(b - a), 0.0);
  for (Eigen::Index r = 0; r < rows.cols(); ++r) {
    if ((c.stopped = StopRaised(options))) return c;
    ChainKinkStatistic(t, rows.col(r).data(), a, b, sigma[r], w, known, options, c.statistic);
  }
  // The first statistic is at a + w + 1, the last at b − w − 1; a peak within w/2 of either is not
  // taken: its rise (or fall) is out of sight, and the running median's clipped windows there lag
  // the flow's curvature.
  for (long k = a + w + 1 + w / 2; k < b - w - 1 - w / 2; ++k) {
    if ((k - a) % kStopPoll == 0 && (c.stopped = StopRaised(options))) return c;
    const double z = c.statistic[static_cast<std::size_t>(k - a)];
    if (!(z > options.kink_threshold)) continue;
    bool largest = true;
    for (long l = std::max(a, k - w); l <= std::min(b - 1, k + w) && largest; ++l) {
      const double other = c.statistic[static_cast<std::size_t>(l - a)];
      largest = l < k ? z >= other : (l == k || z > other);
    }
    if (largest) c.peaks.push_back(k);
  }
  return c;
}

// The distance (samples) from at[i] to its nearest neighbour in at (the chain's length when alone).
long NearestKink(const std::vector<long>& at, std::size_t i, long length) {
  long nearest = length;
  if (i > 0) nearest = std::min(nearest, at[i] - at[i - 1]);
  if (i + 1 < at.size()) nearest = std::min(nearest, at[i + 1] - at[i]);
  return nearest;
}

}  // namespace

KinkDetection DetectKinks(const std::vector<double>& t, const Mat& y, const std::vector<std::uint8_t>& chain_start,
                          const Vec& sigma, const ReconstructOptions& options) {
  const long size = y.cols();
  KinkDetection d;
  d.sigma = sigma.size() ? sigma : EstimateNoiseSigma(y);
  d.statistic.assign(static_cast<std::size_t>(size), 0.0);
  d.gamma.assign(static_cast<std::size_t>(size), 0);
  const Mat rows = y.transpose();  // each measured component contiguous
  for (const auto& [a, b] : Chains(size, chain_start)) {
    long longest = options.chord;
    for (Eigen::Index r = 0; r < y.rows(); ++r) {
      longest = std::max(longest, ChordLength(t, rows.col(r).data(), a, b, d.sigma[r], options));
    }
    // Every chord of the ladder, shortest first: a kink seen with a chord w is new unless one seen
    // already lies within ±w (the same kink, seen again by the longer chord).
    const std::vector<long> ladder = ChordLadder(longest, options.chord);
    std::vector<long> at;
    for (const long w : ladder) {
      const ChainKinks kinks = ChainKinksAt(t, rows, a, b, w, d.sigma, at, options);
      if ((d.stopped = kinks.stopped)) return d;
      for (std::size_t i = 0; i < kinks.statistic.size(); ++i) {
        double& z = d.statistic[static_cast<std::size_t>(a) + i];
        z = std::max(z, kinks.statistic[i]);
      }
      const auto seen = static_cast<long>(at.size());  // at[0, seen) is sorted
      for (const long k : kinks.peaks) {
        const auto near = std::lower_bound(at.begin(), at.begin() + seen, k - w);
        if (near == at.begin() + seen || *near > k + w) at.push_back(k);
      }
      std::sort(at.begin(), at.end());
    }
    // Each located with the longest chord whose fit window (±2w) holds no other kink.
    for (std::size_t i = 0; i < at.size(); ++i) {
      const long room = NearestKink(at, i, b - a);
      long w = ladder.front();
      for (const long c : ladder) {
        if (2 * c < room) w = c;
      }
      d.chord = std::max(d.chord, w);
      d.gamma[static_cast<std::size_t>(LocateKink(t, rows, a, b, at[i], w))] = 1;
    }
    if (at.empty()) d.chord = std::max(d.chord, longest);
  }
  return d;
}

namespace {

// The window of a segment's slope (reconstruct.hpp): samples y[begin, end) of a component with σ.
int SegmentWindow(const std::vector<double>& t, const double* y, long begin, long end, double sigma,
                  const ReconstructOptions& options) {
  const long length = end - begin;
  const auto cap_long = std::max<long>(options.min_window, static_cast<long>(options.max_window_share * length));
  const long cap = std::min(length, cap_long % 2 == 0 ? cap_long - 1 : cap_long);
  if (length < 3) return static_cast<int>(length);
  const double duration = t[static_cast<std::size_t>(end - 1)] - t[static_cast<std::size_t>(begin)];
  const auto [lo, hi] = std::minmax_element(y + begin, y + end);
  const double target = options.slope_precision * (*hi - *lo) / duration, dt = duration / double(length - 1);
  if (!(target > 0.0)) return static_cast<int>(cap);
  long m = static_cast<long>(std::ceil(std::cbrt(12.0 * sigma * sigma / (dt * dt * target * target))));
  m = std::max<long>(m, options.min_window);
  if (m % 2 == 0) ++m;
  return static_cast<int>(std::min(m, cap));
}

}  // namespace

Reconstruction ReconstructStates(const ReconstructionPlan& plan, const std::vector<double>& t, const Mat& y,
                                 const std::vector<std::uint8_t>& chain_start, const Vec& sigma,
                                 const ReconstructOptions& options) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument(error);
  if (!plan.ok()) throw std::invalid_argument(plan.error);
  const auto m = static_cast<Eigen::Index>(plan.measured.size());
  const long size = y.cols();
  if (y.rows() != m || static_cast<long>(t.size()) != size ||
      (!chain_start.empty() && static_cast<long>(chain_start.size()) != size) ||
      (sigma.size() != 0 && sigma.size() != m)) {
    throw std::invalid_argument(fmt::format(
        "ReconstructStates: y is {} × {} for {} measured states, {} times, {} chain starts, {} sigmas", y.rows(),
        size, m, t.size(), chain_start.size(), sigma.size()));
  }
  Reconstruction r;
  KinkDetection kinks = DetectKinks(t, y, chain_start, sigma, options);
  if ((r.stopped = kinks.stopped)) return r;
  r.gamma = std::move(kinks.gamma);
  r.statistic = std::move(kinks.statistic);
  r.sigma = kinks.sigma;
  r.chord = kinks.chord;
  const int n = static_cast<int>(plan.source.size());
  r.x = Mat::Zero(n, size);
  for (Eigen::Index a = 0; a < m; ++a) r.x.row(plan.measured[static_cast<std::size_t>(a)]) = y.row(a);
  const Mat rows = y.transpose();
  std::vector<double> slope(static_cast<std::size_t>(size));
  r.min_window = 0;
  for (const auto& [a, b] : Chains(size, chain_start)) {
    long begin = a;
    for (long k = a + 1; k <= b; ++k) {
      if ((k - a) % kStopPoll == 0 && (r.stopped = StopRaised(options))) return r;
      if (k < b && r.gamma[static_cast<std::size_t>(k)] == 0) continue;
      ++r.segments;
      for (const int i : plan.reconstructed) {
        const int j = plan.source[static_cast<std::size_t>(i)];
        const auto row = std::find(plan.measured.begin(), plan.measured.end(), j) - plan.measured.begin();
        const double* yj = rows.col(row).data();
        const int w = SegmentWindow(t, yj, begin, k, r.sigma[row], options);
        SavitzkyGolaySlope(t, yj, begin, k, w, slope.data());
        for (long s = begin; s < k; ++s) r.x(i, s) = (slope[static_cast<std::size_t>(s)] - plan.offset[i]) / plan.scale[i];
        if (k - begin >= 3) {
          r.min_window = r.min_window == 0 ? w : std::min(r.min_window, w);
          r.max_window = std::max(r.max_window, w);
        }
      }
      begin = k;
    }
  }
  return r;
}

}  // namespace hysid
