// The input-driven impact oscillator (examples/driven-oscillator) from its model file alone:
// simulate with the file's default two-tone input, add noise, identify with the defaults (the
// inputs read at the samples), refine. In several seeds every unknown (k, b, G, λ, ξ0) lies within
// 3 standard errors of the truth, and each standard error within 20 % of the CRLB's.
#include <catch2/catch.hpp>

#include <cmath>

#include "core/identify/identifier.hpp"
#include "core/model_file/input_defaults.hpp"
#include "core/model_file/model_file.hpp"
#include "sim/exogenous.hpp"
#include "sim/input_signal.hpp"
#include "sim/measurement.hpp"
#include "sim/refine/refine.hpp"

namespace hysid {
namespace {

TEST_CASE("driven oscillator: the defaults recover G and the others within 3 SE of the truth, SE at the CRLB",
          "[refine][inputs]") {
  const Model model = ReadModelFile(HYSID_EXAMPLES_DIR "/driven-oscillator/driven-oscillator.toml").model;
  const SampleGrid grid{model.spec().default_t_end, model.spec().default_dt};
  InputSignal u;
  for (long k = 0; k < grid.size(); ++k) u.times.push_back(static_cast<double>(k) * grid.dt);
  u.values = EvaluateInputDefaults(model.spec(), u.times);
  Exogenous exo;
  exo.inputs = &u;
  const Vec x0 = DefaultState(model);
  const Trajectory truth = Simulate(model, x0, grid, {}, exo);
  REQUIRE(truth.status.completed());
  const double sigma = 1e-3;
  const Unknowns unknowns = Unknowns::Of(model);
  const Crlb bound = ComputeCrlb(model, x0, grid, Vec::Constant(2, sigma), unknowns, {}, {}, &u);
  REQUIRE(bound.ok());
  const Vec true_theta = HybridParameters::Of(model, x0).Theta(unknowns);
  for (std::uint64_t seed : {1, 2, 3, 4}) {
    const Mat y = AddMeasurementNoise(truth.x, Vec::Constant(2, sigma), NoiseKey{.seed = seed, .stream = 0});
    IdentifyOptions options;
    options.inputs = u.values;
    IdentifierSettings settings;  // as hysid identify: the residual detector, the solver's accuracy
    settings.detector.kind = DetectorKind::kResidual;
    settings.data_rtol = settings.data_atol = 1e-12;
    const IdentifyResult recursive = Identify(model, y, grid.dt, settings, options);
    CHECK(recursive.jumps_detected == static_cast<long>(truth.jumps.size()));
    const RefineResult r =
        RefineIdentification(model, truth.t, y, {}, RefinementStart(recursive), {}, u.values);
    INFO("seed " << seed << ": " << r.reason);
    REQUIRE(r.ok());
    CHECK(r.samples_used == grid.size());
    const Vec error = r.estimate.Theta(unknowns) - true_theta;
    for (Eigen::Index i = 0; i < error.size(); ++i) {
      INFO(r.names[static_cast<std::size_t>(i)] << ": error " << error[i] << ", se " << r.standard_errors[i]
                                                << ", crlb sd " << bound.sd[i]);
      CHECK(std::abs(error[i]) < 3 * r.standard_errors[i]);
      CHECK(r.standard_errors[i] == Approx(bound.sd[i]).epsilon(0.2));
    }
  }
}

}  // namespace
}  // namespace hysid
