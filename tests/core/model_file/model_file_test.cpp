// Model files against the same models written in C++: every function of the model, whole
// trajectories and identification runs agree; every kind of bad file is refused naming the file,
// the line, the key and the expression (the guard that never fires: sim/model_check).
#include <catch2/catch.hpp>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "core/builtin/bouncing_ball.hpp"
#include "core/builtin/impact_msd.hpp"
#include "core/builtin/impact_pendulum.hpp"
#include "core/identify/identifier.hpp"
#include "core/model_file/model_file.hpp"
#include "sim/measurement.hpp"
#include "sim/model_check/model_check.hpp"
#include "sim/simulator.hpp"

namespace hysid {
namespace {

// The mass on a spring hitting a wall at x = 1 of models/wall-msd.toml, written in C++.
struct WallMsd {
  ModelSpec Spec() const {
    return ModelSpec{
        .name = "wall-msd",
        .description = "mass on a spring hitting a wall at x = 1",
        .state_names = {"x", "v"},
        .alpha = {{"alpha_x", 1.0, true, ""}, {"k", 4.0, false, ""}, {"b", 0.2, false, ""}},
        .beta = {{"beta_x", 1.0, true, ""}, {"lambda", 0.8, false, ""}, {"mu", 0.0, false, ""}},
        .flow_rows = {1},
        .jump_rows = {1},
        .guards = {{"wall", Crossing::kRising}},
        .flow_jacobian_constant = true,
        .default_x0 = {0.0, 5.0},
        .default_t_end = 20.0,
        .default_dt = 5e-4,
    };
  }
  void Phi(ConstVecRef x, MatRef phi) const { phi << x[1], 0.0, 0.0, 0.0, -x[0], -x[1]; }
  void Psi(ConstVecRef x, MatRef psi) const { psi << x[0], 0.0, 0.0, 0.0, -x[1], 1.0; }
  void Guards(ConstVecRef x, VecRef h) const { h[0] = x[0] - 1.0; }
  bool InFlowSet(ConstVecRef x) const { return x[0] < 1.0 || (x[0] == 1.0 && x[1] <= 0.0); }
  bool InJumpSet(ConstVecRef x) const { return x[0] == 1.0 && x[1] >= 0.0; }
  double DistanceToJumpSet(ConstVecRef x) const { return std::hypot(x[0] - 1.0, std::min(x[1], 0.0)); }
  void ProjectOntoGuard(int /*guard*/, VecRef x) const { x[0] = 1.0; }
};

std::string ModelPath(const std::string& name) {
  return std::string(HYSID_MODELS_DIR) + "/" + name + ".toml";
}

void RequireSameSpec(const ModelSpec& a, const ModelSpec& b) {
  REQUIRE(a.name == b.name);
  REQUIRE(a.state_names == b.state_names);
  REQUIRE(a.alpha.size() == b.alpha.size());
  REQUIRE(a.beta.size() == b.beta.size());
  for (std::size_t i = 0; i < a.alpha.size(); ++i) {
    REQUIRE(a.alpha[i].name == b.alpha[i].name);
    REQUIRE(a.alpha[i].value == b.alpha[i].value);
    REQUIRE(a.alpha[i].known == b.alpha[i].known);
  }
  for (std::size_t i = 0; i < a.beta.size(); ++i) {
    REQUIRE(a.beta[i].name == b.beta[i].name);
    REQUIRE(a.beta[i].value == b.beta[i].value);
    REQUIRE(a.beta[i].known == b.beta[i].known);
  }
  REQUIRE(a.flow_rows == b.flow_rows);
  REQUIRE(a.jump_rows == b.jump_rows);
  REQUIRE(a.guards.size() == b.guards.size());
  for (std::size_t g = 0; g < a.guards.size(); ++g) REQUIRE(a.guards[g].direction == b.guards[g].direction);
  REQUIRE(a.flow_jacobian_constant == b.flow_jacobian_constant);
  REQUIRE(a.default_x0 == b.default_x0);
  REQUIRE(a.default_t_end == b.default_t_end);
  REQUIRE(a.default_dt == b.default_dt);
}

// φ, ψ, guards, C, D, distance, projection at random states (and on the sets' boundaries).
void RequireSameFunctions(const Model& file, const Model& cpp) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  const int n = cpp.state_size();
  for (int trial = 0; trial < 200; ++trial) {
    Vec x(n);
    for (int i = 0; i < n; ++i) x[i] = trial % 4 == 0 ? std::round(u(rng)) : u(rng);
    Mat pa(n, cpp.alpha_size()), pb(n, cpp.alpha_size()), sa(n, cpp.beta_size()), sb(n, cpp.beta_size());
    file.Phi(x, pa);
    cpp.Phi(x, pb);
    file.Psi(x, sa);
    cpp.Psi(x, sb);
    REQUIRE(pa == pb);
    REQUIRE(sa == sb);
    Vec ha(cpp.guard_count()), hb(cpp.guard_count());
    file.Guards(x, ha);
    cpp.Guards(x, hb);
    REQUIRE(ha == hb);
    REQUIRE(file.InFlowSet(x) == cpp.InFlowSet(x));
    REQUIRE(file.InJumpSet(x) == cpp.InJumpSet(x));
    REQUIRE(file.DistanceToJumpSet(x) == Approx(cpp.DistanceToJumpSet(x)).epsilon(1e-15).margin(1e-15));
    Vec xa = x, xb = x;
    file.ProjectOntoGuard(0, xa);
    cpp.ProjectOntoGuard(0, xb);
    REQUIRE(xa == xb);
    Mat ja(n, n), jb(n, n);
    file.FlowJacobian(x, cpp.alpha(), ja);
    cpp.FlowJacobian(x, cpp.alpha(), jb);
    REQUIRE((ja - jb).cwiseAbs().maxCoeff() < 1e-8 * (1.0 + jb.cwiseAbs().maxCoeff()));
  }
  // The bulk path gives the per-state values.
  Mat xs = Mat::Random(n, 70);
  Mat bulk(n * cpp.alpha_size(), 70);
  file.PhiColumns(xs.data(), 70, bulk.data());
  for (Eigen::Index k = 0; k < 70; ++k) {
    Mat one(n, cpp.alpha_size());
    cpp.Phi(xs.col(k), one);
    REQUIRE(Eigen::Map<const Mat>(bulk.col(k).data(), n, cpp.alpha_size()) == one);
  }
}

void RequireSameTrajectory(const Model& file, const Model& cpp) {
  const ModelSpec& s = cpp.spec();
  const Vec x0 = Eigen::Map<const Vec>(s.default_x0.data(), cpp.state_size());
  const SampleGrid grid{.t_end = s.default_t_end, .dt = s.default_dt};
  const Trajectory a = Simulate(file, x0, grid), b = Simulate(cpp, x0, grid);
  REQUIRE(a.status.stop == b.status.stop);
  REQUIRE(a.size() == b.size());
  REQUIRE(a.jumps.size() == b.jumps.size());
  REQUIRE(a.jumps.size() > 0);
  REQUIRE(a.j == b.j);
  REQUIRE((a.x - b.x).cwiseAbs().maxCoeff() <= 1e-12 * (1.0 + b.x.cwiseAbs().maxCoeff()));
}

TEST_CASE("the built-in models as model files agree with their C++", "[model_file]") {
  const std::pair<std::string, Model> cases[] = {{"impact-msd", Model(ImpactMsd{})},
                                                 {"bouncing-ball", Model(BouncingBall{})},
                                                 {"impact-pendulum", Model(ImpactPendulum{})}};
  for (const auto& [name, cpp] : cases) {
    INFO(name);
    const Model file = LoadModelFile(ModelPath(name));
    RequireSameSpec(file.spec(), cpp.spec());
    RequireSameFunctions(file, cpp);
    REQUIRE(file.has_jump_set_distance());
    RequireSameTrajectory(file, cpp);
  }
}

TEST_CASE("the wall model: file and C++ give the same trajectory and the same estimates", "[model_file]") {
  const Model file = LoadModelFile(ModelPath("wall-msd"));
  const Model cpp(WallMsd{});
  RequireSameSpec(file.spec(), cpp.spec());
  RequireSameFunctions(file, cpp);
  RequireSameTrajectory(file, cpp);

  const Vec x0 = Eigen::Map<const Vec>(cpp.spec().default_x0.data(), 2);
  const Trajectory traj = Simulate(cpp, x0, SampleGrid{20.0, 5e-4});
  const Mat y = AddMeasurementNoise(traj.x, Vec::Constant(2, 1e-5), NoiseKey{.seed = 3, .stream = 0});
  for (const char* estimator : {"rls", "gtls"}) {
    INFO(estimator);
    IdentifierSettings settings;
    settings.flow_estimator.kind = settings.jump_estimator.kind = ParseKind<EstimatorKind>(estimator);
    const IdentifyResult a = Identify(file, y, 5e-4, settings), b = Identify(cpp, y, 5e-4, settings);
    REQUIRE(a.jumps_detected == b.jumps_detected);
    REQUIRE(a.jumps_detected >= 3);
    REQUIRE(a.gamma == b.gamma);
    for (Eigen::Index i = 0; i < 3; ++i) {
      REQUIRE(a.alpha_hat[i] == Approx(b.alpha_hat[i]).epsilon(1e-9));
      REQUIRE(a.beta_hat[i] == Approx(b.beta_hat[i]).epsilon(1e-9).margin(1e-12));
    }
    // And the estimates are the truth, within the noise.
    REQUIRE(a.alpha_hat[1] == Approx(4.0).epsilon(1e-2));
    REQUIRE(a.beta_hat[1] == Approx(0.8).epsilon(1e-2));
  }
}

// The paper's §5 run (impact-msd, x0 = (20, 0), 20 s at δt = 5e-4, the paper detector r = 220 and
// RLS): from models/impact-msd.toml the flow regression rows (row v of φ evaluated alone,
// Model::PhiRowColumns), every decision and the estimates are the built-in's bit for bit.
TEST_CASE("the §5 run: the model file identifies as the built-in model, bit for bit", "[model_file]") {
  const Model file = LoadModelFile(ModelPath("impact-msd"));
  const Model cpp(ImpactMsd{});
  const Vec x0 = DefaultState(cpp);
  const double dt = 5e-4;
  const Trajectory traj = Simulate(cpp, x0, SampleGrid{20.0, dt});
  for (const double sigma : {0.0, 0.05}) {
    INFO("sigma " << sigma);
    const Mat y = AddMeasurementNoise(traj.x, Vec::Constant(2, sigma), NoiseKey{.seed = 1, .stream = 0});
    const FlowRows ra = BuildFlowRows(file, y, dt), rb = BuildFlowRows(cpp, y, dt);
    REQUIRE(ra.y.size() == std::size_t(y.cols()));
    REQUIRE(std::equal(ra.y.begin() + 1, ra.y.end(), rb.y.begin() + 1));
    REQUIRE(std::equal(ra.phi.begin() + 2, ra.phi.end(), rb.phi.begin() + 2));
    IdentifierSettings settings;
    settings.sets = false;
    const IdentifyResult a = Identify(file, y, dt, settings), b = Identify(cpp, y, dt, settings);
    REQUIRE(a.gamma == b.gamma);
    REQUIRE(a.statistic == b.statistic);
    REQUIRE(a.threshold == b.threshold);
    REQUIRE(a.jumps_detected == b.jumps_detected);
    REQUIRE(a.alpha_hat == b.alpha_hat);
    REQUIRE(a.beta_hat == b.beta_hat);
    // And the run is the paper's: its 14 impacts found, a and b near the truth (5, 0.1).
    if (sigma == 0.0) REQUIRE(a.jumps_detected == 14);
    REQUIRE(a.alpha_hat[1] == Approx(5.0).epsilon(sigma == 0.0 ? 1e-4 : 2e-2));
    REQUIRE(a.alpha_hat[2] == Approx(0.1).epsilon(sigma == 0.0 ? 1e-2 : 0.5));
  }
}

TEST_CASE("a model file evaluates correctly from several threads at once", "[model_file]") {
  const Model file = LoadModelFile(ModelPath("impact-pendulum"));
  const Model cpp(ImpactPendulum{});
  std::vector<int> mismatches(2, 0);
  std::vector<std::thread> threads;
  for (int t = 0; t < 2; ++t) {
    threads.emplace_back([&, t] {
      Mat a(2, 3), b(2, 3);
      for (int k = 0; k < 20000; ++k) {
        Vec x(2);
        x << 0.001 * (k + t), -0.002 * k;
        file.Phi(x, a);
        cpp.Phi(x, b);
        if (a != b) ++mismatches[std::size_t(t)];
      }
    });
  }
  for (auto& th : threads) th.join();
  REQUIRE(mismatches == std::vector<int>{0, 0});
}

// A valid file to break one line at a time.
const char* kGood = R"(name = "m"
states = ["x", "v"]
alpha = [{ name = "one", value = 1.0, known = true }, { name = "a", value = 5.0 }]
beta = [{ name = "one_b", value = 1.0, known = true }, { name = "lambda", value = 0.9 }]
[flow]
phi = [["v", 0], [0, "-x"]]
rows = ["v"]
[jump]
psi = [["x", 0], [0, "-v"]]
rows = ["v"]
[[guard]]
name = "wall"
h = "x"
direction = "falling"
[sets]
C = "x >= 0"
D = "x == 0 && v <= 0"
[defaults]
x0 = [1.0, 0.0]
t_end = 5.0
dt = 1e-3
)";

