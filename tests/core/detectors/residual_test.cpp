// The tuning-free residual detector, sub-sample jump localisation and the second pass,
// against the simulator's ground truth. Nothing here is tuned per system, δt or noise level: every
// run uses the default false-alarm probability (DetectorSettings::false_alarm = 1e-8) unless the
// test is about that probability.
#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "core/builtin/bouncing_ball.hpp"
#include "core/builtin/impact_msd.hpp"
#include "core/builtin/impact_pendulum.hpp"
#include "core/detectors/detector.hpp"
#include "core/detectors/residual.hpp"
#include "core/identify/identifier.hpp"
#include "core/identify/localize.hpp"
#include "core/identify/metrics.hpp"
#include "core/model/regression.hpp"
#include "core/stats/quantiles.hpp"
#include "sim/measurement.hpp"
#include "sim/simulator.hpp"

namespace hysid {
namespace {

IdentifierSettings Residual() {
  IdentifierSettings s;
  s.detector.kind = ParseKind<DetectorKind>("residual");
  s.sets = false;
  return s;
}

struct Run {
  Trajectory traj;
  IdentifyResult result;
  Confusion confusion;
  ParameterErrors errors;
};

Run Identified(const Model& model, const Vec& x0, double t_end, double dt, double sigma, std::uint64_t seed,
               const IdentifierSettings& settings) {
  Run r;
  r.traj = Simulate(model, x0, SampleGrid{t_end, dt});
  REQUIRE(r.traj.status.completed());
  const Mat y = AddMeasurementNoise(r.traj.x, Vec::Constant(model.state_size(), sigma), NoiseKey{seed, 0});
  r.result = Identify(model, y, dt, settings);
  r.confusion = CompareJumps(r.traj.j, r.result.gamma);
  r.errors = CompareParameters(model, r.result.alpha_hat, r.result.beta_hat);
  return r;
}

TEST_CASE("quantiles match closed forms", "[residual]") {
  CHECK(NormalUpperQuantile(0.025) == Approx(1.959963984540054).epsilon(1e-12));
  CHECK(NormalUpperQuantile(5e-7) == Approx(4.891638475698358).epsilon(1e-10));
  for (double p : {0.1, 1e-3, 5e-7}) {
    // ν = 1 (Cauchy): t = tan(π(1/2 − p)); ν = 2: t = (1 − 2p)/√(2p(1 − p)).
    CHECK(StudentUpperQuantile(p, 1) == Approx(std::tan(std::numbers::pi * (0.5 - p))).epsilon(1e-9));
    CHECK(StudentUpperQuantile(p, 2) == Approx((1 - 2 * p) / std::sqrt(2 * p * (1 - p))).epsilon(1e-9));
  }
  // Large ν tends to the normal quantile.
  CHECK(StudentUpperQuantile(1e-3, 1e6) == Approx(NormalUpperQuantile(1e-3)).epsilon(1e-5));
  CHECK_THROWS_AS(StudentUpperQuantile(0.0, 3), std::invalid_argument);
  CHECK_THROWS_AS(StudentUpperQuantile(0.1, 0.5), std::invalid_argument);
}

// The first tested sample (no scale yet, no covariance): z² = ρ²/(V + ε²) with V the noise propagated
// through the flow Jacobian, V = Σ_j v_j(ξ(t))·a_j² + v_j(ξ(t−δt))·b_j², a = e_r − (δt/2)J_r(ξ(t)),
// b = e_r + (δt/2)J_r(ξ(t−δt)), v_j(x) = σ_j² + (data_rtol·|x_j| + data_atol)², against the same sum
// written here, for a constant (§5) and a state-dependent (pendulum) Jacobian, with σ alone, σ and the
// data accuracy, and the data accuracy alone.
TEST_CASE("residual detector: the propagated noise variance of a known sigma", "[residual]") {
  for (const Model& model : {Model{ImpactMsd{}}, Model{ImpactPendulum{}}}) {
    const RegressionLayout layout = RegressionLayout::Flow(model);
    REQUIRE(layout.rows.size() == 1u);
    const int r = layout.rows[0];
    const auto n = static_cast<Eigen::Index>(model.state_size());
    const auto m = static_cast<Eigen::Index>(layout.unknown.size());
    const double dt = 0.01;
    Vec prev(n), cur(n), sigma(n);
    for (Eigen::Index j = 0; j < n; ++j) {
      prev[j] = 0.3 + 0.7 * static_cast<double>(j);
      cur[j] = prev[j] - 0.05 * static_cast<double>(j + 1);
      sigma[j] = 0.02 * static_cast<double>(j + 1);
    }
    const Vec alpha = model.alpha();
    Mat phi(1, m);
    for (Eigen::Index k = 0; k < m; ++k) phi(0, k) = 0.1 * static_cast<double>(k + 1);
    Vec y(1);
    y << 0.37;
    double rho = y[0];
    for (Eigen::Index k = 0; k < m; ++k)
      rho -= phi(0, k) * alpha[layout.unknown[static_cast<std::size_t>(k)]];
    Mat jac_cur(n, n), jac_prev(n, n);
    model.FlowJacobian(cur, alpha, jac_cur);
    model.FlowJacobian(prev, alpha, jac_prev);
    struct Accuracy {
      bool sigma;
      double rtol, atol;
    };
    for (const Accuracy acc :
         {Accuracy{true, 0.0, 0.0}, Accuracy{true, 1e-3, 1e-4}, Accuracy{false, 1e-3, 1e-4}}) {
      INFO(model.name() << " sigma " << acc.sigma << " rtol " << acc.rtol);
      const auto var = [&](Eigen::Index j, double x) {
        const double d = acc.rtol * std::abs(x) + acc.atol;
        return (acc.sigma ? sigma[j] * sigma[j] : 0.0) + d * d;
      };
      double v = 0.0;
      for (Eigen::Index j = 0; j < n; ++j) {
        const double unit = j == r ? 1.0 : 0.0;
        const double a = unit - 0.5 * dt * jac_cur(r, j), b = unit + 0.5 * dt * jac_prev(r, j);
        v += var(j, cur[j]) * a * a + var(j, prev[j]) * b * b;
      }
      DetectorSettings ds;
      ds.kind = DetectorKind::kResidual;
      const auto detector = MakeDetector(ds, model);
      const SampleContext c{.model = &model,
                            .dt = dt,
                            .prev = ConstVecMap(prev.data(), n),
                            .cur = ConstVecMap(cur.data(), n),
                            .flow_phi = ConstMatMap(phi.data(), 1, m),
                            .flow_y = ConstVecMap(y.data(), 1),
                            .alpha_hat = ConstVecMap(alpha.data(), alpha.size()),
                            .flow_updates = m,
                            .sigma = acc.sigma ? &sigma : nullptr,
                            .data_rtol = acc.rtol,
                            .data_atol = acc.atol};
      const Decision d = detector->Classify(c);
      CHECK(d.statistic * d.statistic == Approx(rho * rho / v).epsilon(1e-12));
    }
  }
}

TEST_CASE("residual detector settings errors name the field", "[residual]") {
  const Model model{ImpactMsd{}};
  DetectorSettings s;
  s.kind = DetectorKind::kResidual;
  s.false_alarm = 0.0;
  CHECK_THROWS_WITH(MakeDetector(s, model), Catch::Contains("false_alarm = 0"));
  s.false_alarm = 0.7;
  CHECK_THROWS_WITH(MakeDetector(s, model), Catch::Contains("false_alarm"));
  s.false_alarm = 1e-6;
  CHECK(MakeDetector(s, model)->name() == "residual");
  CHECK_THROWS_WITH(ParseKind<DetectorKind>("residuals"), Catch::Contains("residual"));
}

TEST_CASE("§5 at dt = 5 ms, sigma = 0: all 14 jumps, no false ones", "[residual]") {
  // The paper's detector with r = 220 finds none of these (r tuned for 0.5 ms).
  const Model model{ImpactMsd{}};
  const Run r = Identified(model, DefaultState(model), 20.0, 5e-3, 0.0, 1, Residual());
  CHECK(r.traj.jumps.size() == 14);
  CHECK(r.confusion.tp == 14);
  CHECK(r.confusion.fn == 0);
  CHECK(r.confusion.fp == 0);
  IdentifierSettings paper;
  paper.sets = false;
  const IdentifyResult p = Identify(model, r.traj.x, 5e-3, paper);
  CHECK(CompareJumps(r.traj.j, p.gamma).tp == 0);
}

TEST_CASE("noise-free §5 with every estimator: the data accuracy keeps gtls from false jumps",
          "[residual][data-accuracy]") {
  // gtls fits the noise-free flow to the last digits, so its residuals are the simulator's
  // step-to-step error, which grows after every re-initialisation at a jump. Told the simulator's
  // tolerances, the detector flags none of it; without them it does.
  const Model model{ImpactMsd{}};
  for (const char* estimator : {"rls", "gtls", "frisch"}) {
    IdentifierSettings s = Residual();
    s.flow_estimator.kind = s.jump_estimator.kind = ParseKind<EstimatorKind>(estimator);
    s.data_rtol = SimOptions{}.rtol;
    s.data_atol = SimOptions{}.atol;
    const Run r = Identified(model, DefaultState(model), 20.0, 5e-4, 0.0, 1, s);
    INFO(estimator << ": FP " << r.confusion.fp << " FN " << r.confusion.fn);
    CHECK(r.confusion.tp == 14);
    CHECK(r.confusion.fn == 0);
    CHECK(r.confusion.fp == 0);
    CHECK(r.errors.e_alpha < 1e-6);
  }
  IdentifierSettings exact = Residual();
  exact.flow_estimator.kind = exact.jump_estimator.kind = ParseKind<EstimatorKind>("gtls");
  const Run r = Identified(model, DefaultState(model), 20.0, 5e-4, 0.0, 1, exact);
  CHECK(r.confusion.fp > 0);
  exact.data_rtol = -1e-12;
  CHECK_THROWS_WITH(Identifier(model, 5e-4, exact), Catch::Contains("data_rtol = -1e-12"));
}

TEST_CASE("§5 at dt = 0.1 ms, sigma = 0.25: all jumps, at most 1 false one", "[residual]") {
  const Model model{ImpactMsd{}};
  for (bool known_sigma : {false, true}) {
    IdentifierSettings s = Residual();
    if (known_sigma) s.sigma = Vec::Constant(2, 0.25);
    const Run r = Identified(model, DefaultState(model), 20.0, 1e-4, 0.25, 1, s);
    INFO("sigma known " << known_sigma << ": FP " << r.confusion.fp << " FN " << r.confusion.fn);
    CHECK(r.confusion.fp <= 1);
    CHECK(r.confusion.tp == 14);
  }
}

TEST_CASE("the false-alarm probability is what the test delivers on flow samples", "[residual]") {
  // On §5 with σ = 0.25 at δt = 0.1 ms the flow residuals are Gaussian; with p = 1e-2 the false
  // alarms among ~200000 flow samples are ≈ 2000.
  const Model model{ImpactMsd{}};
  IdentifierSettings s = Residual();
  s.detector.false_alarm = 1e-2;
  const Run r = Identified(model, DefaultState(model), 20.0, 1e-4, 0.25, 2, s);
  const double flow = static_cast<double>(r.confusion.fp + r.confusion.tn);
  const double rate = static_cast<double>(r.confusion.fp) / flow;
  INFO("false-alarm rate " << rate);
  CHECK(rate > 0.7e-2);
  CHECK(rate < 1.3e-2);
  CHECK(r.confusion.tp == 14);
}

TEST_CASE("noise-free §5: localisation brings e_beta from ~5e-5 to <= 2e-7", "[residual][localize]") {
  const Model model{ImpactMsd{}};
  IdentifierSettings s = Residual();
  // The simulator's accuracy, as `hysid identify` reads it from the sidecar: without it the
  // O(δt²) trapezoid residuals of noise-free data are all the detector sees.
  s.data_rtol = s.data_atol = 1e-12;
  const Run plain = Identified(model, DefaultState(model), 20.0, 5e-4, 0.0, 1, s);
  s.localize = true;
  const Run located = Identified(model, DefaultState(model), 20.0, 5e-4, 0.0, 1, s);
  INFO("e_beta without " << plain.errors.e_beta << ", with " << located.errors.e_beta);
  CHECK(plain.errors.e_beta > 1e-5);
  CHECK(located.result.jumps_localized == 14);
  CHECK(located.confusion.tp == 14);
  CHECK(located.confusion.fp == 0);
  // What is left is the prior ridge of the 14-row jump regression (P0 = 1e8·diag(1/g²), g the
  // RMS of each ψ column over the run): 1e-7 (1.4e-11 with --jump-p0 1e12).
  CHECK(located.errors.e_beta <= 2e-7);
  CHECK(located.errors.e_alpha <= 1e-5);
}

TEST_CASE("the localiser finds the simulator's jump instants", "[localize]") {
  const Model model{ImpactMsd{}};
  const double dt = 5e-3;
  const Trajectory traj = Simulate(model, DefaultState(model), SampleGrid{20.0, dt});
  JumpLocalizer localizer(model);
  REQUIRE(localizer.has_known_rows());
  long checked = 0;
  for (const JumpRecord& jr : traj.jumps) {
    const auto k = static_cast<Eigen::Index>(std::ceil(jr.t / dt - 1e-12));
    JumpLocation loc;
    REQUIRE(localizer.Locate(traj.x.col(k - 1), traj.x.col(k), dt, model.alpha(), &loc));
    const double s = (static_cast<double>(k) - 1.0 + loc.fraction) * dt;
    CHECK(std::abs(s - jr.t) <= 1e-9 * dt);
    CHECK((loc.pre - jr.pre).norm() <= 1e-8 * jr.pre.norm());
    CHECK((loc.post - jr.post).norm() <= 1e-8 * jr.post.norm());
    ++checked;
  }
  CHECK(checked == 14);
  // Without a known jump row there is nothing to match: not located.
  const Model ball{BouncingBall{}};
  JumpLocalizer on_ball(ball);
  JumpLocation loc;
  Vec a(2), b(2);
  a << 0.1, 1.0;
  b << 0.1, 1.0;  // same state at both ends: no sign change on h
  CHECK_FALSE(on_ball.Locate(a, b, 1e-3, ball.alpha(), &loc));
}

TEST_CASE("bouncing ball and impact pendulum: misclassification <= 1e-4, several seeds", "[residual]") {
  const Model ball{BouncingBall{}};        // h0 = 1, λ = 0.8: 6 bounces in 3 s (Zeno at 4.06 s)
  const Model pendulum{ImpactPendulum{}};  // 20 impacts in 20 s
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    for (double sigma : {0.0, 0.01}) {
      const Run b = Identified(ball, DefaultState(ball), 3.0, 2e-4, sigma, seed, Residual());
      INFO("ball seed " << seed << " sigma " << sigma << ": FP " << b.confusion.fp << " FN "
                        << b.confusion.fn);
      CHECK(b.confusion.misclassification() <= 1e-4);
      CHECK(b.confusion.tp == 6);
      const Run p = Identified(pendulum, DefaultState(pendulum), 20.0, 1e-3, sigma, seed, Residual());
      INFO("pendulum seed " << seed << " sigma " << sigma << ": FP " << p.confusion.fp << " FN "
                            << p.confusion.fn);
      CHECK(p.confusion.misclassification() <= 1e-4);
      CHECK(p.confusion.tp == 20);
      if (sigma == 0.0) break;  // noise-free runs do not depend on the seed
    }
  }
}

TEST_CASE("warm-up: no burst of false jumps while the scale starts", "[residual][warm-up]") {
  // Robustness map, σ = 0.02, δt = 1 ms, p = 1e-8, noise key (2020, 13029): with the first
  // residuals clipped like later ones, the scale stayed below the residuals of the still poor α̂;
  // samples 6–25 were flagged, α̂ (not updated on them) stayed poor: 15 false jumps. Its neighbours
  // in the same cell had none.
  const Model model{ImpactMsd{}};
  const Trajectory traj = Simulate(model, DefaultState(model), SampleGrid{20.0, 1e-3});
  REQUIRE(traj.status.completed());
  IdentifierSettings s = Residual();
  s.detector.false_alarm = 1e-8;
  s.data_rtol = SimOptions{}.rtol;
  s.data_atol = SimOptions{}.atol;
  for (std::uint64_t unit = 13020; unit <= 13029; ++unit) {
    const Mat y = AddMeasurementNoise(traj.x, Vec::Constant(2, 0.02), NoiseKey{2020, unit});
    const Confusion c = CompareJumps(traj.j, Identify(model, y, 1e-3, s).gamma);
    INFO("unit " << unit << ": FP " << c.fp << " FN " << c.fn);
    CHECK(c.fp == 0);
    CHECK(c.fn == 0);
  }
}

TEST_CASE("second pass recovers a jump missed during the warm-up", "[residual][second-pass]") {
  // ξ0 = (0.004, −10): the wall is hit 0.4 ms in, inside the first sample interval, before α̂
  // exists; the first pass must call it flow, the second pass (final α̂) finds it.
  const Model model{ImpactMsd{}};
  Vec x0(2);
  x0 << 0.004, -10.0;
  IdentifierSettings s = Residual();
  s.second_pass = true;
  s.localize = true;
  const Run r = Identified(model, x0, 20.0, 5e-4, 0.0, 1, s);
  REQUIRE(r.result.second_pass);
  const Confusion first = CompareJumps(r.traj.j, r.result.first_pass_gamma);
  CHECK(first.fn == 1);
  CHECK(r.confusion.fn == 0);
  CHECK(r.confusion.fp == 0);
  CHECK(r.result.reclassified_to_jump == 1);
  CHECK(r.result.reclassified_to_flow == 0);
  CHECK(r.result.jumps_detected == static_cast<long>(r.traj.jumps.size()));
  const ParameterErrors e1 =
      CompareParameters(model, r.result.first_pass_alpha_hat, r.result.first_pass_beta_hat);
  INFO("e_beta first pass " << e1.e_beta << ", second " << r.errors.e_beta);
  CHECK(r.errors.e_beta < e1.e_beta);
}

TEST_CASE("forgetting: the residual detector keeps working with a forgetting RLS", "[residual]") {
  const Model model{ImpactMsd{}};
  IdentifierSettings s = Residual();
  s.flow_estimator.forgetting = 0.9995;
  const Run r = Identified(model, DefaultState(model), 20.0, 5e-4, 0.05, 4, s);
  CHECK(r.confusion.tp == 14);
  CHECK(r.confusion.fp <= 1);
  CHECK(r.errors.rel_alpha < 0.05);
}

}  // namespace
}  // namespace hysid

