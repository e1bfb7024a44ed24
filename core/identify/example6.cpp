#include "core/identify/example6.hpp"

#include <array>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include <fmt/format.h>

namespace hysid {
namespace {

// Nodes and weights of the 20-point Gauss–Legendre rule on [−1, 1] (positive half), computed once by
// Newton's method on P_20.
struct GaussLegendre20 {
  std::array<double, 10> x{}, w{};
  GaussLegendre20() {
    constexpr int n = 20;
    for (int i = 0; i < n / 2; ++i) {
      double z = std::cos(std::numbers::pi * (i + 0.75) / (n + 0.5));
      double dp = 0;
      for (int it = 0; it < 100; ++it) {
        double p0 = 1, p1 = z;
        for (int k = 2; k <= n; ++k) {
          const double p2 = ((2 * k - 1) * z * p1 - (k - 1) * p0) / k;
          p0 = p1, p1 = p2;
        }
        dp = n * (z * p1 - p0) / (z * z - 1);
        const double step = p1 / dp;
        z -= step;
        if (std::abs(step) < 1e-16) break;
      }
      x[static_cast<std::size_t>(i)] = z;
      w[static_cast<std::size_t>(i)] = 2 / ((1 - z * z) * dp * dp);
    }
  }
};

void Check(const Example6Options& o) {
  if (!(o.xi0 > 0 && o.xi0 < std::numbers::pi)) {
    throw std::invalid_argument(fmt::format("Example6Options::xi0 = {}: must be in (0, pi)", o.xi0));
  }
  if (!(o.dt > 0) || !std::isfinite(o.dt)) {
    throw std::invalid_argument(fmt::format("Example6Options::dt = {}: must be finite and > 0", o.dt));
  }
}

}  // namespace

double Example6State(double t, const Example6Options& o) {
  const double c = std::log(1 / std::tan(o.xi0 / 2));  // ln cot(ξ0/2)
  return 2 * std::atan(std::exp(t - c));
}

Example6Point Example6At(double t, const Example6Options& o) {
  Check(o);
  if (!(t >= o.dt) || !std::isfinite(t)) {
    throw std::invalid_argument(fmt::format("Example 6: t = {}: must be finite and >= dt = {}", t, o.dt));
  }
  static const GaussLegendre20 rule;
  Example6Point p;
  p.t = t;
  p.xi = Example6State(t, o);
  p.xi_prev = Example6State(t - o.dt, o);
  p.euler = std::abs(p.xi - p.xi_prev) / o.dt;
  const double mid = t - o.dt / 2, half = o.dt / 2;
  double integral = 0;
  for (std::size_t i = 0; i < rule.x.size(); ++i) {
    integral += rule.w[i] * (std::abs(Example6State(mid - half * rule.x[i], o)) +
                             std::abs(Example6State(mid + half * rule.x[i], o)));
  }
  p.tau = half * integral / o.dt;  // k = 1
  return p;
}

}  // namespace hysid
