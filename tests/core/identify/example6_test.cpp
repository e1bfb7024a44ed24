// The paper's Example 6 against closed forms: the solution solves ξ' = sin ξ, D ≤ τ (Proposition 5),
// τ in the linear regime ξ ≈ ξ0 eᵗ, and τ̂ with r = 1 against τ by the trapezoid error bound.
#include <catch2/catch.hpp>

#include <cmath>
#include <stdexcept>

#include "core/identify/example6.hpp"

namespace {

using hysid::Example6At;
using hysid::Example6Options;
using hysid::Example6State;

TEST_CASE("example 6: the closed form solves xi' = sin(xi) from xi0", "[example6]") {
  const Example6Options o;
  CHECK(Example6State(0.0, o) == Approx(o.xi0).epsilon(1e-14));
  for (double t : {0.5, 2.0, 5.0, 8.0}) {
    const double h = 1e-5;
    const double derivative = (Example6State(t + h, o) - Example6State(t - h, o)) / (2 * h);
    CHECK(derivative == Approx(std::sin(Example6State(t, o))).epsilon(1e-8));
  }
}

TEST_CASE("example 6: the Euler derivative stays below the smoothness bound (Proposition 5)", "[example6]") {
  for (double dt : {0.05, 0.5, 2.0}) {
    const Example6Options o{.xi0 = 1e-2, .dt = dt};
    for (double t = dt; t <= 12.0; t += 0.01) {
      const auto p = Example6At(t, o);
      REQUIRE(p.euler <= p.tau * (1 + 1e-12));
      REQUIRE(p.tau > 0);
    }
  }
}

TEST_CASE("example 6: tau in the linear regime is xi0 e^t (1 - e^-dt) / dt", "[example6]") {
  // For ξ ≪ 1, ξ(t) = ξ0 eᵗ (1 + O(ξ²)); at ξ0 = 1e-6 and t ≤ 2 the relative error is below 1e-10.
  const Example6Options o{.xi0 = 1e-6, .dt = 0.5};
  for (double t : {0.5, 1.0, 2.0}) {
    const double expected = o.xi0 * std::exp(t) * (1 - std::exp(-o.dt)) / o.dt;
    CHECK(Example6At(t, o).tau == Approx(expected).epsilon(1e-10));
  }
}

TEST_CASE("example 6: tau_hat with r = 1 is the trapezoid rule for tau", "[example6]") {
  // |trapezoid − integral| ≤ δt³/12 · max|ξ''| over the interval, with |ξ''| = |sin ξ cos ξ| ≤ 1/2;
  // divided by δt for τ.
  const Example6Options o;
  for (double t = o.dt; t <= 12.0; t += 0.25) {
    const auto p = Example6At(t, o);
    CHECK(std::abs(hysid::Example6TauHat(p, 1.0) - p.tau) <= o.dt * o.dt / 24 + 1e-15);
    CHECK(hysid::Example6TauHat(p, 3.0) == Approx(3 * hysid::Example6TauHat(p, 1.0)));
  }
}

TEST_CASE("example 6: bad options are refused by name", "[example6]") {
  CHECK_THROWS_WITH(Example6At(1.0, Example6Options{.xi0 = 4.0}), Catch::Contains("xi0 = 4"));
  CHECK_THROWS_WITH(Example6At(1.0, Example6Options{.dt = -1}), Catch::Contains("dt = -1"));
  CHECK_THROWS_AS(Example6At(0.1, Example6Options{}), std::invalid_argument);
}

}  // namespace
