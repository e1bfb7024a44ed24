#include "sim/refine/mode_start.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Dense>

#include "core/model/automaton.hpp"

namespace hysid {
namespace {

// Ratio of a window's cost to the median one beyond which it stays out of α's solve.
constexpr double kWindowTrim = 25.0;
constexpr int kMaxRounds = 30;

// One window: Δx (weighted) and G_q (weighted, n × |α|) per mode.
struct Window {
  Vec delta;
  std::vector<Mat> g;
};

// Per row, the noise sd from the second differences' median absolute value (√6 σ for white noise,
// which a smooth flow barely changes); 1 where it is 0.
Vec RowScales(const std::vector<RefineChain>& chains, int n) {
  Vec scale = Vec::Ones(n);
  for (int r = 0; r < n; ++r) {
    std::vector<double> d;
    for (const RefineChain& ch : chains) {
      for (Eigen::Index k = 1; k + 1 < ch.y.cols(); ++k) {
        const double v = ch.y(r, k + 1) - 2.0 * ch.y(r, k) + ch.y(r, k - 1);
        if (std::isfinite(v)) d.push_back(std::abs(v));
      }
    }
    if (d.empty()) continue;
    std::nth_element(d.begin(), d.begin() + static_cast<long>(d.size() / 2), d.end());
    const double sd = 1.4826 * d[d.size() / 2] / std::sqrt(6.0);
    if (sd > 0.0 && std::isfinite(sd)) scale[r] = sd;
  }
  return scale;
}

std::vector<Window> Windows(const Model& model, const std::vector<RefineChain>& chains, const Vec& gamma,
                            const Vec& alpha, const Vec& weight, long steps) {
  const int n = model.state_size(), modes = ModeCount(model.spec());
  const auto p = static_cast<Eigen::Index>(model.alpha_size());
  std::vector<Window> out;
  Mat phi0(n, p), phi1(n, p);
  for (const RefineChain& ch : chains) {
    const auto K = static_cast<long>(ch.t.size());
    for (long a = 0; a + steps < K; a += steps) {
      bool finite = true;
      for (long k = a; k <= a + steps && finite; ++k) finite = ch.y.col(k).allFinite();
      if (!finite) continue;
      Window w{.delta = weight.cwiseProduct(ch.y.col(a + steps) - ch.y.col(a)), .g = {}};
      for (int q = 0; q < modes; ++q) {
        Mat g = Mat::Zero(n, p);
        for (long k = a + 1; k <= a + steps; ++k) {
          Context c0{.t = ch.t[std::size_t(k - 1)], .u = ch.u.cols() ? ch.u.col(k - 1).data() : nullptr,
                     .gamma = gamma.data(), .alpha = alpha.data(), .beta = nullptr, .mode = q, .map = 0};
          Context c1 = c0;
          c1.t = ch.t[std::size_t(k)];
          c1.u = ch.u.cols() ? ch.u.col(k).data() : nullptr;
          model.Phi(ch.y.col(k - 1), phi0, c0);
          model.Phi(ch.y.col(k), phi1, c1);
          g += 0.5 * (ch.t[std::size_t(k)] - ch.t[std::size_t(k - 1)]) * (phi0 + phi1);
        }
        w.g.push_back(weight.asDiagonal() * g);
      }
      if (w.delta.allFinite() &&
          std::all_of(w.g.begin(), w.g.end(), [](const Mat& g) { return g.allFinite(); })) {
        out.push_back(std::move(w));
      }
    }
  }
  return out;
}

double Cost(const Window& w, int q, const Vec& alpha) { return (w.delta - w.g[std::size_t(q)] * alpha).squaredNorm(); }

// Each window's mode of least cost at α (centred: each mode's cost less its mean over the windows).
std::vector<int> Assign(const std::vector<Window>& windows, int modes, const Vec& alpha, bool centred) {
  std::vector<double> mean(std::size_t(modes), 0.0);
  if (centred) {
    for (const Window& w : windows) {
      for (int q = 0; q < modes; ++q) mean[std::size_t(q)] += Cost(w, q, alpha) / double(windows.size());
    }
  }
  std::vector<int> mode(windows.size(), 0);
  for (std::size_t i = 0; i < windows.size(); ++i) {
    double least = std::numeric_limits<double>::infinity();
    for (int q = 0; q < modes; ++q) {
      const double c = Cost(windows[i], q, alpha) - mean[std::size_t(q)];
      if (c < least) least = c, mode[i] = q;
    }
  }
  return mode;
}

// Σ of each window's cost in its mode, and which windows are within kWindowTrim of the median one.
double Total(const std::vector<Window>& windows, const std::vector<int>& mode, const Vec& alpha,
             std::vector<bool>* kept) {
  std::vector<double> cost(windows.size());
  for (std::size_t i = 0; i < windows.size(); ++i) cost[i] = Cost(windows[i], mode[i], alpha);
  std::vector<double> sorted = cost;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2), sorted.end());
  const double limit = kWindowTrim * std::max(sorted[sorted.size() / 2], std::numeric_limits<double>::min());
  double total = 0.0;
  kept->assign(windows.size(), false);
  for (std::size_t i = 0; i < windows.size(); ++i) {
    (*kept)[i] = cost[i] <= limit;
    total += std::min(cost[i], limit);
  }
  return total;
}