std::string Replace(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  REQUIRE(at != std::string::npos);
  return text.replace(at, from.size(), to);
}

// The error of reading the text (with `simulate`, as the programs do: the default trajectory too;
// without, ParseModelFile alone), or "(accepted)".
std::string ErrorOf(const std::string& text, bool simulate = true) {
  try {
    if (simulate) {
      ParseModelText(text, "m.toml");
    } else {
      ParseModelFile(text, "m.toml");
    }
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "(accepted)";
}

// A file whose values are start values (identify): a guard its default trajectory never reaches is a
// note naming the file, line and guard, and the model loads; the same file as the truth is refused.
TEST_CASE("a guard that start values never reach is a note, not a refusal", "[model_file]") {
  using Catch::Matchers::Contains;
  const std::string text = Replace(kGood, "h = \"x\"", "h = \"x + 10\"");
  REQUIRE_THAT(ErrorOf(text), Contains("never reaches D"));
  std::string note = "stale";
  const Model m = ParseModelText(text, "m.toml", ModelValues::kStart, &note);
  CHECK(m.state_size() == 2);
  CHECK_THAT(note, Contains("m.toml:11: guard[0].h: with its start values, guard \"wall\" never reaches D"));
  ParseModelText(kGood, "m.toml", ModelValues::kStart, &note);
  CHECK(note.empty());
  // Other checks stay errors for start values.
  CHECK_THROWS_WITH(ParseModelText(Replace(kGood, "x0 = [1.0, 0.0]", "x0 = [-1.0, 0.0]"), "m.toml", ModelValues::kStart),
                    Contains("defaults.x0: (-1, 0) is outside C and D"));
}

TEST_CASE("a good file loads and its equations read back", "[model_file]") {
  const Model m = ParseModelText(kGood, "m.toml");
  REQUIRE(m.state_size() == 2);
  REQUIRE(m.spec().equations.find("flow: v' = a*(-x)") != std::string::npos);
  REQUIRE(m.spec().equations.find("guard wall: h(xi) = x (falling)") != std::string::npos);
  REQUIRE_FALSE(m.has_jump_set_distance());
  REQUIRE(std::isnan(m.DistanceToJumpSet(Vec::Zero(2))));
}

TEST_CASE("bad model files are refused naming file, line, key and expression", "[model_file]") {
  using Catch::Matchers::Contains;
  REQUIRE_THAT(ErrorOf(Replace(kGood, "[0, \"-x\"]", "[0, \"-y\"]")),
               Contains("m.toml:6: flow.phi[1][1]: \"-y\": unknown symbol \"y\""));
  // toml++ 3.3.0 must never see a non-ASCII byte where it reaches __builtin_unreachable.
  REQUIRE_THAT(ErrorOf(Replace(kGood, "t_end = 5.0", "t_end = 5.0 \xc3\xbb")),
               Contains("a non-ASCII character outside a string or comment"));
  REQUIRE_THAT(ErrorOf(Replace(kGood, "[0, \"-x\"]", "[0, \"-x\", 1]")),
               Contains("m.toml:6: flow.phi[1]: has 3 entries, expected 2"));
  REQUIRE_THAT(ErrorOf(Replace(kGood, "psi = [[\"x\", 0], [0, \"-v\"]]", "psi = [[\"x\", 0]]")),
               Contains("m.toml:9: jump.psi: has 1 entries, expected 2 (one row per state)"));
  REQUIRE_THAT(ErrorOf(Replace(kGood, "\"-v\"]]", "\"-v*(\"]]")),
               Contains("m.toml:9: jump.psi[1][1]: \"-v*(\""));
  REQUIRE_THAT(ErrorOf(Replace(kGood, "direction = \"falling\"", "direction = \"down\"")),
               Contains("m.toml:14: guard[0].direction: unknown direction 'down' (known: falling, rising, both)"));
  REQUIRE_THAT(ErrorOf(Replace(kGood, "rows = [\"v\"]\n[jump]", "rows = [\"w\"]\n[jump]")),
               Contains("m.toml:7: flow.rows[0]: unknown state 'w' (known: x, v)"));
  REQUIRE_THAT(ErrorOf(Replace(kGood, "t_end = 5.0", "t_end = 5.0\nhorizon = 3")),
               Contains("m.toml:21: defaults.horizon: unknown key"));
  REQUIRE_THAT(ErrorOf(Replace(kGood, "D = \"x == 0 && v <= 0\"\n", "")),
               Contains("m.toml:15: sets.D: missing"));
  REQUIRE_THAT(ErrorOf(Replace(kGood, "x0 = [1.0, 0.0]", "x0 = [-1.0, 0.0]")),
               Contains("m.toml:19: defaults.x0: (-1, 0) is outside C and D"));
  // x oscillates in [-1, 1] without the wall: x + 10 never reaches zero.
  REQUIRE_THAT(ErrorOf(Replace(kGood, "h = \"x\"", "h = \"x + 10\"")),
               Contains("m.toml:11: guard[0].h: guard \"wall\" never reaches D on the default trajectory"));
  REQUIRE_THAT(ErrorOf(Replace(kGood, "name = \"a\", value = 5.0", "name = \"a\", value = \"5\"")),
               Contains("m.toml:3: alpha[1].value: expected a number, got a string"));
  REQUIRE_THAT(ErrorOf("name = \n"), Contains("m.toml:1: TOML syntax"));
  REQUIRE_THAT(ErrorOf(Replace(kGood, "h = \"x\"", "h = \"2\"")),
               Contains("m.toml:13: guard[0].h: guard 'wall': \"2\" reads no state, input or time, so it never "
                        "changes along a run and can never cross zero"));
}

// [flow] without rows: the rows of φ with an unknown α entry, as for a [[flow]] table (here v: the known
// α "one" enters row x). A missing [jump] rows or [sets] says what to write.
TEST_CASE(
    "rows left out of [flow] are the rows with unknowns, and a missing jump rows or sets says what to write",
    "[model_file]") {
  using Catch::Matchers::Contains;
  const Model given = ParseModelText(kGood, "m.toml");
  const Model defaulted = ParseModelText(Replace(kGood, "rows = [\"v\"]\n[jump]", "[jump]"), "m.toml");
  CHECK(defaulted.spec().flow_rows == given.spec().flow_rows);
  CHECK(defaulted.spec().flow_rows == std::vector<int>{1});
  // "one" unknown too: both rows carry an unknown, both are the default.
  const Model both =
      ParseModelText(Replace(Replace(kGood, "rows = [\"v\"]\n[jump]", "[jump]"),
                             "value = 1.0, known = true }, { name = \"a\"", "value = 1.0 }, { name = \"a\""),
                     "m.toml");
  CHECK(both.spec().flow_rows == std::vector<int>{0, 1});
  REQUIRE_THAT(
      ErrorOf(Replace(kGood, "rows = [\"v\"]\n[[guard]]", "[[guard]]")),
      Contains("m.toml:8: jump.rows: missing: give the identified rows; the rows the unknown parameters "
               "enter are rows = [\"v\"]"));
  REQUIRE_THAT(ErrorOf(Replace(kGood, "[sets]\nC = \"x >= 0\"\nD = \"x == 0 && v <= 0\"\n", "")),
               Contains("sets: missing: one [flow] and one [jump] need the flow set C and the jump set D"));
}

TEST_CASE("a guard reads α and β by name, at the context's values, and parameters alone are refused", "[model_file]") {
  using Catch::Matchers::Contains;
  // x oscillates in [-1, 1]: the wall at x = a/10 − lambda/2 = 0.05 is reached.
  const std::string text = Replace(kGood, "h = \"x\"", "h = \"x - a/10 + lambda/2\"");
  Model m = ParseModelFile(text, "m.toml").model;
  Vec x(2);
  x << 0.5, -0.2;
  Vec h(1);
  m.Guards(x, h);  // the model's own α, β
  CHECK(h[0] == 0.5 - 5.0 / 10 + 0.9 / 2);
  const Vec alpha = (Vec(2) << 1.0, 3.0).finished(), beta = (Vec(2) << 1.0, 0.5).finished();
  m.Guards(x, h, Context{.alpha = alpha.data(), .beta = beta.data()});
  CHECK(h[0] == 0.5 - 3.0 / 10 + 0.5 / 2);
  Mat dh_da(1, 2), dh_db(1, 2);
  m.GuardParameterJacobian(x, Context{}, Model::ParameterBlock::kAlpha, dh_da);
  m.GuardParameterJacobian(x, Context{}, Model::ParameterBlock::kBeta, dh_db);
  CHECK(dh_da(0, 0) == 0.0);
  CHECK(std::abs(dh_da(0, 1) + 0.1) <= 1e-9);
  CHECK(std::abs(dh_db(0, 1) - 0.5) <= 1e-9);
  m.SetParameter("a", 2.0);  // SetParameter moves the guard with the model's own α
  m.Guards(x, h);
  CHECK(h[0] == 0.5 - 2.0 / 10 + 0.9 / 2);
  // The sets read them too.
  const std::string sets = Replace(text, "C = \"x >= 0\"", "C = \"x >= a - 5\"");
  const Model with_sets = ParseModelFile(sets, "m.toml").model;
  const Vec below = (Vec(2) << -0.5, 0.0).finished();
  CHECK(with_sets.InFlowSet(below, Context{.alpha = alpha.data(), .beta = beta.data()}));  // -0.5 >= 3 - 5
  CHECK_FALSE(with_sets.InFlowSet(below));                                                   // -0.5 >= 0
  // φ stays linear in α: an α name is no variable of φ.
  REQUIRE_THAT(ErrorOf(Replace(kGood, "[0, \"-x\"]", "[0, \"-x*a\"]")), Contains("unknown symbol \"a\""));
  // Constants and parameters alone never change along a run.
  REQUIRE_THAT(ErrorOf(Replace(kGood, "h = \"x\"", "h = \"a - lambda\""), false),
               Contains("m.toml:13: guard[0].h: guard 'wall': \"a - lambda\" reads no state, input or time"));
  // The variables an unknown symbol's message lists include them.
  REQUIRE_THAT(ErrorOf(Replace(kGood, "h = \"x\"", "h = \"x - q\""), false),
               Contains("(the variables: states x, v; flow parameters one, a; jump parameters one_b, lambda)"));
}


// Every place a model file holds an expression (φ and ψ entries, a guard's h and projection, C, D, the
// distance to D), each with '=' written for '==' or as an assignment: refused naming the file, line,
// key and expression; the comparisons that contain '=' are accepted in the same places.
TEST_CASE("an expression may not assign: every expression key, every assignment form", "[model_file]") {
  using Catch::Matchers::Contains;
  const std::string with_projection = Replace(kGood, "direction = \"falling\"",
                                              "direction = \"falling\"\nproject = { x = \"0\" }");
  const std::string with_distance = Replace(kGood, "D = \"x == 0 && v <= 0\"",
                                            "D = \"x == 0 && v <= 0\"\ndistance_to_D = \"abs(x)\"");
  struct Place {
    std::string text, entry, key;
    int line;
  };
  const std::vector<Place> places{
      {kGood, "\"-x\"", "flow.phi[1][1]", 6},
      {kGood, "\"-v\"", "jump.psi[1][1]", 9},
      {kGood, "h = \"x\"", "guard[0].h", 13},
      {with_projection, "x = \"0\"", "guard[0].project.x", 15},
      {kGood, "C = \"x >= 0\"", "sets.C", 16},
      {kGood, "D = \"x == 0 && v <= 0\"", "sets.D", 17},
      {with_distance, "distance_to_D = \"abs(x)\"", "sets.distance_to_D", 18},
  };
  for (const Place& p : places) {
    const std::string lhs = p.entry.substr(0, p.entry.find('"'));
    for (const std::string bad : {"v = v*2", "x = 1 && v >= 0", "(v = 0) + x", "x + (v = 2)"}) {
      INFO(p.key << ": " << bad);
      const std::string error = ErrorOf(Replace(p.text, p.entry, lhs + "\"" + bad + "\""));
      CHECK_THAT(error, Contains(fmt::format("m.toml:{}: {}: \"{}\": '=' is muParser's assignment", p.line,
                                             p.key, bad)));
    }
    for (const std::string fine : {"x == 0 || v <= 0", "x >= 0 && v != 1"}) {
      INFO(p.key << ": " << fine);
      CHECK_THAT(ErrorOf(Replace(p.text, p.entry, lhs + "\"" + fine + "\"")),
                 !Contains("assignment"));
    }
  }
}

// Entries see the state as given: φ evaluated at ξ gives the same matrix every time, and an entry
// that reads v after one that scales it reads the v passed in.
TEST_CASE("entries of one matrix do not affect each other or later evaluations", "[model_file]") {
  const Model m = ParseModelFile(Replace(kGood, "phi = [[\"v\", 0], [0, \"-x\"]]",
                                         "phi = [[\"v*2\", 0], [\"v\", \"-x\"]]"),
                                 "m.toml").model;
  Vec x(2);
  x << 0.5, 3.0;
  Mat first(2, 2), again(2, 2);
  m.Phi(x, first);
  m.Phi(x, again);
  CHECK(first(0, 0) == 6.0);
  CHECK(first(1, 0) == 3.0);
  CHECK(first(1, 1) == -0.5);
  CHECK(first == again);
  CHECK(x(1) == 3.0);
}

// Malformed expressions, listed and drawn at random from operator and operand tokens: each is refused
// naming the file, line, key and expression, with a reason (never muParser's bare "Internal error"),
// or loads; none escapes as another exception.
TEST_CASE("malformed expressions are refused naming the key and the expression", "[model_file]") {
  using Catch::Matchers::Contains;
  const std::string where = "m.toml:6: flow.phi[1][1]: \"";
  auto check = [&](const std::string& expr, bool must_fail) {
    INFO(expr);
    const std::string error = ErrorOf(Replace(kGood, "\"-x\"]]", "\"" + expr + "\"]]"), false);
    if (must_fail) CHECK(error != "(accepted)");
    if (error == "(accepted)") return;
    CHECK_THAT(error, Contains(where + expr + "\": "));
    CHECK_THAT(error, !Contains("Internal error"));
    CHECK(error.size() > where.size() + expr.size() + 12);  // a reason follows the expression
  };
  for (const std::string bad :
       {"v++", "v--", "-", "+", "v+++x", "v---x", "++v", "--v", "v+", "v*", "*v", "v^", "(v", "v)", "((v)",
        "v)(", "()", "x ? v", "x ? v :", "? v : x", "x : v", "v,", ",v", "v,,x", "sin()", "sin(v,x)",
        "min()", "v x", "1 2", "sin", "sin v", "1e", "!", "!v", "v!", "$", "_", "v;x", "v # x", "x ?? v",
        "&&v", "v&&", "v||", "v <", "< v", "v ==", "v !=", "v >= ", "x ? : v", "v ^^ 2", "v**2", "1..2",
        "v(1)", "2(v)"}) {
    check(bad, true);
  }
  const std::vector<std::string> tokens{"v",  "x", "1",  "2.5", "+",  "-",  "*",    "/",    "^",  "(",  ")",
                                        "?",  ":", ",",  "&&",  "||", "<",  "<=",   "==",   "!=", "++", "--",
                                        " ",  "e", "1e", "!",   "sin(", "min(", "_pi", "abs("};
  std::mt19937 engine(20261125);  // its output sequence is fixed by the standard
  for (int i = 0; i < 400; ++i) {
    std::string expr;
    const int length = 1 + static_cast<int>(engine() % 6);
    for (int t = 0; t < length; ++t) expr += tokens[engine() % tokens.size()];
    if (expr.find_first_not_of(' ') == std::string::npos) continue;
    check(expr, false);
  }
}


}  // namespace

