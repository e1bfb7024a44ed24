#include "core/identify/events.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <utility>

#include <Eigen/LU>
#include <Eigen/QR>
#include <fmt/format.h>

#include "core/model/automaton.hpp"
#include "core/model/noise_shape.hpp"
#include "core/model/regression.hpp"

namespace hysid {
namespace {

constexpr long kMinFit = 4;  // samples of a degree-2 fit (one more than its coefficients)
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr int kDetectionRounds = 3;  // detection passes with the modes found (several modes and jumps)

// A degree-2 least-squares fit of y(j, lo..hi) in τ = t − t_ref: y ≈ c0 + c1 τ + c2 τ²; v1 is c1's
// variance per unit noise variance, sse the squared residual.
struct Quadratic {
  double c0 = 0.0, c1 = 0.0, c2 = 0.0, v1 = kNaN, sse = kNaN;
};

Quadratic FitQuadratic(const Mat& y, const std::vector<double>& t, long lo, long hi, Eigen::Index j, double t_ref) {
  // τ scaled to [−1, 1] for a well-conditioned 3 × 3 system.
  const double scale = std::max({std::abs(t[std::size_t(lo)] - t_ref), std::abs(t[std::size_t(hi)] - t_ref),
                                 std::numeric_limits<double>::min()});
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (long i = lo; i <= hi; ++i) {
    const double u = (t[std::size_t(i)] - t_ref) / scale;
    const Eigen::Vector3d x(1.0, u, u * u);
    a += x * x.transpose();
    b += x * y(j, i);
  }
  const Eigen::Matrix3d inv = a.inverse();
  const Eigen::Vector3d c = inv * b;
  Quadratic q;
  q.sse = 0.0;
  for (long i = lo; i <= hi; ++i) {
    const double u = (t[std::size_t(i)] - t_ref) / scale;
    const double r = y(j, i) - (c[0] + u * (c[1] + u * c[2]));
    q.sse += r * r;
  }
  q.c0 = c[0];
  q.c1 = c[1] / scale;
  q.c2 = c[2] / (scale * scale);
  q.v1 = inv(1, 1) / (scale * scale);
  return q;
}

// The maximal runs [a, b] of finite samples with no break between consecutive ones.
std::vector<std::pair<long, long>> Segments(const Mat& y, const std::vector<std::uint8_t>& breaks) {
  std::vector<std::pair<long, long>> out;
  long a = -1;
  for (long k = 0; k < y.cols(); ++k) {
    if (!y.col(k).allFinite()) {
      if (a >= 0) out.emplace_back(a, k - 1);
      a = -1;
    } else if (a < 0) {
      a = k;
    } else if (breaks[std::size_t(k)] != 0) {
      out.emplace_back(a, k - 1);
      a = k;
    }
  }
  if (a >= 0) out.emplace_back(a, y.cols() - 1);
  return out;
}

// The slope-change statistic at split c (first sample after) with windows [lo, c−1], [c, hi]; `which`
// receives the component that attains it.
double SlopeChange(const Mat& y, const std::vector<double>& t, const Vec& sigma, long lo, long c, long hi,
                   Eigen::Index* which) {
  const double t_ref = 0.5 * (t[std::size_t(c - 1)] + t[std::size_t(c)]);
  double best = 0.0;
  for (Eigen::Index j = 0; j < y.rows(); ++j) {
    const Quadratic l = FitQuadratic(y, t, lo, c - 1, j, t_ref), r = FitQuadratic(y, t, c, hi, j, t_ref);
    const double z = std::abs(r.c1 - l.c1) / (sigma[j] * std::sqrt(l.v1 + r.v1));
    if (std::isfinite(z) && z > best) {
      best = z;
      if (which != nullptr) *which = j;
    }
  }
  return best;
}

// A peak at c in segment [a, b]: the split within ±2 whose two fits over the window leave the least
// σ-weighted residual, and the instant in (t_{k−1}, t_k] where the fits of component `j` meet.
Kink LocateKink(const Mat& y, const std::vector<double>& t, const Vec& sigma, long a, long b, long c, long window,
                Eigen::Index j) {
  const long lo = std::max(a, c - window), hi = std::min(b, c + window - 1);
  long best = c;
  double best_cost = std::numeric_limits<double>::infinity();
  for (long s = c - 2; s <= c + 2; ++s) {
    if (s - lo < kMinFit || hi - s + 1 < kMinFit) continue;
    const double t_ref = 0.5 * (t[std::size_t(s - 1)] + t[std::size_t(s)]);
    double cost = 0.0;
    for (Eigen::Index i = 0; i < y.rows(); ++i) {
      cost += (FitQuadratic(y, t, lo, s - 1, i, t_ref).sse + FitQuadratic(y, t, s, hi, i, t_ref).sse) /
              (sigma[i] * sigma[i]);
    }
    if (cost < best_cost) {
      best_cost = cost;
      best = s;
    }
  }
  const double t0 = t[std::size_t(best - 1)], t1 = t[std::size_t(best)], t_ref = 0.5 * (t0 + t1);
  const Quadratic l = FitQuadratic(y, t, lo, best - 1, j, t_ref), r = FitQuadratic(y, t, best, hi, j, t_ref);
  // Roots of (l − r)(τ) = d0 + d1 τ + d2 τ² in (t0, t1] − t_ref, the one nearest the middle.
  const double d0 = l.c0 - r.c0, d1 = l.c1 - r.c1, d2 = l.c2 - r.c2;
  double time = kNaN, nearest = std::numeric_limits<double>::infinity();
  auto consider = [&](double tau) {
    if (!std::isfinite(tau) || t_ref + tau <= t0 || t_ref + tau > t1 || !(std::abs(tau) < nearest)) return;
    nearest = std::abs(tau);
    time = t_ref + tau;
  };
  if (std::abs(d2) * (t1 - t0) < 1e-12 * std::abs(d1)) {
    consider(-d0 / d1);
  } else if (const double disc = d1 * d1 - 4.0 * d2 * d0; disc >= 0.0) {
    consider((-d1 + std::sqrt(disc)) / (2.0 * d2));
    consider((-d1 - std::sqrt(disc)) / (2.0 * d2));
  }
  if (!std::isfinite(time)) time = t_ref;
  return Kink{.sample = best, .time = time, .statistic = 0.0};
}

// c1's variance per unit noise variance for a degree-2 fit to m samples δt apart that end half a step
// before the reference instant (one side of a split).
double SideSlopeVariance(long m, double dt) {
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
  for (long i = 0; i < m; ++i) {
    const double u = -(static_cast<double>(m - i) - 0.5) / static_cast<double>(m);  // τ / (m δt)
    const Eigen::Vector3d x(1.0, u, u * u);
    a += x * x.transpose();
  }
  const double scale = static_cast<double>(m) * dt;
  return a.inverse()(1, 1) / (scale * scale);
}

// The window of the slope-change statistic: settings.window, widened (up to a quarter of the longest
// segment, at most 256 samples) until a slope change the size of the data's typical slope — the
// median |chord slope| over settings.window samples, per component — stands at 1.5 × the threshold
// above the noise in some component. A switch changes the flow by a sizeable part of itself; with
// noise, 16 samples cannot see that (a pump tank at 1 % of its level range: about 3 sd).
long KinkWindow(const Mat& y, const std::vector<double>& t, const std::vector<std::pair<long, long>>& segments,
                const Vec& sigma, const KinkSettings& settings) {
  const long w = settings.window;
  long longest = 0;
  std::vector<double> steps;
  std::vector<std::vector<double>> slopes(static_cast<std::size_t>(y.rows()));
  for (const auto& [a, b] : segments) {
    longest = std::max(longest, b - a + 1);
    for (long k = a; k + w <= b; k += w) {
      const double dt = t[std::size_t(k + w)] - t[std::size_t(k)];
      steps.push_back(dt / static_cast<double>(w));
      for (Eigen::Index j = 0; j < y.rows(); ++j) {
        slopes[std::size_t(j)].push_back(std::abs(y(j, k + w) - y(j, k)) / dt);
      }
    }
  }
  if (steps.empty()) return w;
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  const double dt = median(steps);
  Vec scale(y.rows());
  for (Eigen::Index j = 0; j < y.rows(); ++j) scale[j] = median(slopes[std::size_t(j)]);
  const long cap = std::max(w, std::min<long>(256, longest / 4));
  for (long m = w;; m = std::min(cap, m + std::max<long>(1, m / 4))) {
    const double sd = std::sqrt(2.0 * SideSlopeVariance(m, dt));
    for (Eigen::Index j = 0; j < y.rows(); ++j) {
      if (scale[j] >= 1.5 * settings.threshold * sigma[j] * sd) return m;
    }
    if (m == cap) return m;
  }
}

}  // namespace

std::vector<Kink> DetectKinks(const Mat& y, const std::vector<double>& t, const std::vector<std::uint8_t>& breaks,
                              const Vec& sigma_in, const KinkSettings& settings) {
  if (settings.window < kMinFit || !(settings.threshold > 0.0)) {
    throw std::invalid_argument(fmt::format("KinkSettings: window = {} must be >= {} and threshold = {} > 0",
                                            settings.window, kMinFit, settings.threshold));
  }
  Vec sigma = sigma_in;
  for (Eigen::Index j = 0; j < sigma.size(); ++j) {  // noise-free data: a floor at rounding's scale
    const double scale = y.row(j).array().isFinite().any()
                             ? y.row(j).unaryExpr([](double v) { return std::isfinite(v) ? std::abs(v) : 0.0; }).maxCoeff()
                             : 1.0;
    sigma[j] = std::max(sigma[j], 1e-12 * (1.0 + scale));
  }
  const std::vector<std::pair<long, long>> segments = Segments(y, breaks);
  const long m = KinkWindow(y, t, segments, sigma, settings);
  std::vector<Kink> out;
  for (const auto& [a, b] : segments) {
    if (b - a + 1 < 2 * kMinFit) continue;
    const long first = a + kMinFit, last = b - kMinFit + 1;  // splits with enough samples on each side
    // The statistic of each split and the component attaining it.
    std::vector<std::pair<double, Eigen::Index>> split(std::size_t(last - first + 1));
    for (long c = first; c <= last; ++c) {
      auto& [zc, j] = split[std::size_t(c - first)];
      j = 0;
      zc = SlopeChange(y, t, sigma, std::max(a, c - m), c, std::min(b, c + m - 1), &j);
    }
    for (long c = first; c <= last; ++c) {
      const double zc = split[std::size_t(c - first)].first;
      if (!(zc > settings.threshold)) continue;
      bool peak = true;
      for (long d = std::max(first, c - m); peak && d <= std::min(last, c + m); ++d) {
        const double zd = split[std::size_t(d - first)].first;
        peak = d < c ? zd < zc : zd <= zc;
      }
      if (!peak) continue;
      Kink k = LocateKink(y, t, sigma, a, b, c, m, split[std::size_t(c - first)].second);
      k.statistic = zc;
      out.push_back(k);
    }
  }
  return out;
}

namespace {

// The least |h_g|/‖∇ₓh_g‖ over the flow step of length `step` from x (0 when h_g changes sign in it).
double GuardDistance(const Model& model, ConstVecRef x, double step, const Context& ctx, const Vec& alpha, int g) {
  const Eigen::Index n = x.size();
  Vec f(n), h(model.guard_count()), hp(model.guard_count()), hm(model.guard_count());
  model.Flow(x, alpha, f, ctx);
  double best = std::numeric_limits<double>::infinity(), last = kNaN;
  constexpr int kPoints = 4;
  for (int s = 0; s <= kPoints; ++s) {
    Vec xs = x + (static_cast<double>(s) / kPoints) * step * f;
    model.Guards(xs, h, ctx);
    if (s > 0 && last * h[g] <= 0.0) return 0.0;
    last = h[g];
    double grad2 = 0.0;
    for (Eigen::Index i = 0; i < n; ++i) {
      const double e = 1e-6 * (1.0 + std::abs(xs[i])), keep = xs[i];
      xs[i] = keep + e;
      model.Guards(xs, hp, ctx);
      xs[i] = keep - e;
      model.Guards(xs, hm, ctx);
      xs[i] = keep;
      grad2 += std::pow((hp[g] - hm[g]) / (2.0 * e), 2);
    }
    const double d = grad2 > 0.0 ? std::abs(h[g]) / std::sqrt(grad2) : std::abs(h[g]);
    if (std::isfinite(d)) best = std::min(best, d);
  }
  return std::isfinite(best) ? best : kNaN;
}

struct Pending {
  long sample;
  bool jump;
  double time, statistic;
};

// The map of event `e` from mode q: the armed maps of its kind, else (armed = false) all of its kind.
void Assign(const Model& model, const std::vector<JumpMap>& maps, const Mat& y, const std::vector<double>& t,
            const Mat& inputs, const Vec& alpha, AutomatonEvent* e) {
  const ModelSpec& spec = model.spec();
  std::vector<int> candidates;
  for (int g = 0; g < model.guard_count(); ++g) {
    const int m = ArmedMap(spec, e->mode_before, g);
    if (m >= 0 && maps[std::size_t(m)].identity != e->jump) candidates.push_back(m);
  }
  e->armed = !candidates.empty();
  for (int m = 0; !e->armed && m < static_cast<int>(maps.size()); ++m) {
    if (maps[std::size_t(m)].identity != e->jump) candidates.push_back(m);
  }
  long pre = e->sample - 1;
  if (pre < 0 || !y.col(pre).allFinite()) pre = e->sample;
  const Context ctx{.t = t[std::size_t(pre)],
                    .u = inputs.rows() > 0 ? inputs.col(pre).data() : nullptr,
                    .alpha = alpha.data(),
                    .mode = e->mode_before};
  const double step = t[std::size_t(e->sample)] - t[std::size_t(pre)];
  e->map = -1;
  e->guard_distance = kNaN;
  for (int m : candidates) {
    const int g = maps[std::size_t(m)].guard;
    const double d = g >= 0 ? GuardDistance(model, y.col(pre), step, ctx, alpha, g) : kNaN;
    const bool better = e->map < 0 || (std::isfinite(d) && !(d >= e->guard_distance));
    if (better) {
      e->map = m;
      e->guard = g;
      e->guard_distance = d;
    }
  }
}

}  // namespace

std::vector<AutomatonEvent> AssignEvents(const Model& model, const Mat& y, const std::vector<double>& t,
                                         const Mat& inputs, const Vec& alpha, int initial_mode,
                                         const std::vector<std::uint8_t>& jumps, const std::vector<Kink>& kinks,
                                         std::vector<int>* modes, std::vector<int>* maps_out) {
  const std::vector<JumpMap> maps = JumpMaps(model.spec());
  std::vector<Pending> pending;
  for (std::size_t k = 1; k < jumps.size(); ++k) {
    if (jumps[k] != 0) pending.push_back({long(k), true, t[k], 0.0});
  }
  for (const Kink& k : kinks) pending.push_back({k.sample, false, k.time, k.statistic});
  std::stable_sort(pending.begin(), pending.end(),
                   [](const Pending& a, const Pending& b) { return a.sample < b.sample || (a.sample == b.sample && a.jump && !b.jump); });
  const auto count = static_cast<std::size_t>(y.cols());
  modes->assign(count, initial_mode);
  maps_out->assign(count, 0);
  std::vector<AutomatonEvent> events;
  int q = initial_mode;
  for (const Pending& p : pending) {
    AutomatonEvent e{.sample = p.sample, .time = p.time, .jump = p.jump, .mode_before = q, .statistic = p.statistic};
    Assign(model, maps, y, t, inputs, alpha, &e);
    q = e.map >= 0 ? ModeAfter(model.spec(), q, e.map) : q;
    e.mode_after = q;
    std::fill(modes->begin() + p.sample, modes->end(), q);
    if (e.jump && e.map >= 0) (*maps_out)[std::size_t(p.sample)] = e.map;
    events.push_back(e);
  }
  return events;
}

double ModeResidual(const Model& model, const Mat& y, const std::vector<double>& t, const Mat& inputs,
                    const std::vector<std::uint8_t>& breaks, const std::vector<int>& modes) {
  RegressionBuilder builder(model);
  const auto rows = static_cast<Eigen::Index>(builder.flow_layout().rows.size());
  const auto u = static_cast<Eigen::Index>(builder.flow_layout().unknown.size());
  Mat a(rows * y.cols(), u), phi(rows, u);
  Vec b(rows * y.cols()), fy(rows);
  Eigen::Index used = 0;
  for (Eigen::Index k = 1; k < y.cols(); ++k) {
    if (breaks[std::size_t(k)] != 0 || !y.col(k).allFinite() || !y.col(k - 1).allFinite()) continue;
    const bool in = inputs.rows() > 0;
    const Context prev{.t = t[std::size_t(k - 1)], .u = in ? inputs.col(k - 1).data() : nullptr, .mode = modes[std::size_t(k - 1)]};
    const Context cur{.t = t[std::size_t(k)], .u = in ? inputs.col(k).data() : nullptr, .mode = modes[std::size_t(k)]};
    builder.Flow(y.col(k - 1), y.col(k), t[std::size_t(k)] - t[std::size_t(k - 1)], phi, fy, prev, cur);
    if (!phi.allFinite() || !fy.allFinite()) continue;
    a.middleRows(used, rows) = phi;
    b.segment(used, rows) = fy;
    used += rows;
  }
  if (used == 0) return kNaN;
  const Mat used_a = a.topRows(used);
  const Vec used_b = b.head(used);
  if (u == 0) return used_b.squaredNorm();
  const Vec theta = used_a.colPivHouseholderQr().solve(used_b);
  return (used_a * theta - used_b).squaredNorm();
}

namespace {

// σ per component for the kink statistic: given, else EstimateNoiseSigma over the finite columns
// (ones when fewer than 4).
Vec KinkSigma(const Mat& y, const IdentifierSettings& settings) {
  if (settings.sigma.size() == y.rows()) return settings.sigma;
  std::vector<Eigen::Index> finite;
  for (Eigen::Index k = 0; k < y.cols(); ++k) {
    if (y.col(k).allFinite()) finite.push_back(k);
  }
  if (finite.size() < 4) return Vec::Ones(y.rows());
  return EstimateNoiseSigma(y(Eigen::all, finite));
}

void CheckAutomatonSettings(const Model& model, const IdentifierSettings& settings, const IdentifyOptions& options) {
  if (settings.localize) {
    throw std::invalid_argument(fmt::format(
        "IdentifierSettings::localize: not available for hybrid automaton '{}' (the localiser fits one flow and one "
        "jump map)",
        model.name()));
  }
  if (options.initial_mode >= ModeCount(model.spec())) {
    throw std::invalid_argument(fmt::format("IdentifyOptions::initial_mode = {}: model '{}' has {} mode(s)",
                                            options.initial_mode, model.name(), ModeCount(model.spec())));
  }
}

// Why the assignment is not to be trusted: events of a kind no map has, or none armed in the mode.
std::string EventsReason(const std::vector<AutomatonEvent>& events) {
  long none = 0, unarmed = 0;
  long first = -1;
  for (const AutomatonEvent& e : events) {
    if (e.map >= 0 && e.armed) continue;
    (e.map < 0 ? none : unarmed) += 1;
    if (first < 0) first = e.sample;
  }
  if (none + unarmed == 0) return "";
  return fmt::format("{} event(s) with no map of their kind and {} with none armed in their mode (first at sample {})",
                     none, unarmed, first);
}

// The switches among `events` whose guard moved against its direction as the switch approached: h at
// the sample before the switch less h at the sample `window` before that (within its flow segment),
// positive for a falling guard or negative for a rising one. Jumps, guards of either direction and
// guards that read a state the model does not measure (its rows of y are a reconstruction, a start
// only: h changes when one of them does) count never.
int AgainstDirection(const Model& model, const Mat& y, const std::vector<double>& t, const Mat& inputs,
                     const Vec& alpha, const std::vector<std::uint8_t>& breaks, const std::vector<AutomatonEvent>& events,
                     int window) {
  const long K = static_cast<long>(y.cols());
  const std::vector<int>& measured = model.spec().measured;
  Vec h(model.guard_count());
  const auto guard_at = [&](const ConstVecRef& x, long k, int g) {
    const Context ctx{.t = t[std::size_t(k)], .u = inputs.rows() > 0 ? inputs.col(k).data() : nullptr,
                      .alpha = alpha.data()};
    model.Guards(x, h, ctx);
    return h[g];
  };
  const auto reads_hidden = [&](long k, int g) {
    const double at = guard_at(y.col(k), k, g);
    for (int i = 0; i < y.rows(); ++i) {
      if (measured.empty() || std::find(measured.begin(), measured.end(), i) != measured.end()) continue;
      Vec moved = y.col(k);
      moved[i] += 1e-6 * std::max(1.0, std::abs(moved[i]));
      if (guard_at(moved, k, g) != at) return true;
    }
    return false;
  };
  int against = 0;
  for (const AutomatonEvent& e : events) {
    if (e.jump || e.map < 0 || e.guard < 0) continue;
    const Crossing c = model.spec().guards[std::size_t(e.guard)].direction;
    if (c == Crossing::kBoth) continue;
    const long b = e.sample - 1;
    long a = b;
    while (a > 0 && b - a < window && breaks[std::size_t(a)] == 0) --a;
    if (a == b || b >= K || !y.col(a).allFinite() || !y.col(b).allFinite() || reads_hidden(b, e.guard)) continue;
    const double change = guard_at(y.col(b), b, e.guard) - guard_at(y.col(a), a, e.guard);
    if ((c == Crossing::kFalling && change > 0.0) || (c == Crossing::kRising && change < 0.0)) ++against;
  }
  return against;
}

// Residual sums of squares within this relative difference are the same: the modes' φ have one form
// (a library of candidate terms in every mode), so either labelling fits alike to rounding.
constexpr double kSameResidual = 1e-6;

// The events of one set of jump labels, assigned from the best initial mode (the rule in events.hpp).
struct Assignment {
  std::vector<AutomatonEvent> events;
  std::vector<int> modes, maps;  // per sample
  std::vector<double> rss;       // per candidate initial mode (NaN: not tried)
  std::vector<int> against;      // per candidate initial mode: switches against their guard's direction
  int initial_mode = 0;
  bool inferred = false;
};

// Whether initial mode q beats `than` (the rule in events.hpp): the smaller flow residual, or when the
// two are the same (kSameResidual), fewer switches against their guards' directions.
bool BetterInitialMode(const Assignment& a, int q, int than) {
  const double rq = a.rss[std::size_t(q)], rt = a.rss[std::size_t(than)];
  if (std::abs(rq - rt) > kSameResidual * std::max(rq, rt)) return rq < rt;
  return a.against[std::size_t(q)] < a.against[std::size_t(than)];
}

// breaks[k] = 1: no flow between samples k − 1 and k (a jump, a chain start; sample 0).
std::vector<std::uint8_t> Breaks(const std::vector<std::uint8_t>& jumps, const IdentifyOptions& options) {
  std::vector<std::uint8_t> breaks = jumps;
  if (!breaks.empty()) breaks[0] = 1;
  for (std::size_t k = 0; k < options.chain_start.size(); ++k) breaks[k] |= options.chain_start[k];
  return breaks;
}

Assignment AssignAll(const Model& model, const Mat& y, const std::vector<double>& t, const IdentifierSettings& settings,
                     const IdentifyOptions& options, const Vec& alpha, const std::vector<std::uint8_t>& jumps) {
  const ModelSpec& spec = model.spec();
  const std::vector<JumpMap> maps = JumpMaps(spec);
  const bool has_switch = std::any_of(maps.begin(), maps.end(), [](const JumpMap& m) { return m.identity; });
  const std::vector<std::uint8_t> breaks = Breaks(jumps, options);
  const std::vector<Kink> kinks =
      has_switch ? DetectKinks(y, t, breaks, KinkSigma(y, settings), options.kinks) : std::vector<Kink>{};
  // Each candidate initial mode (the model's default first, so that it wins a tie).
  std::vector<int> candidates;
  if (options.initial_mode >= 0) {
    candidates.push_back(options.initial_mode);
  } else {
    candidates.push_back(spec.default_mode);
    for (int q = 0; q < ModeCount(spec); ++q) {
      if (q != spec.default_mode) candidates.push_back(q);
    }
  }
  Assignment out;
  out.rss.assign(std::size_t(ModeCount(spec)), kNaN);
  out.against.assign(std::size_t(ModeCount(spec)), 0);
  out.initial_mode = candidates.front();
  out.inferred = candidates.size() > 1;
  for (int q0 : candidates) {
    std::vector<int> modes, per_map;
    std::vector<AutomatonEvent> e = AssignEvents(model, y, t, options.inputs, alpha, q0, jumps, kinks, &modes, &per_map);
    out.rss[std::size_t(q0)] = out.inferred ? ModeResidual(model, y, t, options.inputs, breaks, modes) : kNaN;
    const int against = out.inferred ? AgainstDirection(model, y, t, options.inputs, alpha, breaks, e, options.kinks.window) : 0;
    out.against[std::size_t(q0)] = against;
    if (q0 == candidates.front() || BetterInitialMode(out, q0, out.initial_mode)) {
      out.initial_mode = q0;
      out.events = std::move(e);
      out.modes = std::move(modes);
      out.maps = std::move(per_map);
    }
  }
  return out;
}

// The detection pass (jump detector, no events assigned) with every sample in mode `modes` (empty:
// mode 0) and each jump's map `maps` (empty: map 0).
IdentifyResult DetectionPass(const Model& model, const Mat& y, double dt, const IdentifierSettings& settings,
                             const IdentifyOptions& options, std::vector<int> modes, std::vector<int> maps) {
  IdentifyOptions plain = options;
  plain.assign_events = false;
  plain.modes = std::move(modes);
  plain.maps = std::move(maps);
  return Identify(model, y, dt, settings, plain);
}

// A run of flagged pairs is a pass's recursive α̂ catching up with a flow it did not have (a switch
// into a mode it was not given, or a first segment too short to tell α's columns apart): a jump is
// one pair between flows. Only the isolated flags are kept.
std::vector<std::uint8_t> Isolated(const std::vector<std::uint8_t>& jumps) {
  std::vector<std::uint8_t> out = jumps;
  for (std::size_t k = 0; k < jumps.size(); ++k) {
    const bool before = k > 0 && jumps[k - 1] != 0, after = k + 1 < jumps.size() && jumps[k + 1] != 0;
    if (before || after) out[k] = 0;
  }
  return out;
}

// Jumps before the modes are known: a pair is a jump when the pass of every mode q (all samples in
// q) flags it, so that a mode's flow cannot explain it; a pair flagged only because the pass took
// another mode's flow (a run of detections where the model is in mode q) is not a jump. `first`
// receives the pass of the default mode (its α̂ is the assignment's flow step).
std::vector<std::uint8_t> JumpsOfEveryMode(const Model& model, const Mat& y, double dt,
                                           const IdentifierSettings& settings, const IdentifyOptions& options,
                                           IdentifyResult* first) {
  const ModelSpec& spec = model.spec();
  auto all_in = [&](int q) { return q == 0 ? std::vector<int>{} : std::vector<int>(std::size_t(y.cols()), q); };
  *first = DetectionPass(model, y, dt, settings, options, all_in(spec.default_mode), {});
  std::vector<std::uint8_t> jumps = first->gamma;
  for (int q = 0; q < ModeCount(spec); ++q) {
    if (q == spec.default_mode) continue;
    const IdentifyResult pass = DetectionPass(model, y, dt, settings, options, all_in(q), {});
    for (std::size_t k = 0; k < jumps.size(); ++k) jumps[k] &= pass.gamma[k];
  }
  return ModeCount(spec) == 1 ? jumps : Isolated(jumps);
}

// The final pass's result completed with the assignment: γ = 1 at every event (a switch is an event
// of the hybrid time domain, an identity map, although the pass regressed its pair as flow), the
// events, modes and initial mode (in the safe start too).
void FinishAutomaton(const Model& model, bool has_jump, const Assignment& a, IdentifyResult* r) {
  for (const AutomatonEvent& e : a.events) r->gamma[std::size_t(e.sample)] = 1;
  if (r->safe_start) {
    IdentifyResult safe = *r->safe_start;
    safe.gamma = r->gamma;
    safe.events = a.events;
    safe.mode = a.modes;
    safe.initial_mode = a.initial_mode;
    r->safe_start = std::make_shared<const IdentifyResult>(std::move(safe));
  }
  if (!has_jump && r->jump_status == EstimatorStatus::kNotExcited && model.beta_size() == 0) {
    r->jump_status = EstimatorStatus::kOk;  // only identity maps: no β to estimate
    r->jump_reason.clear();
  }
  r->events = a.events;
  r->mode = a.modes;
  r->initial_mode = a.initial_mode;
  r->initial_mode_inferred = a.inferred;
  r->initial_mode_rss = a.rss;
  r->events_reason = EventsReason(r->events);
}

}  // namespace

IdentifyResult IdentifyAutomaton(const Model& model, const Mat& y, double dt, const IdentifierSettings& settings,
                                 const IdentifyOptions& options) {
  const ModelSpec& spec = model.spec();
  const std::vector<JumpMap> maps = JumpMaps(spec);
  const bool has_jump = std::any_of(maps.begin(), maps.end(), [](const JumpMap& m) { return !m.identity; });
  CheckAutomatonSettings(model, settings, options);
  const auto count = static_cast<std::size_t>(y.cols());
  std::vector<double> t = options.times;
  if (t.empty()) {
    for (std::size_t k = 0; k < count; ++k) t.push_back(static_cast<double>(k) * dt);
  }
  // Jumps: given labels, or detected (every mode's pass, then the pass with the modes found).
  IdentifyResult detection;
  std::vector<std::uint8_t> jumps = options.labels.empty() ? std::vector<std::uint8_t>(count, 0) : options.labels;
  const bool detect = options.labels.empty() && has_jump;
  if (detect) jumps = JumpsOfEveryMode(model, y, dt, settings, options, &detection);
  auto alpha_of = [&](const IdentifyResult& r) {
    return detect && r.alpha_hat.allFinite() ? r.alpha_hat : model.alpha();
  };
  Assignment a = AssignAll(model, y, t, settings, options, alpha_of(detection), jumps);
  // Jumps against the flow of each sample's mode, until they agree with the modes they give.
  for (int round = 0; detect && ModeCount(spec) > 1 && round < kDetectionRounds; ++round) {
    IdentifyResult again = DetectionPass(model, y, dt, settings, options, a.modes, a.maps);
    std::vector<std::uint8_t> found = Isolated(again.gamma);
    // The pair across a switch mixes two modes' flows in its trapezoid: the switch explains it.
    for (const AutomatonEvent& e : a.events) {
      for (long k = e.sample - 1; !e.jump && k <= e.sample + 1; ++k) {
        if (k >= 0 && k < static_cast<long>(found.size())) found[std::size_t(k)] = 0;
      }
    }
    detection = std::move(again);
    if (found == jumps) break;
    jumps = std::move(found);
    a = AssignAll(model, y, t, settings, options, alpha_of(detection), jumps);
  }
  IdentifyOptions pass = options;
  pass.assign_events = false;
  pass.labels = jumps;
  pass.modes = a.modes;
  pass.maps = a.maps;
  IdentifyResult r = Identify(model, y, dt, settings, pass);
  if (detect) {
    if (options.statistics) {
      r.statistic = detection.statistic;
      r.threshold = detection.threshold;
    }
    if (detection.jump_status == EstimatorStatus::kIllConditioned && r.jump_status == EstimatorStatus::kOk) {
      r.jump_status = detection.jump_status;
      r.jump_reason = detection.jump_reason;
    }
  }
  FinishAutomaton(model, has_jump, a, &r);
  return r;
}

}  // namespace hysid
