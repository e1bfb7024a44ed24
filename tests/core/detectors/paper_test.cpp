// The paper detector's sup over the vertices of Ĉ (VertexJacobianSup): exact against evaluating every
// vertex, while evaluating far fewer.
#include <catch2/catch.hpp>

#include <cmath>
#include <random>

#include "core/builtin/impact_pendulum.hpp"
#include "core/detectors/paper.hpp"

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

}  // namespace
}  // namespace hysid
