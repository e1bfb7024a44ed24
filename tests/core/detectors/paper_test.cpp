// The paper detector's sup over the vertices of Ĉ (VertexJacobianSup): exact against evaluating every
// vertex, while evaluating far fewer.
#include <catch2/catch.hpp>

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>

#include "core/builtin/impact_msd.hpp"
#include "core/builtin/impact_pendulum.hpp"
#include "core/detectors/paper.hpp"
#include "sim/measurement.hpp"
#include "sim/simulator.hpp"

namespace hysid {
namespace {

TEST_CASE("vertex sup of the Jacobian norm equals the brute-force max over every vertex", "[paper]") {
  const Model model{ImpactPendulum{}};  // J̄_r(ξ, α) = [−a cos ξ1, −b]: depends on ξ
  for (BoundMode mode : {BoundMode::kPaper, BoundMode::kHomogeneous}) {
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> angle(0.0, 3.0), step(-1.0, 1.0);
    VertexJacobianSup sup(model, mode);
    Mat points(2, 40);
    for (Eigen::Index v = 0; v < points.cols(); ++v) points.col(v) << angle(rng), step(rng);
    sup.SetPoints(points);
    Vec alpha = model.alpha();
    long calls = 0;
    for (int k = 0; k < 2000; ++k) {
      // α̂ walks like a converging estimate: large steps first, then small ones.
      const double scale = 1.0 / (1.0 + k);
      alpha[1] += scale * step(rng);
      alpha[2] += 0.1 * scale * step(rng);
      if (k == 700) {  // the hull grows: new vertex set
        points.conservativeResize(2, 60);
        for (Eigen::Index v = 40; v < 60; ++v) points.col(v) << angle(rng), 2.0 * step(rng);
        sup.SetPoints(points);
      }
      const double brute = SupJacobianNorm(model, alpha, mode, points);
      const double cached = sup.Sup(alpha);
      ++calls;
      INFO("mode " << static_cast<int>(mode) << " step " << k);
      REQUIRE(cached == brute);  // exact, not approximately equal
    }
    // The cache must actually save work: far fewer full evaluations than calls, few candidates.
    CHECK(sup.refreshes() < calls / 20);
    CHECK(sup.candidates() < 60);
  }
}

TEST_CASE("vertex sup without points is 0", "[paper]") {
  const Model model{ImpactPendulum{}};
  VertexJacobianSup sup(model, BoundMode::kPaper);
  CHECK(sup.Sup(model.alpha()) == 0.0);
}

TEST_CASE("a flow run's norm of J(alpha) has QuadraticForm's bits, signed zeros and non-finite unknowns too",
          "[paper]") {
  // detail::PaperConstant2::NormSquared takes t0·(q0·t0) + t1·(q1·t1) when GᵀG is zero outside the
  // unknowns' diagonal (the §5 model: GᵀG = diag(0, 1, 1), unknowns 1 and 2), and QuadraticForm<3>
  // otherwise or when that sum is zero or an unknown not finite (a zero sum's sign, a NaN).
  auto same = [](double x, double y) {
    return std::bit_cast<std::uint64_t>(x) == std::bit_cast<std::uint64_t>(y) || (std::isnan(x) && std::isnan(y));
  };
  const double inf = std::numeric_limits<double>::infinity();
  const double values[] = {-0.0, 0.0, 1e-200, -3.0, 0.7, inf, -inf, std::nan("")};
  struct Case {
    const char* what;
    double q[9];
    int u0, u1;
    bool separable;
  };
  const Case cases[] = {
      {"§5: diag(0, 1, 1)", {0, 0, 0, 0, 1, 0, 0, 0, 1}, 1, 2, true},
      {"diag(0, 2.5, 1e-3)", {0, 0, 0, 0, 2.5, 0, 0, 0, 1e-3}, 1, 2, true},
      // Not a Gram matrix, but NormSquared takes any symmetric one: products that underflow to −0.
      {"diag(0, -1, -1)", {0, 0, 0, 0, -1, 0, 0, 0, -1}, 1, 2, true},
      {"unknowns first, -0 off the diagonal", {1, -0.0, 0, -0.0, 1, 0, 0, 0, 0}, 0, 1, true},
      {"cross term", {0, 0, 0, 0, 1, 0.5, 0, 0.5, 1}, 1, 2, false},
      {"known entry enters", {1, 0, 0.5, 0, 1, 0, 0.5, 0, 1}, 1, 2, false},
  };
  const double alpha[3] = {1.0, 0.0, 0.0};
  for (const Case& k : cases) {
    INFO(k.what);
    detail::PaperConstant2<3> c{};
    for (int i = 0; i < 9; ++i) c.q[i] = k.q[i];
    for (int i = 0; i < 3; ++i) c.alpha[i] = alpha[i];
    c.u0 = k.u0;
    c.u1 = k.u1;
    // LoadConstant2's rule, as a PaperDetector would set it.
    c.separable = c.u0 < c.u1;
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) {
        const double v = c.q[j * 3 + i];
        if (v != 0.0 && !(i == j && (i == c.u0 || i == c.u1))) c.separable = false;
      }
    }
    c.q0 = c.q[c.u0 * 3 + c.u0];
    c.q1 = c.q[c.u1 * 3 + c.u1];
    CHECK(c.separable == k.separable);
    for (const double t0 : values) {
      for (const double t1 : values) {
        double full[3] = {alpha[0], alpha[1], alpha[2]};
        full[k.u0] = t0;
        full[k.u1] = t1;
        const double expected = detail::QuadraticForm<3>(3, k.q, full);
        const double got = c.NormSquared(t0, t1);
        INFO("t0 " << t0 << ", t1 " << t1 << ": " << got << " against " << expected);
        CHECK(same(got, expected));
      }
    }
  }
}

}  // namespace
}  // namespace hysid