namespace hysid {
namespace {

TEST_CASE("FlagsWith: another false_alarm with this detector's state decides as a detector of that "
          "false_alarm - ThresholdsBelow orders them",
          "[residual][twins]") {
  const Model model{ImpactMsd{}};
  const Trajectory truth = Simulate(model, DefaultState(model), SampleGrid{20.0, 1e-3});
  REQUIRE(truth.status.completed());
  const Mat y = AddMeasurementNoise(truth.x, Vec::Constant(2, 0.05), NoiseKey{4, 0});
  DetectorSettings often, rarely;
  often.kind = rarely.kind = DetectorKind::kResidual;
  often.false_alarm = 0.05;
  rarely.false_alarm = 1e-4;
  ResidualDetector a(often, model), b(rarely, model);
  CHECK(a.ThresholdsBelow(b));
  CHECK_FALSE(b.ThresholdsBelow(a));
  RegressionBuilder builder(model);
  Mat phi(1, 2);
  Vec row(1);
  const Vec alpha = model.alpha();  // α̂ held at the truth: both detectors see the same state
  long flagged = 0, differ = 0;
  for (Eigen::Index k = 1; k < y.cols(); ++k) {
    builder.Flow(y.col(k - 1), y.col(k), truth.dt, phi, row);
    const SampleContext c{.model = &model,
                          .dt = truth.dt,
                          .prev = ConstVecMap(y.col(k - 1).data(), 2),
                          .cur = ConstVecMap(y.col(k).data(), 2),
                          .flow_phi = ConstMatMap(phi.data(), 1, 2),
                          .flow_y = ConstVecMap(row.data(), 1),
                          .alpha_hat = ConstVecMap(alpha.data(), alpha.size()),
                          .flow_updates = 10};
    const Decision da = a.Classify(c);
    a.Observe(c, da);
    const Decision db = b.Classify(c);
    b.Observe(c, db);
    CHECK(da.statistic == db.statistic);  // the same learned state
    if (!da.gamma) {
      CHECK(!db.gamma);
      continue;
    }
    ++flagged;
    differ += db.gamma ? 0 : 1;
    CHECK(a.FlagsWith(b) == db.gamma);
  }
  CHECK(flagged > 50);
  CHECK(differ > 10);  // both outcomes asked
  CHECK(differ < flagged);
}

}  // namespace
}  // namespace hysid
