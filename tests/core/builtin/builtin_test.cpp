// The built-in models: their maps against the paper's equations, Jacobians against central
// differences, C and D, the registry, and their specs as models/NAME.toml states them.
#include <catch2/catch.hpp>

#include <cmath>
#include <string>
#include <vector>

#include "core/builtin/bouncing_ball.hpp"
#include "core/builtin/builtin.hpp"
#include "core/builtin/impact_msd.hpp"
#include "core/builtin/impact_pendulum.hpp"
#include "core/builtin/spec.hpp"
#include "core/model/registry.hpp"

namespace hysid {
namespace {

TEST_CASE("impact-msd flow and jump maps match the paper's equations", "[builtin]") {
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

TEST_CASE("analytic Jacobians agree with central differences", "[builtin]") {
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

TEST_CASE("RegisterBuiltinModels registers the three built-in models", "[builtin]") {
  ModelRegistry registry;
  RegisterBuiltinModels(registry);
  CHECK(registry.names() == std::vector<std::string>{"bouncing-ball", "impact-msd", "impact-pendulum"});
  CHECK(registry.Make("impact-pendulum").name() == "impact-pendulum");
  CHECK_THROWS_WITH(registry.Make("pendulum"), Catch::Contains("impact-pendulum"));
}

TEST_CASE("a built-in spec is its model file's: the paper's Sec. 5 values for impact-msd", "[builtin]") {
  const ModelSpec& s = BuiltinSpec("impact-msd");
  CHECK(s.name == "impact-msd");
  CHECK(s.state_names == std::vector<std::string>{"x", "v"});
  REQUIRE(s.alpha.size() == 3);
  CHECK((s.alpha[0].known && !s.alpha[1].known && !s.alpha[2].known));
  CHECK((s.alpha[1].name == "a" && s.alpha[1].value == 5.0 && s.alpha[2].value == 0.1));
  REQUIRE(s.beta.size() == 3);
  CHECK((s.beta[1].name == "lambda" && s.beta[1].value == 0.99 && s.beta[2].value == 0.0));
  CHECK(s.default_x0 == std::vector<double>{20.0, 0.0});
  CHECK((s.default_t_end == 20.0 && s.default_dt == 5e-4));
  CHECK((s.guards.size() == 1 && s.guards[0].direction == Crossing::kFalling));
  CHECK(s.flow_jacobian_constant);
  CHECK_FALSE(BuiltinSpec("impact-pendulum").flow_jacobian_constant);
  CHECK(&BuiltinSpec("impact-msd") == &s);  // parsed once
  CHECK_THROWS_WITH(BuiltinSpec("wall-msd"), Catch::Contains("no built-in model 'wall-msd'"));
}

TEST_CASE("flow and jump sets of impact-msd", "[builtin]") {
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

TEST_CASE("distance to the jump set D = {xi1 = 0, xi2 <= 0} of the built-in models", "[builtin]") {
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
}

}  // namespace
}  // namespace hysid