namespace hysid {
namespace {

TEST_CASE("FlagsWith: another r with this detector's state decides as a detector of that r", "[paper][twins]") {
  const Model model{ImpactMsd{}};
  const Trajectory truth = Simulate(model, DefaultState(model), SampleGrid{20.0, 1e-3});
  REQUIRE(truth.status.completed());
  const Mat y = AddMeasurementNoise(truth.x, Vec::Constant(2, 0.05), NoiseKey{3, 0});
  for (const BoundRule bound : {BoundRule::kPaper, BoundRule::kHomogeneous}) {
    DetectorSettings low, high;
    low.r = 5.0;
    high.r = 20.0;
    low.bound = high.bound = bound;
    PaperDetector a(low, model), b(high, model);
    const Vec alpha = model.alpha();  // α̂ held at the truth: both detectors see the same state
    long flagged = 0, differ = 0;
    for (Eigen::Index k = 1; k < y.cols(); ++k) {
      const Decision da = a.ClassifyConstant<2, true>(y.col(k - 1).data(), y.col(k).data(), 2, truth.dt,
                                                      alpha.data(), 0, 10);
      const Decision db = b.ClassifyConstant<2, true>(y.col(k - 1).data(), y.col(k).data(), 2, truth.dt,
                                                      alpha.data(), 0, 10);
      if (!da.gamma) {
        CHECK(!db.gamma);  // a larger r flags no sample the smaller one does not
        continue;
      }
      ++flagged;
      differ += db.gamma ? 0 : 1;
      CHECK(a.FlagsWith(high.r, y.col(k - 1).data(), y.col(k).data(), 2, truth.dt, 10) == db.gamma);
    }
    CHECK(flagged > 50);
    CHECK(differ > 10);  // both outcomes asked
    CHECK(differ < flagged);
    CHECK(a.FlagsWith(high.r, y.col(0).data(), y.col(1).data(), 2, truth.dt, 0));  // warm-up: τ̂0 for every r
  }
}

}  // namespace
}  // namespace hysid
