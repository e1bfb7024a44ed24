// Cost of the hybrid sensitivities against a plain trajectory (same §5 run, same tolerances), and of
// the output-error refinement of a recursive estimate on the 40 001-sample §5 run (σ = 0.25), from the
// recursive start and, after a false detection, from the repaired start.
#include <benchmark/benchmark.h>

#include "core/builtin/impact_msd.hpp"
#include "core/identify/identifier.hpp"
#include "sim/measurement.hpp"
#include "sim/refine/refine.hpp"
#include "sim/sensitivity/sensitivity.hpp"

namespace hysid {
namespace {

const Vec kX0 = (Vec(2) << 20.0, 0.0).finished();
const SampleGrid kGrid{20.0, 5e-4};

// Argument: tolerance exponent (12 → rtol = atol = 1e-12).
SimOptions Tolerance(benchmark::State& state) {
  SimOptions o;
  o.rtol = o.atol = std::pow(10.0, -static_cast<double>(state.range(0)));
  return o;
}

void BM_PlainTrajectory(benchmark::State& state) {
  const Model model{ImpactMsd{}};
  const SimOptions o = Tolerance(state);
  for (auto _ : state) {
    Trajectory t = Simulate(model, kX0, kGrid, o);
    benchmark::DoNotOptimize(t.x.data());
  }
}
BENCHMARK(BM_PlainTrajectory)->Arg(12)->Arg(10)->Unit(benchmark::kMillisecond);

void BM_SensitivityTrajectory(benchmark::State& state) {
  const Model model{ImpactMsd{}};
  const SensitivityOptions o{.sim = Tolerance(state), .sensitivities = true};
  for (auto _ : state) {
    SensitivityTrajectory s =
        SimulateSensitivities(model, HybridParameters::Of(model, kX0), Unknowns::Of(model), kGrid, o);
    benchmark::DoNotOptimize(s.sensitivities.data());
  }
}
BENCHMARK(BM_SensitivityTrajectory)->Arg(12)->Arg(10)->Unit(benchmark::kMillisecond);

// The §5 trajectory with σ = 0.25 noise (seed 1) and its recursive estimate (residual detector).
Mat Section5Data() {
  const Trajectory truth = Simulate(Model{ImpactMsd{}}, kX0, kGrid);
  return AddMeasurementNoise(truth.x, Vec::Constant(2, 0.25), NoiseKey{.seed = 1, .stream = 0});
}
IdentifyResult Section5Recursive(const Model& model, const Mat& y) {
  IdentifierSettings settings;
  settings.detector.kind = DetectorKind::kResidual;
  settings.data_rtol = settings.data_atol = 1e-12;
  return Identify(model, y, kGrid.dt, settings);
}

void BM_RefineSection5(benchmark::State& state) {
  const Model model{ImpactMsd{}};
  const Mat y = Section5Data();
  const IdentifyResult recursive = Section5Recursive(model, y);
  int iterations = 0;
  for (auto _ : state) {
    RefineResult r = Refine(model, {RefineChain::Uniform(y, kGrid.dt, recursive.gamma)},
                            recursive.alpha_hat, recursive.beta_hat);
    if (!r.ok()) state.SkipWithError(r.reason.c_str());
    iterations = r.iterations;
    benchmark::DoNotOptimize(r.covariance.data());
  }
  state.counters["iterations"] = iterations;
}
BENCHMARK(BM_RefineSection5)->Unit(benchmark::kMillisecond);

// The same with a false detection added in mid-flight (sample 1911, between the first two impacts):
// the fit on the detected segments fails, and the fit from the repaired start is timed with it.
void BM_RefineRepairedStart(benchmark::State& state) {
  const Model model{ImpactMsd{}};
  const Mat y = Section5Data();
  IdentifyResult recursive = Section5Recursive(model, y);
  recursive.gamma[1911] = 1;
  int iterations = 0;
  for (auto _ : state) {
    RefineResult r = Refine(model, {RefineChain::Uniform(y, kGrid.dt, recursive.gamma)},
                            recursive.alpha_hat, recursive.beta_hat);
    if (!r.ok() || r.start_repair.empty()) state.SkipWithError("the repaired start did not give the fit");
    iterations = r.iterations;
    benchmark::DoNotOptimize(r.covariance.data());
  }
  state.counters["iterations"] = iterations;
}
BENCHMARK(BM_RefineRepairedStart)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace hysid

BENCHMARK_MAIN();
