// The errors-in-variables estimators inside the identifier: the noise shapes it derives
// from σ and δt, the σ it estimates when none is given, and gtls / frisch end to end on §5 data.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>

#include "core/builtin/impact_msd.hpp"
#include "core/estimators/frisch.hpp"
#include "core/estimators/gtls.hpp"
#include "core/identify/identifier.hpp"
#include "core/identify/metrics.hpp"
#include "sim/measurement.hpp"
#include "sim/simulator.hpp"
#include "tests/testing/vec.hpp"

namespace hysid {
namespace {

using testing::V;

Mat Diag3(double a, double b, double c) {
  Mat m = Mat::Zero(3, 3);
  m.diagonal() << a, b, c;
  return m;
}

IdentifierSettings Named(const std::string& name) {
  IdentifierSettings s;
  s.sets = false;
  s.flow_estimator.kind = s.jump_estimator.kind = ParseKind<EstimatorKind>(name);
  return s;
}

TEST_CASE("WithNoiseShapes: impact-msd closed forms, sigma 0, user shapes, rls untouched",
          "[identify][eiv]") {
  const Model model{ImpactMsd{}};
  const double dt = 5e-4;
  const Vec x0 = V(20.0, 0.0);
  // Row v: z = [(δt/2)(−x_k − x_{k−1}), (δt/2)(−v_k − v_{k−1}), Δv]; jump z = [−v_{k−1}, 1, v_k].
  const IdentifierSettings gtls = WithNoiseShapes(model, dt, Named("gtls"), V(0.3, 0.6), x0);
  const Mat flow = Diag3(0.5 * dt * dt * 0.09, 0.5 * dt * dt * 0.36, 2.0 * 0.36);
  CHECK((gtls.flow_estimator.noise_shape - flow).norm() <= 1e-6 * flow.norm());
  CHECK((gtls.jump_estimator.noise_shape - Diag3(0.36, 0.0, 0.36)).norm() <= 1e-9);
  // frisch gets the same shapes (it uses the zero diagonal entry: μ's column is exact).
  const IdentifierSettings frisch = WithNoiseShapes(model, dt, Named("frisch"), V(0.3, 0.6), x0);
  CHECK(frisch.jump_estimator.noise_shape == gtls.jump_estimator.noise_shape);
  Identifier id(model, dt, frisch);
  const auto& jump = dynamic_cast<const Frisch&>(id.jump_estimator());
  CHECK(jump.noisy_columns() == std::vector<Eigen::Index>{0, 2});
  // σ = 0 (noise-free data): the shape of equal noise, σ = 1.
  const IdentifierSettings zero = WithNoiseShapes(model, dt, Named("gtls"), V(0.0, 0.0), x0);
  CHECK((zero.flow_estimator.noise_shape - Diag3(0.5 * dt * dt, 0.5 * dt * dt, 2.0)).norm() <= 1e-6);
  // σ = (0.3, 0): no noise reaches the jump regression (it only sees v) — least squares.
  const IdentifierSettings half = WithNoiseShapes(model, dt, Named("gtls"), V(0.3, 0.0), x0);
  CHECK(half.jump_estimator.noise_shape == Diag3(0.0, 0.0, 1.0));
  CHECK(half.flow_estimator.noise_shape(0, 0) > 0.0);
  // A shape given by the user is kept; rls gets none.
  IdentifierSettings user = Named("gtls");
  user.flow_estimator.noise_shape = Mat::Identity(3, 3);
  CHECK(WithNoiseShapes(model, dt, user, V(0.3, 0.6), x0).flow_estimator.noise_shape == Mat::Identity(3, 3));
  CHECK(WithNoiseShapes(model, dt, Named("rls"), V(0.3, 0.6), x0).flow_estimator.noise_shape.size() == 0);
  CHECK_THROWS_WITH(WithNoiseShapes(model, dt, Named("gtls"), Vec::Ones(3), x0),
                    Catch::Contains("sigma has 3 entries"));
  // The streaming Identifier derives them itself (σ given, else ones) at the model's x0.
  IdentifierSettings streaming = Named("gtls");
  streaming.sigma = V(0.3, 0.6);
  Identifier sid(model, dt, streaming);
  CHECK((dynamic_cast<const Gtls&>(sid.flow_estimator()).noise_shape() - flow).norm() <= 1e-6 * flow.norm());
}

TEST_CASE("Identify with gtls: sigma estimated from the data when not given, used as given otherwise",
          "[identify][eiv]") {
  const Model model{ImpactMsd{}};
  const Trajectory traj = Simulate(model, V(20.0, 0.0), SampleGrid{20.0, 5e-4});
  REQUIRE(traj.status.completed());
  const Vec sigma = V(0.1, 0.4);  // unequal: the ratio matters for C
  const Mat y = AddMeasurementNoise(traj.x, sigma, NoiseKey{11, 0});
  const IdentifyResult estimated = Identify(model, y, traj.dt, Named("gtls"));
  REQUIRE(estimated.noise_sigma_estimated);
  std::printf("[eiv] sigma (%.2f, %.2f): MAD estimate (%.4f, %.4f)\n", sigma[0], sigma[1],
              estimated.noise_sigma[0], estimated.noise_sigma[1]);
  CHECK(estimated.noise_sigma[0] == Approx(sigma[0]).epsilon(0.03));
  CHECK(estimated.noise_sigma[1] == Approx(sigma[1]).epsilon(0.03));
  const Mat expected = WithNoiseShapes(model, traj.dt, Named("gtls"), estimated.noise_sigma, V(20.0, 0.0))
                           .flow_estimator.noise_shape;
  CHECK((estimated.flow_noise_shape - expected).norm() <= 1e-6 * expected.norm());
  IdentifierSettings given = Named("gtls");
  given.sigma = sigma;
  const IdentifyResult known = Identify(model, y, traj.dt, given);
  CHECK_FALSE(known.noise_sigma_estimated);
  CHECK(known.noise_sigma == sigma);
  // C up to scale: the estimate differs from the given σ by ~1 %, so α̂ barely moves.
  CHECK((known.alpha_hat - estimated.alpha_hat).norm() <= 1e-2);
  CHECK(known.flow_status == EstimatorStatus::kOk);
  CHECK(Identify(model, y, traj.dt, Named("rls")).flow_noise_shape.size() == 0);
}

TEST_CASE("noise-free §5 with gtls and frisch: all 14 jumps, e_alpha < 1e-4", "[identify][eiv]") {
  const Model model{ImpactMsd{}};
  const Trajectory traj = Simulate(model, V(20.0, 0.0), SampleGrid{20.0, 5e-4});
  REQUIRE(traj.status.completed());
  for (const char* name : {"gtls", "frisch"}) {
    const IdentifyResult r = Identify(model, traj.x, traj.dt, Named(name));
    const Confusion c = CompareJumps(traj.j, r.gamma);
    const ParameterErrors e = CompareParameters(model, r.alpha_hat, r.beta_hat);
    INFO(name << ": alpha_hat " << r.alpha_hat.transpose() << ", beta_hat " << r.beta_hat.transpose());
    CHECK(c.tp == 14);
    CHECK(c.fp == 0);
    CHECK(e.e_alpha < 1e-4);
    CHECK(e.e_beta < 1e-3);
    CHECK(r.alpha_hat.allFinite());
    CHECK(r.beta_hat.allFinite());
  }
}

TEST_CASE("§5 at sigma 2 with the true jumps: RLS attenuates a as predicted, gtls does not",
          "[identify][eiv]") {
  // Flow row v: φ = (δt/2)(−x_k − x_{k−1}, −v_k − v_{k−1}); the regressor noise (δt/2)(e_k + e_{k−1})
  // has variance δt²σ²/2 against the signal δt²·E[x²], so plim â_LS ≈ a·E[x²]/(E[x²] + σ²/2)
  // (the small x–v correlation neglected). 100 seeds, oracle labels (no detector).
  const Model model{ImpactMsd{}};
  const Trajectory traj = Simulate(model, V(20.0, 0.0), SampleGrid{20.0, 5e-4});
  REQUIRE(traj.status.completed());
  const double sigma = 2.0;
  const double ex2 = traj.x.row(0).array().square().mean();
  const double predicted = 5.0 * ex2 / (ex2 + 0.5 * sigma * sigma);
  const int runs = 100;
  Vec ls(runs), gt(runs);
  RegressionBuilder builder(model);
  IdentifierSettings settings = WithNoiseShapes(model, traj.dt, Named("gtls"), V(sigma, sigma), V(20.0, 0.0));
  EstimatorSettings rls_settings;
  Mat phi(1, 2);
  Vec yf(1);
  for (int run = 0; run < runs; ++run) {
    const Mat y = AddMeasurementNoise(traj.x, V(sigma, sigma), NoiseKey{2024, std::uint64_t(run)});
    auto rls = MakeEstimator(rls_settings, Vec::Zero(2));
    auto gtls = MakeEstimator(settings.flow_estimator, Vec::Zero(2));
    for (long k = 1; k < y.cols(); ++k) {
      if (traj.j[std::size_t(k)] != traj.j[std::size_t(k - 1)]) continue;
      builder.Flow(y.col(k - 1), y.col(k), traj.dt, phi, yf);
      rls->Update(phi, yf);
      gtls->Update(phi, yf);
    }
    ls[run] = rls->estimate()[0];
    gt[run] = gtls->estimate()[0];
  }
  auto se = [&](const Vec& v) {
    return std::sqrt((v.array() - v.mean()).square().sum() / (runs - 1) / runs);
  };
  std::printf(
      "[eiv] §5 sigma 2, %d runs, true jumps: E[x^2] = %.2f, predicted RLS a^ %.4f; "
      "RLS %.4f +- %.4f, gtls %.4f +- %.4f (mean +- SE)\n",
      runs, ex2, predicted, ls.mean(), se(ls), gt.mean(), se(gt));
  CHECK(std::abs(ls.mean() - predicted) <= 3.0 * se(ls));
  CHECK(std::abs(ls.mean() - 5.0) >= 3.0 * se(ls));
  CHECK(std::abs(gt.mean() - 5.0) <= 3.0 * se(gt));
}

}  // namespace
}  // namespace hysid
