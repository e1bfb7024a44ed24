// Sensitivities with unknown guard parameters γ: a spring–mass hitting a wall at x = w
// (examples/wall/wall.toml). Every column of S, the γ column included, against central differences
// of whole simulated trajectories, in plain and matched mode; ∂t_j/∂θ against the differences of the
// jump times; the first jump's ∂t/∂w against its closed form; and γ acting in φ and ψ as well.
#include <catch2/catch.hpp>

#include <cmath>
#include <string>

#include "core/model_file/model_file.hpp"
#include "sim/sensitivity/crlb.hpp"

namespace hysid {
namespace {

// The example's model with the true wall at w = 1 (the file's 0.9 is a start).
Model Wall() {
  Model model = ReadModelFile("examples/wall/wall.toml").model;
  model.SetParameter("w", 1.0);
  return model;
}

Vec DefaultX0(const Model& m) {
  const auto& v = m.spec().default_x0;
  return Eigen::Map<const Vec>(v.data(), static_cast<Eigen::Index>(v.size()));
}

SensitivityOptions StatesOnly() {
  SensitivityOptions o;
  o.sensitivities = false;
  return o;
}

// Largest |S_k − central difference| over every column, relative to the column's largest |S|, over
// samples whose segment agrees in the ± runs; `segments` empty: plain mode, else matched on them.
// Also the jump times' gradients (plain mode), relative to the largest |∂t_j/∂θ_i|.
struct Agreement {
  double states = 0.0, jump_times = 0.0;
};
Agreement CompareWithDifferences(const Model& model, const SampleGrid& grid,
                                 const std::vector<int>& segments) {
  const Unknowns u = Unknowns::Of(model);
  const HybridParameters nominal = HybridParameters::Of(model, DefaultX0(model));
  auto run = [&](const HybridParameters& p, const SensitivityOptions& o) {
    return segments.empty() ? SimulateSensitivities(model, p, u, grid, o)
                            : SimulateSensitivitiesMatched(model, p, u, grid, segments, o);
  };
  const SensitivityTrajectory s = run(nominal, {});
  REQUIRE(s.ok());
  const Vec theta = nominal.Theta(u);
  REQUIRE(theta.size() == s.parameters);
  Agreement worst;
  for (Eigen::Index i = 0; i < theta.size(); ++i) {
    const double h = 1e-5 * std::max(1.0, std::abs(theta[i]));
    Vec tp = theta, tm = theta;
    tp[i] += h;
    tm[i] -= h;
    const SensitivityTrajectory plus = run(nominal.WithTheta(u, tp), StatesOnly());
    const SensitivityTrajectory minus = run(nominal.WithTheta(u, tm), StatesOnly());
    REQUIRE(plus.ok());
    REQUIRE(minus.ok());
    double err = 0.0, scale = 0.0;
    long compared = 0;
    for (long k = 0; k < s.trajectory.size(); ++k) {
      const auto ku = static_cast<std::size_t>(k);
      scale = std::max(scale, s.S(k).col(i).cwiseAbs().maxCoeff());
      if (plus.trajectory.j[ku] != s.trajectory.j[ku] || minus.trajectory.j[ku] != s.trajectory.j[ku])
        continue;
      const Vec fd = (plus.trajectory.x.col(k) - minus.trajectory.x.col(k)) / (2 * h);
      err = std::max(err, (fd - s.S(k).col(i)).cwiseAbs().maxCoeff());
      ++compared;
    }
    CHECK(compared > s.trajectory.size() - 4 * static_cast<long>(s.trajectory.jumps.size()) - 4);
    UNSCOPED_INFO("column " << i << " (" << u.Names(model)[static_cast<std::size_t>(i)]
                            << "): " << err / scale);
    worst.states = std::max(worst.states, err / scale);
    if (!segments.empty()) continue;
    REQUIRE(plus.trajectory.jumps.size() == s.trajectory.jumps.size());
    REQUIRE(minus.trajectory.jumps.size() == s.trajectory.jumps.size());
    const double jscale = s.jump_time_gradients.row(i).cwiseAbs().maxCoeff();
    for (std::size_t j = 0; j < s.trajectory.jumps.size(); ++j) {
      const double fd = (plus.trajectory.jumps[j].t - minus.trajectory.jumps[j].t) / (2 * h);
      const double e = std::abs(fd - s.jump_time_gradients(i, static_cast<Eigen::Index>(j))) / jscale;
      worst.jump_times = std::max(worst.jump_times, e);
    }
  }
  return worst;
}

TEST_CASE("guard parameter: θ holds w, and S matches central differences in plain mode", "[sensitivity]") {
  const Model model = Wall();
  const Unknowns u = Unknowns::Of(model);
  REQUIRE(u.gamma == std::vector<int>{0});
  const std::vector<std::string> names = u.Names(model);
  CHECK(names == std::vector<std::string>{"k", "b", "lambda", "w", "x0[x]", "x0[v]"});
  const Agreement a = CompareWithDifferences(model, SampleGrid{8.0, 5e-4}, {});
  CHECK(a.states < 1e-5);
  CHECK(a.jump_times < 1e-5);
}

TEST_CASE("guard parameter: S matches central differences in matched mode, jumps moved", "[sensitivity]") {
  const Model model = Wall();
  const SampleGrid grid{8.0, 5e-4};
  const SensitivityTrajectory plain =
      SimulateSensitivities(model, HybridParameters::Of(model, DefaultX0(model)), Unknowns::Of(model), grid);
  REQUIRE(plain.ok());
  REQUIRE(plain.trajectory.jumps.size() >= 3);
  // The first detected jump 3 samples late, the second 3 early: those samples are read from the
  // continued flow of the neighbouring segment.
  std::vector<int> seg = plain.trajectory.j;
  const long k1 = std::lround(plain.trajectory.jumps[0].t / grid.dt);
  const long k2 = std::lround(plain.trajectory.jumps[1].t / grid.dt);
  for (long k = k1 - 3; k <= k1 + 3; ++k) seg[static_cast<std::size_t>(k)] = 0;
  for (long k = k2 - 3; k <= k2 + 3; ++k) seg[static_cast<std::size_t>(k)] = 2;
  CHECK(CompareWithDifferences(model, grid, seg).states < 1e-5);
}

TEST_CASE("guard parameter: the first impact's dt/dw and dv+/dw in closed form (no damping)",
          "[sensitivity]") {
  Model model = Wall();
  model.SetParameter("b", 0.0);
  // x = (v0/ω) sin ωt until x = w: t1 = asin(ω w / v0)/ω, ∂t1/∂w = 1/v(t1), v(t1) = v0 cos ω t1. After
  // the impact v+ = −λ v(t1), so ∂v+/∂w = −λ ∂v(t1)/∂w = −λ (−ω² w / v(t1)) (energy: v² = v0² − ω² x²).
  const double omega = 4.0, v0 = 10.0, w = 1.0, lambda = 0.95;
  const double t1 = std::asin(omega * w / v0) / omega, v1 = v0 * std::cos(omega * t1);
  const Unknowns u = Unknowns::Of(model);
  const SensitivityTrajectory s =
      SimulateSensitivities(model, HybridParameters::Of(model, DefaultX0(model)), u, SampleGrid{0.2, 1e-3});
  REQUIRE(s.ok());
  REQUIRE(s.trajectory.jumps.size() == 1);
  const Eigen::Index col_w = 3;
  CHECK(s.trajectory.jumps[0].t == Approx(t1).epsilon(1e-9));
  CHECK(s.jump_time_gradients(col_w, 0) == Approx(1.0 / v1).epsilon(1e-7));
  // Just after the impact: x+ = w (∂x+/∂w = 1 less the flow since), v+ as above.
  const long k = static_cast<long>(std::ceil(t1 / 1e-3));
  const double tau = k * 1e-3 - t1;  // time since the impact
  const Eigen::Vector2d post{w, -lambda * v1};
  // ∂ξ(t)/∂w after the impact: the flow's transition over τ applied to ∂ξ+/∂w − f⁺ ∂t1/∂w.
  Eigen::Matrix2d a;
  a << 0.0, 1.0, -omega * omega, 0.0;
  const Eigen::Vector2d f_plus = a * post;
  const Eigen::Vector2d dpost{1.0, -lambda * (-omega * omega * w / v1)};
  Eigen::Matrix2d phi;  // exp(aτ) for the undamped oscillator
  phi << std::cos(omega * tau), std::sin(omega * tau) / omega, -omega * std::sin(omega * tau),
      std::cos(omega * tau);
  const Eigen::Vector2d expected = phi * (dpost - f_plus / v1);
  CHECK(s.S(k)(0, col_w) == Approx(expected[0]).epsilon(1e-6));
  CHECK(s.S(k)(1, col_w) == Approx(expected[1]).epsilon(1e-6));
}

TEST_CASE("guard parameter acting in φ and ψ too: S matches central differences", "[sensitivity]") {
  // The spring's rest position at 0.2 w and a restitution scaled by w: γ in the flow, the guard, the
  // projection and the jump map.
  const std::string text = R"toml(
name = "wall-everywhere"
states = ["x", "v"]
alpha = [
  { name = "alpha_x", value = 1.0, known = true },
  { name = "k", value = 16.0 },
  { name = "b", value = 0.02 },
]
beta = [
  { name = "beta_x", value = 1.0, known = true },
  { name = "lambda", value = 0.95 },
]
guard_params = [ { name = "w", value = 1.0 } ]
[flow]
phi = [["v", 0, 0], [0, "-(x - 0.2*w)", "-v"]]
rows = ["v"]
[jump]
psi = [["x", 0], [0, "-v*w"]]
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
x0 = [0.0, 10.0]
t_end = 6.0
dt = 5e-4
)toml";
  const Model model = ParseModelFile(text, "wall-everywhere.toml").model;
  const Agreement a = CompareWithDifferences(model, SampleGrid{6.0, 5e-4}, {});
  CHECK(a.states < 1e-5);
  CHECK(a.jump_times < 1e-5);
}

TEST_CASE("a guard parameter no flow reads: its flow term is skipped and S still matches differences",
          "[sensitivity]") {
  // w in the flow and the guard, d in the guard alone (the wall at w·d): only w's ∂f/∂γ is computed.
  const std::string text = R"toml(
name = "wall-scaled"
states = ["x", "v"]
alpha = [
  { name = "alpha_x", value = 1.0, known = true },
  { name = "k", value = 16.0 },
]
beta = [
  { name = "beta_x", value = 1.0, known = true },
  { name = "lambda", value = 0.9 },
]
guard_params = [ { name = "w", value = 1.0 }, { name = "d", value = 0.9 } ]
[flow]
phi = [["v", 0], [0, "-(x - 0.2*w)"]]
rows = ["v"]
[jump]
psi = [["x", 0], [0, "-v"]]
rows = ["v"]
[[guard]]
name = "wall"
h = "x - w*d"
direction = "rising"
[sets]
C = "x <= w*d"
D = "x >= w*d && v >= 0"
[defaults]
x0 = [0.0, 4.0]
t_end = 4.0
dt = 5e-4
)toml";
  const Model model = ParseModelFile(text, "wall-scaled.toml").model;
  CHECK(model.flow_reads_gamma(0));
  CHECK_FALSE(model.flow_reads_gamma(1));
  const Agreement a = CompareWithDifferences(model, SampleGrid{4.0, 5e-4}, {});
  CHECK(a.states < 1e-5);
  CHECK(a.jump_times < 1e-5);
}

}  // namespace
}  // namespace hysid