// The unknown α entries by least squares over the kept windows in their modes, known ones fixed,
// each clamped to its bounds.
Vec SolveAlpha(const Model& model, const std::vector<Window>& windows, const std::vector<int>& mode,
               const std::vector<bool>& kept, const Vec& start, const Unknowns& unknowns) {
  const auto u = static_cast<Eigen::Index>(unknowns.alpha.size());
  const Eigen::Index n = windows.front().delta.size();
  const auto rows = n * static_cast<Eigen::Index>(std::count(kept.begin(), kept.end(), true));
  Mat a(rows, u);
  Vec b(rows);
  Eigen::Index at = 0;
  for (std::size_t i = 0; i < windows.size(); ++i) {
    if (!kept[i]) continue;
    const Mat& g = windows[i].g[std::size_t(mode[i])];
    b.segment(at, n) = windows[i].delta - g * start;  // the unknown entries' columns add back below
    for (Eigen::Index j = 0; j < u; ++j) {
      const int c = unknowns.alpha[std::size_t(j)];
      a.block(at, j, n, 1) = g.col(c);
      b.segment(at, n) += g.col(c) * start[c];
    }
    at += n;
  }
  Vec alpha = start;
  if (a.rows() < u) return alpha;
  const Eigen::CompleteOrthogonalDecomposition<Mat> qr(a);
  const Vec x = qr.solve(b);
  if (!x.allFinite()) return alpha;
  for (Eigen::Index j = 0; j < u; ++j) {
    const Parameter& param = model.spec().alpha[std::size_t(unknowns.alpha[std::size_t(j)])];
    alpha[unknowns.alpha[std::size_t(j)]] = std::clamp(x[j], param.lower, param.upper);
  }
  return alpha;
}

struct Clustered {
  Vec alpha;
  double cost = std::numeric_limits<double>::infinity();
};

Clustered Iterate(const Model& model, const std::vector<Window>& windows, std::vector<int> mode, const Vec& start,
                  const Unknowns& unknowns) {
  const int modes = ModeCount(model.spec());
  std::vector<bool> kept;
  Clustered out{.alpha = start, .cost = Total(windows, mode, start, &kept)};
  for (int round = 0; round < kMaxRounds; ++round) {
    out.alpha = SolveAlpha(model, windows, mode, kept, start, unknowns);
    std::vector<int> next = Assign(windows, modes, out.alpha, false);
    out.cost = Total(windows, next, out.alpha, &kept);
    if (next == mode) break;
    mode = std::move(next);
  }
  return out;
}

}  // namespace

std::optional<Vec> ModeClusteredAlpha(const Model& model, const std::vector<RefineChain>& chains,
                                      const std::vector<int>& rows, const HybridParameters& start,
                                      const Unknowns& unknowns, long window) {
  const int n = model.state_size(), modes = ModeCount(model.spec());
  if (modes < 2 || static_cast<int>(rows.size()) != n || unknowns.alpha.empty() || window < 1) return std::nullopt;
  const Vec gamma = start.GammaOr(model);
  const Vec weight = RowScales(chains, n).cwiseInverse();
  const std::vector<Window> windows = Windows(model, chains, gamma, start.alpha, weight, window);
  if (static_cast<long>(windows.size()) * n < 2L * static_cast<long>(unknowns.alpha.size())) return std::nullopt;
  Clustered best;
  for (const bool centred : {false, true}) {
    Clustered c = Iterate(model, windows, Assign(windows, modes, start.alpha, centred), start.alpha, unknowns);
    if (c.cost < best.cost) best = std::move(c);
  }
  if (!best.alpha.allFinite()) return std::nullopt;
  return best.alpha;
}

}  // namespace hysid