// The driven cart of docs/model-files.md: a measured input u in φ, a guard parameter w in the guard,
// the projection and the sets, only x measured.
const char* kCart = R"toml(name = "driven-cart"
states = ["x", "v"]
measured = ["x"]
inputs = ["u"]
input_defaults = { u = "0.1*sin(3*t)" }
alpha = [
  { name = "alpha_x", value = 1.0, known = true },
  { name = "k", value = 2.0, description = "stiffness", bounds = [0.0, 10.0] },
  { name = "G", value = 1.0, description = "input gain" },
]
beta = [
  { name = "beta_x", value = 1.0, known = true },
  { name = "e", value = 0.5, description = "restitution", bounds = [0.0, 1.0] },
]
guard_params = [
  { name = "w", value = 1.0, description = "wall position", bounds = [0.5, 2.0] },
]
[flow]
phi = [["v", 0, 0], [0, "-x", "u"]]
rows = ["v"]
[jump]
psi = [["x", 0], [0, "-v"]]
rows = ["v"]
[[guard]]
name = "wall"
h = "x - w"
direction = "rising"
project = { x = "w" }
[sets]
C = "x <= w"
D = "x >= w && v >= 0"
[defaults]
x0 = [0.0, 1.5]
t_end = 10.0
dt = 1e-3
)toml";

