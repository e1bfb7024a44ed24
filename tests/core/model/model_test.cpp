// Models: parameters, flow/jump maps against their formulas, Jacobians against finite differences.
#include <catch2/catch.hpp>

#include <cmath>

#include "core/model/builtin/bouncing_ball.hpp"
#include "core/model/builtin/impact_msd.hpp"
#include "core/model/builtin/impact_pendulum.hpp"
#include "core/model/registry.hpp"

namespace hysid {
namespace {

// The example of docs/extending.md ("A model in C++"), verbatim but for the hysid:: prefixes.
struct VanDerPolWall {
  ModelSpec Spec() const {
    return {.name = "vdp-wall",
            .description = "Van der Pol oscillator with a wall",
            .state_names = {"x", "v"},
            // known = true marks a constant of the model structure (not identified).
            .alpha = {{"alpha_x", 1.0, true, "coefficient of v in x'"}, {"eps", 0.7, false, "damping"}},
            .beta = {{"beta_x", 1.0, true, "coefficient of x in x+"}, {"lambda", 0.5, false, "restitution"}},
            .flow_rows = {1},  // rows of φα with unknown parameters (reduced order, §4.3)
            .jump_rows = {1},
            .guards = {{"wall", Crossing::kFalling}},  // D reached when h = x falls through 0
            .default_x0 = {1.0, 0.0}};
  }
  void Phi(ConstVecRef x, MatRef phi) const {  // φ(ξ), n × |α|
    phi << x[1], 0.0, -x[0], (1 - x[0] * x[0]) * x[1];
  }
  void Psi(ConstVecRef x, MatRef psi) const {  // ψ(ξ), n × |β|
    psi << x[0], 0.0, 0.0, -x[1];
  }
  void Guards(ConstVecRef x, VecRef h) const { h[0] = x[0]; }
  bool InFlowSet(ConstVecRef x) const { return x[0] >= 0.0; }
  bool InJumpSet(ConstVecRef x) const { return x[0] == 0.0 && x[1] <= 0.0; }
  // Optional: FlowJacobian(x, alpha, J) (central differences otherwise),
  // ProjectOntoGuard(i, x) (puts a located crossing exactly on guard i) and
  // DistanceToJumpSet(x) (distance to D, for the set metrics; NaN without it).
};
static_assert(HybridModel<VanDerPolWall>);

TEST_CASE("impact-msd flow and jump maps match the paper's equations", "[model]") {
  const Model m{ImpactMsd{}};
  Vec x(2), f(2), xp(2);
  x << 0.3, -1.7;
  m.Flow(x, m.alpha(), f);
  CHECK(f[0] == -1.7);
  CHECK(f[1] == Approx(-5.0 * 0.3 - 0.1 * -1.7).epsilon(1e-15));
  m.Jump(x, m.beta(), xp);
  CHECK(xp[0] == 0.3);
  CHECK(xp[1] == Approx(0.99 * 1.7).epsilon(1e-15));
  CHECK(m.alpha_size() == 3);
  CHECK(m.spec().flow_rows == std::vector<int>{1});
}

TEST_CASE("analytic Jacobians agree with central differences", "[model]") {
  for (const Model& m : {Model{ImpactMsd{}}, Model{BouncingBall{}}, Model{ImpactPendulum{}}}) {
    Vec x(2);
    x << 0.4, -0.9;
    Mat analytic(2, 2), numeric(2, 2);
    m.FlowJacobian(x, m.alpha(), analytic);
    // Central difference by hand.
    const double h = 1e-6;
    for (int c = 0; c < 2; ++c) {
      Vec xp = x, xm = x, fp(2), fm(2);
      xp[c] += h;
      xm[c] -= h;
      m.Flow(xp, m.alpha(), fp);
      m.Flow(xm, m.alpha(), fm);
      numeric.col(c) = (fp - fm) / (2 * h);
    }
    INFO(m.name());
    CHECK((analytic - numeric).cwiseAbs().maxCoeff() <= 1e-8);
  }
}

TEST_CASE("a model without FlowJacobian gets a central-difference Jacobian", "[model]") {
  const Model m{VanDerPolWall{}};
  Vec x(2);
  x << 0.5, 2.0;
  Mat jac(2, 2);
  m.FlowJacobian(x, m.alpha(), jac);
  const double eps = 0.7;
  Mat exact(2, 2);
  exact << 0, 1,  //
      -1 - 2 * eps * x[0] * x[1], eps * (1 - x[0] * x[0]);
  CHECK((jac - exact).cwiseAbs().maxCoeff() <= 1e-7);
}

TEST_CASE("parameters are set by name, with clear errors", "[model]") {
  Model m{ImpactMsd{}};
  m.SetParameter("a=7.5");
  CHECK(m.alpha()[1] == 7.5);
  m.SetParameter("lambda", 0.5);
  CHECK(m.beta()[1] == 0.5);
  CHECK_THROWS_WITH(m.SetParameter("k=1"),
                    Catch::Contains("no parameter 'k'") && Catch::Contains("a, b, lambda, mu"));
  CHECK_THROWS_WITH(m.SetParameter("alpha_x=2"), Catch::Contains("known constant"));
  CHECK_THROWS_WITH(m.SetParameter("a=abc"), Catch::Contains("not a number"));
  CHECK_THROWS_WITH(m.SetParameter("a"), Catch::Contains("name=value"));
  CHECK_THROWS_WITH(m.SetParameter("a", std::nan("")), Catch::Contains("finite"));
  // A copy is independent of the original.
  Model copy = m;
  copy.SetParameter("a", 1.0);
  CHECK(m.alpha()[1] == 7.5);
}

TEST_CASE("the registry knows the built-in models and names them on a miss", "[model]") {
  ModelRegistry registry;
  RegisterBuiltinModels(registry);
  CHECK(registry.names() == std::vector<std::string>{"bouncing-ball", "impact-msd", "impact-pendulum"});
  CHECK(registry.Make("impact-pendulum").name() == "impact-pendulum");
  CHECK_THROWS_WITH(registry.Make("pendulum"), Catch::Contains("impact-pendulum"));
  registry.Register(VanDerPolWall{});
  CHECK(registry.Contains("vdp-wall"));
  CHECK_THROWS(registry.Register(VanDerPolWall{}));
}

TEST_CASE("flow and jump sets of impact-msd", "[model]") {
  const Model m{ImpactMsd{}};
  Vec x(2);
  x << 1.0, -3.0;
  CHECK(m.InFlowSet(x));
  CHECK_FALSE(m.InJumpSet(x));
  x << 0.0, -3.0;
  CHECK_FALSE(m.InFlowSet(x));
  CHECK(m.InJumpSet(x));
  x << -0.1, 1.0;
  CHECK_FALSE(m.InFlowSet(x));
  CHECK_FALSE(m.InJumpSet(x));
}

TEST_CASE("distance to the jump set D = {xi1 = 0, xi2 <= 0} of the built-in models", "[model]") {
  for (const Model& m : {Model{ImpactMsd{}}, Model{BouncingBall{}}, Model{ImpactPendulum{}}}) {
    INFO(m.name());
    REQUIRE(m.has_jump_set_distance());
    auto d = [&](double a, double b) { return m.DistanceToJumpSet((Vec(2) << a, b).finished()); };
    CHECK(d(0.0, -3.0) == 0.0);  // on D
    CHECK(d(0.0, 0.0) == 0.0);   // its end point
    CHECK(d(0.5, -3.0) == 0.5);  // beside it
    CHECK(d(-0.5, -3.0) == 0.5);
    CHECK(d(3.0, 4.0) == 5.0);  // nearest point of D is the origin
    CHECK(d(0.0, 2.0) == 2.0);
  }
  // The example model of docs/extending.md does not provide it: NaN.
  const Model vdp{VanDerPolWall{}};
  CHECK_FALSE(vdp.has_jump_set_distance());
  CHECK(std::isnan(vdp.DistanceToJumpSet(Vec::Zero(2))));
}

}  // namespace
}  // namespace hysid
