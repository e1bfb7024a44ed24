// Units do not matter: the same §5 trajectory with its state in other units (ξ·s, s = 1e-6, 1e6) or
// its time in other units (t·c with v/c, c = 1e-6, 1e6) gives the same estimates, recursive and
// refined: a, b and λ are dimensionless under a state scaling and stay equal; μ scales with the state
// (μ·s) or with the velocity (μ/c); under the time scaling a → a/c², b → b/c.
#include <catch2/catch.hpp>

#include <cmath>
#include <string>

#include "core/builtin/impact_msd.hpp"
#include "core/identify/identifier.hpp"
#include "sim/measurement.hpp"
#include "sim/refine/refine.hpp"

namespace hysid {
namespace {

struct Scaled {
  Mat y;
  double dt;
  Vec alpha_factor, beta_factor;  // estimate in the scaled units = factor × estimate in the original
};

// State × s (both components), or time × c with v × 1/c.
Scaled StateScaled(const Mat& y, double dt, double s) {
  return {s * y, dt, (Vec(3) << 1.0, 1.0, 1.0).finished(), (Vec(3) << 1.0, 1.0, s).finished()};
}
Scaled TimeScaled(const Mat& y, double dt, double c) {
  Mat z = y;
  z.row(1) /= c;
  return {z, dt * c, (Vec(3) << 1.0, 1.0 / (c * c), 1.0 / c).finished(), (Vec(3) << 1.0, 1.0, 1.0 / c).finished()};
}

IdentifierSettings Settings(const std::string& estimator) {
  IdentifierSettings s;
  s.sets = false;
  s.detector.kind = DetectorKind::kResidual;
  s.UseEstimator(ParseKind<EstimatorKind>(estimator));
  return s;
}

// |scaled / factor − original| ≤ tol·|original| per entry (the absolute margin for entries near 0).
void CheckScaled(const Vec& scaled, const Vec& original, const Vec& factor, double tol, double margin) {
  for (Eigen::Index i = 0; i < original.size(); ++i) {
    INFO("entry " << i << ": " << scaled[i] / factor[i] << " vs " << original[i]);
    CHECK(std::abs(scaled[i] / factor[i] - original[i]) <= tol * std::abs(original[i]) + margin);
  }
}

struct Run {
  Model model{ImpactMsd{}};
  SampleGrid grid{20.0, 5e-4};
  Mat y = AddMeasurementNoise(Simulate(model, (Vec(2) << 20.0, 0.0).finished(), grid).x,
                              Vec::Constant(2, 0.01), NoiseKey{.seed = 11, .stream = 0});
};

}  // namespace

TEST_CASE("the recursive estimate does not depend on the units of state and time", "[identify][scale]") {
  const Run run;
  for (const std::string estimator : {"rls", "gtls", "integral", "frisch"}) {
    const IdentifyResult base = Identify(run.model, run.y, run.grid.dt, Settings(estimator));
    REQUIRE(base.flow_status == EstimatorStatus::kOk);
    REQUIRE(base.jumps_detected == 14);
    for (const double f : {1e-6, 1e6}) {
      for (const bool time : {false, true}) {
        INFO(estimator << (time ? ": time x " : ": state x ") << f);
        const Scaled sc = time ? TimeScaled(run.y, run.grid.dt, f) : StateScaled(run.y, run.grid.dt, f);
        const IdentifyResult r = Identify(run.model, sc.y, sc.dt, Settings(estimator));
        CHECK(r.flow_status == base.flow_status);
        CHECK(r.jump_status == base.jump_status);
        CHECK(r.gamma == base.gamma);
        // μ̂ ≈ 0 (truth 0): compared with a margin of 1e-9 of its scale.
        CheckScaled(r.alpha_hat, base.alpha_hat, sc.alpha_factor, 1e-6, 0.0);
        CheckScaled(r.beta_hat, base.beta_hat, sc.beta_factor, 1e-6, 1e-9);
      }
    }
  }
}

// The paper detector's τ̂0 is absolute and its bound L̂ comes from the identified rows alone, so it is
// not unit-free. Whatever the units, it never says ok about a wrong result: in each of the four units
// either every status is ok with the same detections and the estimates scaled, or a status is not ok
// and says why. A uniform state scaling by 1e-6 keeps it exact; time × 1e6 with v × 1e-6 (the known
// row x' = v then dominates the bound) and the states 1e6 times larger (every sample above τ̂0) do not.
TEST_CASE("the paper detector in other units: the same result, or a status that is not ok with a reason",
          "[identify][scale]") {
  const Run run;
  IdentifierSettings settings = Settings("rls");
  settings.detector.kind = DetectorKind::kPaper;
  const IdentifyResult base = Identify(run.model, run.y, run.grid.dt, settings);
  REQUIRE(base.flow_status == EstimatorStatus::kOk);
  REQUIRE(base.jump_status == EstimatorStatus::kOk);
  REQUIRE(base.jumps_detected == 14);
  int same = 0, refused = 0;
  for (const double f : {1e-6, 1e6}) {
    for (const bool time : {false, true}) {
      INFO((time ? "time x " : "state x ") << f);
      const Scaled sc = time ? TimeScaled(run.y, run.grid.dt, f) : StateScaled(run.y, run.grid.dt, f);
      const IdentifyResult r = Identify(run.model, sc.y, sc.dt, settings);
      if (r.flow_status == EstimatorStatus::kOk && r.jump_status == EstimatorStatus::kOk) {
        ++same;
        CHECK(r.gamma == base.gamma);
        CheckScaled(r.alpha_hat, base.alpha_hat, sc.alpha_factor, 1e-6, 0.0);
        CheckScaled(r.beta_hat, base.beta_hat, sc.beta_factor, 1e-6, 1e-9);
        continue;
      }
      ++refused;
      CHECK(r.gamma != base.gamma);  // a status that is not ok only where the detections differ
      const std::string why = r.flow_status != EstimatorStatus::kOk ? r.flow_reason : r.jump_reason;
      CHECK_THAT(why, Catch::Matchers::Contains("the paper detector"));
      if (time && f == 1e6) CHECK_THAT(r.jump_reason, Catch::Matchers::Contains("bound cannot hold"));
      if (!time && f == 1e6) CHECK_THAT(r.flow_reason, Catch::Matchers::Contains("took every sample"));
    }
  }
  CHECK(same == 1);  // state × 1e-6
  CHECK(refused == 3);
}

namespace {

// The refinement of one uniform run at k·dt.
RefineResult RefineUniform(const Model& model, const Mat& y, double dt, const IdentifyResult& recursive) {
  std::vector<double> t(static_cast<std::size_t>(y.cols()));
  for (std::size_t k = 0; k < t.size(); ++k) t[k] = static_cast<double>(k) * dt;
  return RefineIdentification(model, t, y, {}, recursive);
}

}  // namespace

TEST_CASE("the refined estimate does not depend on the units of the state", "[refine][scale]") {
  const Run run;
  const IdentifyResult base_recursive = Identify(run.model, run.y, run.grid.dt, Settings("rls"));
  const RefineResult base = RefineUniform(run.model, run.y, run.grid.dt, base_recursive);
  INFO(base.reason);
  REQUIRE(base.ok());
  for (const double s : {1e-6, 1e6}) {
    INFO("state x " << s);
    const Scaled sc = StateScaled(run.y, run.grid.dt, s);
    const IdentifyResult recursive = Identify(run.model, sc.y, sc.dt, Settings("rls"));
    const RefineResult r = RefineUniform(run.model, sc.y, sc.dt, recursive);
    INFO(r.reason);
    REQUIRE(r.ok());
    CHECK(r.model_jumps == base.model_jumps);
    // The fits stop at Ceres' tolerance and integrate at a tolerance relative to σ: equal to a small
    // fraction of a standard error; the standard errors themselves scale like the estimates.
    const Vec unit = (Vec(3) << 1.0, 1.0, 1.0).finished();
    for (Eigen::Index i = 1; i < 3; ++i) {
      CHECK(std::abs(r.estimate.alpha[i] - base.estimate.alpha[i]) <= 0.2 * base.standard_errors[i - 1]);
    }
    CHECK(std::abs(r.estimate.beta[1] - base.estimate.beta[1]) <= 0.2 * base.standard_errors[2]);
    CHECK(std::abs(r.estimate.beta[2] / s - base.estimate.beta[2]) <= 0.2 * base.standard_errors[3]);
    CheckScaled(r.standard_errors.head(3), base.standard_errors.head(3), unit, 0.02, 0.0);
    CHECK(r.standard_errors[3] / s == Approx(base.standard_errors[3]).epsilon(0.02));
  }
}

}  // namespace hysid