TEST_CASE("a model file with measured states, an input and a guard parameter loads", "[model_file]") {
  const Model m = ParseModelText(kCart, "cart.toml");
  const ModelSpec& s = m.spec();
  REQUIRE(s.measured == std::vector<int>{0});
  REQUIRE(MeasuredIndices(m) == std::vector<int>{0});
  REQUIRE(s.inputs == std::vector<std::string>{"u"});
  REQUIRE(s.input_defaults == std::vector<std::string>{"0.1*sin(3*t)"});
  REQUIRE(m.gamma_size() == 1);
  REQUIRE(m.gamma()[0] == 1.0);
  REQUIRE(UnknownNames(s.guard_params) == std::vector<std::string>{"w"});
  REQUIRE(s.alpha[1].lower == 0.0);
  REQUIRE(s.alpha[1].upper == 10.0);
  REQUIRE(std::isinf(s.alpha[2].lower));
  REQUIRE(s.guard_params[0].upper == 2.0);
}

TEST_CASE("a model file evaluates at the context's input and guard parameters", "[model_file]") {
  Model m = ParseModelText(kCart, "cart.toml");
  const double u = 0.3, gamma = 2.0;
  const Context ctx{.t = 0.7, .u = &u, .gamma = &gamma};
  Vec x(2);
  x << 0.5, -0.2;
  Mat phi(2, 3);
  m.Phi(x, phi, ctx);
  Mat exact(2, 3);
  exact << -0.2, 0, 0,  //
      0, -0.5, 0.3;
  CHECK(phi == exact);
  Vec f(2);
  m.Flow(x, m.alpha(), f, ctx);
  CHECK(f[0] == -0.2);
  CHECK(f[1] == -2.0 * 0.5 + 1.0 * 0.3);
  Vec h(1);
  m.Guards(x, h, ctx);
  CHECK(h[0] == 0.5 - 2.0);
  const Context own{.t = 0.0, .u = &u};  // γ nullptr: the model's own w = 1
  m.Guards(x, h, own);
  CHECK(h[0] == 0.5 - 1.0);
  CHECK(m.InFlowSet(x, ctx));
  CHECK_FALSE(m.InJumpSet(x, ctx));
  Vec beyond(2);
  beyond << 1.5, 0.1;  // beyond the own wall at 1, inside C for the wall at 2
  CHECK(m.InJumpSet(beyond, own));
  CHECK_FALSE(m.InJumpSet(beyond, ctx));
  CHECK(m.InFlowSet(beyond, ctx));
  Vec onto = beyond;
  m.ProjectOntoGuard(0, onto, ctx);
  CHECK(onto[0] == 2.0);
  CHECK(onto[1] == 0.1);
  Mat dh(1, 1);
  m.GuardGammaJacobian(x, ctx, dh);
  CHECK(std::abs(dh(0, 0) + 1.0) <= 1e-9);
  // SetParameter moves the model's own wall.
  m.SetParameter("w", 1.25);
  CHECK(m.gamma()[0] == 1.25);
  m.Guards(x, h, own);
  CHECK(h[0] == 0.5 - 1.25);
  // Without u: a programming error, named.
  CHECK_THROWS_AS(m.Guards(x, h), std::logic_error);
  CHECK_THROWS_WITH(m.Phi(x, phi, Context{}), Catch::Matchers::Contains("must be evaluated with Context::u"));
}

