// Models: the HybridModel concept on the example of docs/extending.md, parameters by name, the
// central-difference Jacobian, the registry.
#include <catch2/catch.hpp>

#include <cmath>

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
  Model m{VanDerPolWall{}};
  m.SetParameter("eps=1.5");
  CHECK(m.alpha()[1] == 1.5);
  m.SetParameter("lambda", 0.25);
  CHECK(m.beta()[1] == 0.25);
  CHECK_THROWS_WITH(m.SetParameter("k=1"),
                    Catch::Contains("no parameter 'k'") && Catch::Contains("eps, lambda"));
  CHECK_THROWS_WITH(m.SetParameter("alpha_x=2"), Catch::Contains("known constant"));
  CHECK_THROWS_WITH(m.SetParameter("eps=abc"), Catch::Contains("not a number"));
  CHECK_THROWS_WITH(m.SetParameter("eps"), Catch::Contains("name=value"));
  CHECK_THROWS_WITH(m.SetParameter("eps", std::nan("")), Catch::Contains("finite"));
  // A copy is independent of the original.
  Model copy = m;
  copy.SetParameter("eps", 1.0);
  CHECK(m.alpha()[1] == 1.5);
}

TEST_CASE("a registry makes its models by name and names them on a miss", "[model]") {
  ModelRegistry registry;
  registry.Register(VanDerPolWall{});
  CHECK(registry.Contains("vdp-wall"));
  CHECK(registry.names() == std::vector<std::string>{"vdp-wall"});
  CHECK(registry.Make("vdp-wall").name() == "vdp-wall");
  CHECK_THROWS_WITH(registry.Make("vdp"), Catch::Contains("vdp-wall"));
  CHECK_THROWS(registry.Register(VanDerPolWall{}));
}

TEST_CASE("a model without DistanceToJumpSet has NaN distances", "[model]") {
  // The example model of docs/extending.md does not provide it: NaN.
  const Model vdp{VanDerPolWall{}};
  CHECK_FALSE(vdp.has_jump_set_distance());
  CHECK(std::isnan(vdp.DistanceToJumpSet(Vec::Zero(2))));
}

}  // namespace
}  // namespace hysid
