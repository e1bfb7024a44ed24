// The flow regression (eq. 7, reduced to the identified rows): closed form, and FlowRow / FlowRows
// (the identifier's per-sample and block paths) against Flow pair by pair.
#include <catch2/catch.hpp>

#include <vector>

#include "core/builtin/bouncing_ball.hpp"
#include "core/builtin/impact_msd.hpp"
#include "core/builtin/impact_pendulum.hpp"
#include "core/model/regression.hpp"
#include "sim/measurement.hpp"

namespace hysid {
namespace {

// One identified row with four unknown columns and no known one: a layout without a compile-time
// path in FlowRows (the generic loops). ξ2' = α1ξ1 + α2ξ2 + α3ξ1² + α4.
struct FourUnknowns {
  ModelSpec Spec() const {
    ModelSpec spec;
    spec.name = "four-unknowns";
    spec.state_names = {"x", "v"};
    for (const char* a : {"a1", "a2", "a3", "a4"})
      spec.alpha.push_back(Parameter{.name = a, .value = 1.0, .known = false, .description = ""});
    spec.beta = {Parameter{.name = "b", .value = 1.0, .known = false, .description = ""}};
    spec.flow_rows = {1};
    spec.jump_rows = {1};
    spec.guards = {Guard{.name = "wall"}};
    spec.default_x0 = {1.0, 0.0};
    return spec;
  }
  void Phi(ConstVecRef x, MatRef phi) const {
    phi << 0.0, 0.0, 0.0, 0.0,  //
        x[0], x[1], x[0] * x[0], 1.0;
  }
  void Psi(ConstVecRef x, MatRef psi) const { psi << 0.0, x[1]; }
  void Guards(ConstVecRef x, VecRef h) const { h[0] = x[0]; }
  bool InFlowSet(ConstVecRef x) const { return x[0] >= 0.0; }
  bool InJumpSet(ConstVecRef x) const { return x[0] <= 0.0; }
};

// A wandering sample path (n × K) with noise: no two consecutive samples alike.
Mat Samples(Eigen::Index count) {
  Mat x(2, count);
  for (Eigen::Index k = 0; k < count; ++k) {
    const double t = 1e-3 * static_cast<double>(k);
    x(0, k) = 1.5 + std::sin(3.0 * t);
    x(1, k) = std::cos(2.0 * t) - 0.2;
  }
  return AddMeasurementNoise(x, Vec::Constant(2, 0.01), NoiseKey{7, 0});
}

TEST_CASE("flow regression of impact-msd is the trapezoid rule in closed form", "[regression]") {
  const Model model{ImpactMsd{}};
  RegressionBuilder b(model);
  Vec prev(2), cur(2);
  prev << 2.0, -1.0;
  cur << 1.5, -1.25;
  Mat phi(1, 2);
  Vec y(1);
  const double dt = 0.25, h = 0.5 * dt;
  b.Flow(prev, cur, dt, phi, y);
  // Row ξ2: φ = (0, −ξ1, −ξ2) with α_x known (it multiplies 0 in this row).
  CHECK(phi(0, 0) == h * (-2.0 + -1.5));
  CHECK(phi(0, 1) == h * (1.0 + 1.25));
  CHECK(y[0] == -1.25 - -1.0);
}

TEST_CASE("FlowRow and FlowRows equal Flow pair by pair, across blocks and restarts", "[regression]") {
  const Model models[] = {Model{ImpactMsd{}}, Model{BouncingBall{}}, Model{ImpactPendulum{}},
                          Model{FourUnknowns{}}};
  const Mat x = Samples(700);
  const double dt = 1e-3;
  for (const Model& model : models) {
    INFO(model.name());
    RegressionBuilder ref(model), row(model), rows(model);
    const auto u = static_cast<Eigen::Index>(ref.flow_layout().unknown.size());
    REQUIRE(ref.flow_layout().rows.size() == 1);
    // Reference: Flow on every pair, and on two pairs out of sequence.
    Mat phi_ref(u, x.cols() - 1);
    Vec y_ref(x.cols() - 1);
    Mat phi1(1, u);
    Vec y1(1);
    for (Eigen::Index k = 1; k < x.cols(); ++k) {
      ref.Flow(x.col(k - 1), x.col(k), dt, phi1, y1);
      phi_ref.col(k - 1) = phi1.transpose();
      y_ref[k - 1] = y1[0];
    }
    // FlowRow pair by pair.
    std::vector<double> p(static_cast<std::size_t>(u));
    double yv = 0.0;
    for (Eigen::Index k = 1; k < x.cols(); ++k) {
      row.FlowRow(x.col(k - 1).data(), x.col(k).data(), dt, p.data(), &yv);
      CHECK(Eigen::Map<const Vec>(p.data(), u) == phi_ref.col(k - 1));
      CHECK(yv == y_ref[k - 1]);
    }
    // FlowRows in uneven chunks (block boundaries at 64 states inside FlowRows), then a chunk that
    // does not continue the previous one (its first φ must be evaluated, not reused).
    const Eigen::Index chunks[] = {1, 2, 63, 64, 65, 130, 300};
    Mat phi_rows(u, x.cols() - 1);
    Vec y_rows(x.cols() - 1);
    Eigen::Index k = 1;
    for (Eigen::Index len : chunks) {
      len = std::min(len, x.cols() - k);
      rows.FlowRows(x.col(k - 1).data(), x.col(k).data(), len, dt, phi_rows.col(k - 1).data(),
                    y_rows.data() + (k - 1));
      k += len;
    }
    REQUIRE(k == x.cols() - 74);
    rows.FlowRows(x.col(k - 1).data(), x.col(k).data(), x.cols() - k, dt, phi_rows.col(k - 1).data(),
                  y_rows.data() + (k - 1));
    CHECK(phi_rows == phi_ref);
    CHECK(y_rows == y_ref);
    Mat phi_jump(u, 1);
    double y_jump = 0.0;
    rows.FlowRows(x.col(10).data(), x.col(11).data(), 1, dt, phi_jump.data(), &y_jump);
    CHECK(phi_jump.col(0) == phi_ref.col(10));
    CHECK(y_jump == y_ref[10]);
  }
}

}  // namespace
}  // namespace hysid
