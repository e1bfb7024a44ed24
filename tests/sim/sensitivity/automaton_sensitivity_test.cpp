// Sensitivities of hybrid automata against central differences of whole simulated trajectories: the
// floor/ceiling ball (each map's own restitution, ∂/∂e_ceiling only through the ceiling's jumps) and
// the pump tank (mode switches by identity maps, f⁺ in the new mode, ∂/∂γ for h_lo and h_hi), with
// the jump times' gradients against the differences of the jump times.
#include <algorithm>
#include <cmath>

#include <catch2/catch.hpp>

#include "sim/sensitivity/sensitivity.hpp"
#include "tests/sim/automaton_models.hpp"

namespace hysid {
namespace {

struct Agreement {
  double states = 0.0, jump_times = 0.0;
  long compared = 0;
};

// Largest |S_k − central difference| per column relative to the column's largest |S| (samples whose
// segment is the same in the ± runs), and the same for ∂t_j/∂θ.
Agreement CompareWithDifferences(const Model& model, const Vec& x0, const SampleGrid& grid) {
  const Unknowns u = Unknowns::Of(model);
  const HybridParameters nominal = HybridParameters::Of(model, x0);
  SensitivityOptions states_only;
  states_only.sensitivities = false;
  const SensitivityTrajectory s = SimulateSensitivities(model, nominal, u, grid);
  REQUIRE(s.ok());
  const Vec theta = nominal.Theta(u);
  Agreement worst;
  for (Eigen::Index i = 0; i < theta.size(); ++i) {
    const double h = 1e-5 * std::max(1.0, std::abs(theta[i]));
    Vec tp = theta, tm = theta;
    tp[i] += h;
    tm[i] -= h;
    const SensitivityTrajectory plus = SimulateSensitivities(model, nominal.WithTheta(u, tp), u, grid, states_only);
    const SensitivityTrajectory minus = SimulateSensitivities(model, nominal.WithTheta(u, tm), u, grid, states_only);
    REQUIRE(plus.ok());
    REQUIRE(minus.ok());
    double err = 0.0, scale = 0.0;
    for (long k = 0; k < s.trajectory.size(); ++k) {
      const auto ku = static_cast<std::size_t>(k);
      scale = std::max(scale, s.S(k).col(i).cwiseAbs().maxCoeff());
      if (plus.trajectory.j[ku] != s.trajectory.j[ku] || minus.trajectory.j[ku] != s.trajectory.j[ku]) continue;
      const Vec fd = (plus.trajectory.x.col(k) - minus.trajectory.x.col(k)) / (2 * h);
      err = std::max(err, (fd - s.S(k).col(i)).cwiseAbs().maxCoeff());
      ++worst.compared;
    }
    UNSCOPED_INFO("column " << u.Names(model)[std::size_t(i)] << ": states " << err / scale);
    worst.states = std::max(worst.states, err / scale);
    REQUIRE(plus.trajectory.jumps.size() == s.trajectory.jumps.size());
    REQUIRE(minus.trajectory.jumps.size() == s.trajectory.jumps.size());
    const double jscale = std::max(1e-300, s.jump_time_gradients.row(i).cwiseAbs().maxCoeff());
    for (std::size_t j = 0; j < s.trajectory.jumps.size(); ++j) {
      const double fd = (plus.trajectory.jumps[j].t - minus.trajectory.jumps[j].t) / (2 * h);
      const double e = std::abs(fd - s.jump_time_gradients(i, static_cast<Eigen::Index>(j)));
      worst.jump_times = std::max(worst.jump_times, e / std::max(jscale, std::abs(fd)));
    }
  }
  return worst;
}

using testing::Of;

TEST_CASE("floor/ceiling ball: S and dt_j/dθ match central differences, each map on its own β",
          "[sensitivity]") {
  const Model model{testing::FloorCeiling{}};
  const Unknowns u = Unknowns::Of(model);
  REQUIRE(u.Names(model) == std::vector<std::string>{"g", "e_floor", "e_ceiling", "x0[h]", "x0[v]"});
  const Vec x0 = Of({0.5, 4.0});
  const SampleGrid grid{.t_end = 2.5, .dt = 1e-3};
  const Agreement a = CompareWithDifferences(model, x0, grid);
  CHECK(a.compared > 0);
  CHECK(a.states < 1e-5);
  CHECK(a.jump_times < 1e-5);
  // ∂ξ/∂e_ceiling is zero before the ceiling's impact and ∂v⁺/∂e_ceiling = −v⁻ just after it (the
  // impact's time does not move with e_ceiling).
  const SensitivityTrajectory s = SimulateSensitivities(model, HybridParameters::Of(model, x0), u, grid);
  REQUIRE(s.ok());
  REQUIRE(s.trajectory.jumps[0].map == 1);
  const JumpRecord& ceiling = s.trajectory.jumps[0];
  const long k = static_cast<long>(std::ceil(ceiling.t / grid.dt));
  CHECK(s.S(k - 1).col(2).cwiseAbs().maxCoeff() == 0.0);
  CHECK(s.jump_time_gradients(2, 0) == 0.0);
  CHECK(s.S(k)(1, 2) == Approx(-ceiling.pre(1)).epsilon(1e-9));
}

TEST_CASE("pump tank: S and dt_j/dθ match central differences across mode switches, γ included",
          "[sensitivity]") {
  const Model model{testing::PumpTank{}};
  const Unknowns u = Unknowns::Of(model);
  REQUIRE(u.Names(model) == std::vector<std::string>{"a", "P", "h_lo", "h_hi", "x0[h]"});
  const Agreement a = CompareWithDifferences(model, Of({1.5}), SampleGrid{.t_end = 12.0, .dt = 1e-2});
  CHECK(a.compared > 0);
  CHECK(a.states < 1e-5);
  CHECK(a.jump_times < 1e-5);
  // In closed form: the first pump-off (from h0 = 1.5 in mode on) is where h = h_hi, so
  // ∂t_s/∂h_hi = 1/h'(t_s⁻) = 1/(P − a√h_hi), and h_lo, not armed before it, does not move it.
  const SensitivityTrajectory s =
      SimulateSensitivities(model, HybridParameters::Of(model, Of({1.5})), u, SampleGrid{.t_end = 3.0, .dt = 1e-2});
  REQUIRE(s.ok());
  REQUIRE(s.trajectory.jumps.size() >= 1);
  CHECK(s.jump_time_gradients(3, 0) == Approx(1.0 / (1.0 - 0.5 * std::sqrt(2.0))).epsilon(1e-8));
  CHECK(s.jump_time_gradients(2, 0) == 0.0);  // h_lo does not arm in mode on
}

}  // namespace
}  // namespace hysid