TEST_CASE("a guard parameter alone: the x-only forms use the model's own, and the default trajectory hits it",
          "[model_file]") {
  std::string text = Replace(kCart, "measured = [\"x\"]\ninputs = [\"u\"]\ninput_defaults = { u = \"0.1*sin(3*t)\" }\n", "");
  text = Replace(text, "[0, \"-x\", \"u\"]", "[0, \"-x\", 1]");
  Model m = ParseModelText(text, "wall.toml");  // simulates the default trajectory: the guard at w fires
  Vec x(2);
  x << 0.5, -0.2;
  Vec h(1);
  m.Guards(x, h);
  CHECK(h[0] == 0.5 - 1.0);
  m.SetParameter("w=0.75");
  m.Guards(x, h);
  CHECK(h[0] == 0.5 - 0.75);
  CHECK_THROWS_WITH(m.SetParameter("w=3"), Catch::Matchers::Contains("outside its bounds [0.5, 2]"));
  CHECK(MeasuredIndices(m) == std::vector<int>{0, 1});
}

TEST_CASE("bad measured, inputs, guard parameters and bounds are refused by name", "[model_file]") {
  using Catch::Matchers::Contains;
  auto error = [](const std::string& from, const std::string& to) {
    try {
      ParseModelText(Replace(kCart, from, to), "cart.toml");
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("(loaded)");
  };
  CHECK_THAT(error("measured = [\"x\"]", "measured = [\"y\"]"),
             Contains("cart.toml:3: measured[0]: unknown state 'y' (known: x, v)"));
  CHECK_THAT(error("measured = [\"x\"]", "measured = [\"x\", \"x\"]"), Contains("cart.toml:3: measured[1]"));
  CHECK_THAT(error("measured = [\"x\"]", "measured = []"), Contains("cart.toml:3: measured"));
  CHECK_THAT(error("inputs = [\"u\"]", "inputs = [\"u\", \"q\"]"),
             Contains("cart.toml:4: inputs[1]: input 'q' is used in no expression"));
  CHECK_THAT(error("inputs = [\"u\"]", "inputs = [\"u\", \"v\"]"),
             Contains("cart.toml:4: inputs[1]: 'v' is already the name of a state"));
  CHECK_THAT(error("inputs = [\"u\"]", "inputs = [\"u\", \"sin\"]"),
             Contains("cart.toml:4: inputs[1]: 'sin' is a built-in name"));
  CHECK_THAT(error("inputs = [\"u\"]", "inputs = [\"u\", \"t\"]"),
             Contains("cart.toml:4: inputs[1]: 't' is a built-in name"));
  CHECK_THAT(error("{ u = \"0.1*sin(3*t)\" }", "{ u = \"0.1*sin(3*x)\" }"),
             Contains("cart.toml:5: input_defaults.u: \"0.1*sin(3*x)\": unknown symbol \"x\" (the variables: time t)"));
  CHECK_THAT(error("{ u = \"0.1*sin(3*t)\" }", "{ z = \"1\" }"),
             Contains("cart.toml:5: input_defaults.z: unknown input 'z'"));
  CHECK_THAT(error("bounds = [0.5, 2.0] },", "bounds = [0.5, 2.0] },\n  { name = \"c\", value = 0.0 },"),
             Contains("cart.toml:17: guard_params[1].name: guard parameter 'c' is used in no expression"));
  CHECK_THAT(error("name = \"w\", value = 1.0,", "name = \"k\", value = 1.0,"),
             Contains("guard_params[0].name: 'k' is already the name of a state, a parameter or an input"));
  CHECK_THAT(error("bounds = [0.5, 2.0]", "bounds = [1.5, 2.0]"),
             Contains("cart.toml:16: guard_params[0].bounds: [1.5, 2] excludes the value 1 of 'w'"));
  CHECK_THAT(error("bounds = [0.0, 10.0]", "bounds = [10.0, 0.0]"),
             Contains("cart.toml:8: alpha[1].bounds: [10, 0]: lower must be below upper"));
  CHECK_THAT(error("bounds = [0.0, 1.0]", "bounds = [0.0]"),
             Contains("cart.toml:13: beta[1].bounds: has 1 entries, expected 2"));
  CHECK_THAT(error("[0, \"-x\", \"u\"]", "[0, \"-x\", \"u*q\"]"),
             Contains("unknown symbol \"q\" (the variables: states x, v; inputs u; guard parameters w; time t)"));
}
TEST_CASE("a guard in an input alone (no state) is accepted and evaluates at the context's input", "[model_file]") {
  std::string text = Replace(kCart, "h = \"x - w\"", "h = \"u - w/10 + G*0\"");
  text = Replace(text, "project = { x = \"w\" }\n", "");
  const Model m = ParseModelFile(text, "cart.toml").model;
  const double u = 0.3;
  Vec h(1);
  m.Guards(Vec::Zero(2), h, Context{.t = 1.0, .u = &u});
  CHECK(h[0] == 0.3 - 0.1);
}

}  // namespace hysid
