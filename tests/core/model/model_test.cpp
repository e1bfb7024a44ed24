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


// A struct with the context forms: ξ' = (v, −x + G·u), a wall at x = w (γ), only x measured.
struct DrivenWall {
  ModelSpec Spec() const {
    return {.name = "driven-wall",
            .description = "a driven mass against a wall at an unknown position",
            .state_names = {"x", "v"},
            .alpha = {{"one", 1.0, true, ""}, {"G", 2.0, false, "input gain"}},
            .beta = {{"one_b", 1.0, true, ""}, {"e", 0.5, false, "restitution", 0.0, 1.0}},
            .flow_rows = {1},
            .jump_rows = {1},
            .guards = {{"wall", Crossing::kRising}},
            .default_x0 = {0.0, 1.0},
            .measured = {0},
            .inputs = {"u"},
            .guard_params = {{"w", 1.0, false, "wall", 0.0, 5.0}}};
  }
  void Phi(ConstVecRef x, const Context& ctx, MatRef phi) const {
    SetRowMajor<2, 2>(phi, {x[1], 0.0, -x[0], ctx.u[0]});
  }
  void Psi(ConstVecRef x, const Context&, MatRef psi) const { SetRowMajor<2, 2>(psi, {x[0], 0.0, 0.0, -x[1]}); }
  void Guards(ConstVecRef x, const Context& ctx, VecRef h) const { h[0] = x[0] - ctx.gamma[0]; }
  bool InFlowSet(ConstVecRef x, const Context& ctx) const { return x[0] <= ctx.gamma[0]; }
  bool InJumpSet(ConstVecRef x, const Context& ctx) const { return x[0] >= ctx.gamma[0] && x[1] >= 0.0; }
  void ProjectOntoGuard(int, const Context& ctx, VecRef x) const { x[0] = ctx.gamma[0]; }
};
static_assert(HybridModel<DrivenWall> && ContextModel<DrivenWall> && !XOnlyModel<DrivenWall>);
static_assert(HybridModel<VanDerPolWall> && !ContextModel<VanDerPolWall>);

TEST_CASE("a struct with the context forms sees the context's input and γ, or the model's own γ", "[model]") {
  Model m{DrivenWall{}};
  REQUIRE(m.gamma_size() == 1);
  REQUIRE(m.input_size() == 1);
  REQUIRE(MeasuredIndices(m) == std::vector<int>{0});
  REQUIRE(UnknownNames(m.spec().guard_params) == std::vector<std::string>{"w"});
  Vec x(2);
  x << 0.4, 0.3;
  const double u = -1.5, gamma = 0.25;
  Vec f(2);
  m.Flow(x, m.alpha(), f, Context{.t = 0.0, .u = &u});
  CHECK(f[0] == 0.3);
  CHECK(f[1] == -0.4 + 2.0 * -1.5);
  Mat jac(2, 2);
  m.FlowJacobian(x, m.alpha(), jac, Context{.t = 0.0, .u = &u});
  CHECK(std::abs(jac(1, 0) + 1.0) <= 1e-8);
  CHECK(std::abs(jac(0, 1) - 1.0) <= 1e-8);
  Vec h(1);
  m.Guards(x, h, Context{.t = 0.0, .u = &u});
  CHECK(h[0] == 0.4 - 1.0);
  m.Guards(x, h, Context{.t = 0.0, .u = &u, .gamma = &gamma});
  CHECK(h[0] == 0.4 - 0.25);
  CHECK(m.InJumpSet(x, Context{.t = 0.0, .u = &u, .gamma = &gamma}));
  Mat dh(1, 1);
  m.GuardGammaJacobian(x, Context{.t = 0.0, .u = &u}, dh);
  CHECK(std::abs(dh(0, 0) + 1.0) <= 1e-9);
  m.SetParameter("w", 0.5);
  m.Guards(x, h, Context{.t = 0.0, .u = &u});
  CHECK(h[0] == 0.4 - 0.5);
  CHECK_THROWS_WITH(m.SetParameter("w", 6.0), "parameter 'w' = 6: outside its bounds [0, 5]");
  CHECK_THROWS_WITH(m.SetParameter("e", -0.1), "parameter 'e' = -0.1: outside its bounds [0, 1]");
  CHECK_THROWS_AS(m.Flow(x, m.alpha(), f), std::logic_error);
}

TEST_CASE("an x-only struct evaluated with a context ignores it", "[model]") {
  const Model m{VanDerPolWall{}};
  Vec x(2);
  x << 0.5, 2.0;
  const double u = 7.0;
  Mat a(2, 2), b(2, 2);
  m.Phi(x, a);
  m.Phi(x, b, Context{.t = 3.0, .u = &u});
  CHECK(a == b);
  CHECK(MeasuredIndices(m) == std::vector<int>{0, 1});
  CHECK(m.gamma_size() == 0);
}

struct BadBounds : DrivenWall {
  ModelSpec Spec() const {
    ModelSpec s = DrivenWall::Spec();
    s.guard_params[0].value = 7.0;
    return s;
  }
};

TEST_CASE("a spec whose value lies outside its bounds is refused naming the parameter", "[model]") {
  CHECK_THROWS_WITH(Model{BadBounds{}},
                    "model 'driven-wall': parameter 'w' = 7 is outside its bounds [0, 5]");
}
}  // namespace
}  // namespace hysid
