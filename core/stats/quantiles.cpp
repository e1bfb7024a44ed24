#include "core/stats/quantiles.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

#include <fmt/format.h>

namespace hysid {
namespace {

// Continued fraction of I_x(a, b) (modified Lentz), valid for x < (a + 1)/(a + b + 2).
double BetaContinuedFraction(double x, double a, double b) {
  constexpr double kTiny = 1e-300;
  constexpr double kEps = 1e-16;
  double c = 1.0;
  double d = 1.0 - (a + b) * x / (a + 1.0);
  if (std::abs(d) < kTiny) d = kTiny;
  d = 1.0 / d;
  double f = d;
  for (int m = 1; m <= 10000; ++m) {
    const double md = m;
    // Even step.
    double num = md * (b - md) * x / ((a + 2.0 * md - 1.0) * (a + 2.0 * md));
    d = 1.0 + num * d;
    if (std::abs(d) < kTiny) d = kTiny;
    c = 1.0 + num / c;
    if (std::abs(c) < kTiny) c = kTiny;
    d = 1.0 / d;
    f *= d * c;
    // Odd step.
    num = -(a + md) * (a + b + md) * x / ((a + 2.0 * md) * (a + 2.0 * md + 1.0));
    d = 1.0 + num * d;
    if (std::abs(d) < kTiny) d = kTiny;
    c = 1.0 + num / c;
    if (std::abs(c) < kTiny) c = kTiny;
    d = 1.0 / d;
    const double delta = d * c;
    f *= delta;
    if (std::abs(delta - 1.0) < kEps) break;
  }
  return f;
}

void CheckTail(double p, const char* what) {
  if (!(p > 0.0 && p <= 0.5)) {
    throw std::invalid_argument(fmt::format("{}: tail probability p = {} must be in (0, 0.5]", what, p));
  }
}

}  // namespace

double RegularizedIncompleteBeta(double x, double a, double b) {
  if (!(a > 0.0) || !(b > 0.0) || !(x >= 0.0 && x <= 1.0)) {
    throw std::invalid_argument(fmt::format(
        "RegularizedIncompleteBeta: x = {}, a = {}, b = {}: need x in [0, 1], a, b > 0", x, a, b));
  }
  if (x == 0.0 || x == 1.0) return x;
  const double log_front =
      std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) + b * std::log1p(-x);
  const double front = std::exp(log_front);
  if (x < (a + 1.0) / (a + b + 2.0)) return front * BetaContinuedFraction(x, a, b) / a;
  return 1.0 - front * BetaContinuedFraction(1.0 - x, b, a) / b;
}

double NormalUpperQuantile(double p) {
  CheckTail(p, "NormalUpperQuantile");
  // P(Z > z) = erfc(z/√2)/2 is decreasing in z: bisection to the last bits.
  double lo = 0.0, hi = 40.0;
  for (int i = 0; i < 200 && hi - lo > 1e-15 * hi; ++i) {
    const double mid = 0.5 * (lo + hi);
    (0.5 * std::erfc(mid / std::sqrt(2.0)) > p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

double StudentUpperQuantile(double p, double nu) {
  CheckTail(p, "StudentUpperQuantile");
  if (!(nu >= 1.0) || !std::isfinite(nu)) {
    throw std::invalid_argument(fmt::format("StudentUpperQuantile: nu = {}: must be >= 1 and finite", nu));
  }
  // P(T > t) = I_{ν/(ν+t²)}(ν/2, 1/2)/2, decreasing in t, with density
  // f(t) = (1 + t²/ν)^{−(ν+1)/2} / (√ν B(ν/2, 1/2)). Safeguarded Newton on the tail: a Newton step
  // that leaves the bracket [lo, hi] is replaced by bisection; stops at 1e-14 relative.
  auto tail = [&](double t) { return 0.5 * RegularizedIncompleteBeta(nu / (nu + t * t), 0.5 * nu, 0.5); };
  const double log_norm =
      -0.5 * std::log(nu) - (std::lgamma(0.5 * nu) + std::lgamma(0.5) - std::lgamma(0.5 * nu + 0.5));
  auto density = [&](double t) { return std::exp(log_norm - 0.5 * (nu + 1.0) * std::log1p(t * t / nu)); };
  double lo = 0.0, hi = 1.0;
  while (tail(hi) > p) {
    lo = hi;
    hi *= 2.0;
    if (hi > 1e300) return std::numeric_limits<double>::infinity();
  }
  double t = 0.5 * (lo + hi);
  for (int i = 0; i < 300; ++i) {
    const double excess = tail(t) - p;  // > 0: t below the quantile
    (excess > 0.0 ? lo : hi) = t;
    double next = t + excess / density(t);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    const bool done = std::abs(next - t) <= 1e-14 * next || hi - lo <= 1e-14 * hi;
    t = next;
    if (done) break;
  }
  return t;
}

}  // namespace hysid
