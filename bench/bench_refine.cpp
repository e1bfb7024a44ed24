// Cost of the hybrid sensitivities against a plain trajectory (same §5 run, same tolerances), and of
// the output-error refinement of a recursive estimate on the 40 001-sample §5 run (σ = 0.25), from the
// recursive start and, after a false detection, from the repaired start; the refinement of the
// systems of examples/ as they are measured (height only, a guard parameter, a measured input).
#include <benchmark/benchmark.h>

#include <string>
#include <utility>
#include <vector>

#include "bench/default_inputs.hpp"
#include "core/builtin/impact_msd.hpp"
#include "core/identify/identifier.hpp"
#include "core/identify/reconstruct.hpp"
#include "sim/measurement.hpp"
#include "sim/model_check/model_check.hpp"
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

// A system of examples/ as `hysid identify` fits it with the defaults, after `hysid simulate` with the
// README's noise: simulated with the model file's defaults (x0, t_end; δt the defaults', or
// t_end / (samples − 1) when `samples` is given) and `truth` set on the model, σ on every state
// (seed 1), the unmeasured states reconstructed as the recursive pass's start and its kinks as its
// labels, the residual detector with the solver's tolerances as the data's accuracy, the inputs
// (the model file's input_defaults at the sample times) in the data. As `hysid identify` with the
// sidecar of `hysid simulate`, the model carries the true values of `truth` (a guard parameter's
// start still comes from the detected jumps).
struct ExampleFit {
  Model model;
  std::vector<double> t = {};
  Mat y = {};  // n × K: the measured states, the others reconstructed
  Mat u = {};  // m × K inputs, or empty
  IdentifyResult recursive = {};
  RefineOptions options = {};
};

ExampleFit MakeExampleFit(const std::string& file, double sigma, long samples,
                          const std::vector<std::pair<std::string, double>>& truth = {}) {
  ExampleFit f{.model = LoadModelFile(std::string(HYSID_EXAMPLES_DIR "/") + file)};
  for (const auto& [name, value] : truth) f.model.SetParameter(name, value);
  const ModelSpec& spec = f.model.spec();
  const SampleGrid grid{spec.default_t_end,
                        samples > 0 ? spec.default_t_end / static_cast<double>(samples - 1) : spec.default_dt};
  const InputSignal inputs = DefaultInputs(f.model, grid);
  f.u = inputs.values;
  Exogenous exo;
  exo.inputs = inputs.empty() ? nullptr : &inputs;
  const Trajectory truth_run = Simulate(f.model, DefaultState(f.model), grid, SimOptions{}, exo);
  const Mat noisy = AddMeasurementNoise(truth_run.x, Vec::Constant(f.model.state_size(), sigma), NoiseKey{1, 0});
  f.t = truth_run.t;
  IdentifierSettings settings;
  settings.detector.kind = DetectorKind::kResidual;
  settings.data_rtol = SimOptions{}.rtol;
  settings.data_atol = SimOptions{}.atol;
  IdentifyOptions options;
  options.inputs = f.u;
  const std::vector<int> measured = MeasuredIndices(f.model);
  f.y = noisy;
  if (static_cast<int>(measured.size()) < f.model.state_size()) {
    const Reconstruction r =
        ReconstructStates(PlanReconstruction(f.model, measured), f.t, noisy(measured, Eigen::all), {}, Vec());
    f.y = r.x;
    options.labels = r.gamma;
    f.options.measured = measured;
  }
  f.recursive = Identify(f.model, f.y, grid.dt, settings, options);
  return f;
}

// The refinement of `f` from its recursive start (RefinementStart, as `hysid identify`); counters:
// the iterations and the samples fit.
void RunExampleFit(benchmark::State& state, const ExampleFit& f) {
  RefineResult r;
  for (auto _ : state) {
    r = RefineIdentification(f.model, f.t, f.y, {}, RefinementStart(f.recursive), f.options, f.u);
    if (!r.ok()) state.SkipWithError((std::string(ToString(r.status)) + ": " + r.reason).c_str());
    benchmark::DoNotOptimize(r.covariance.data());
  }
  state.counters["iterations"] = r.iterations;
  state.counters["samples"] = static_cast<double>(r.samples_used);
}

// examples/drag-ball: the height measured only (1 mm noise), g, k, e and ξ0 fit to the height;
// argument: the samples over the defaults' 5 s (751: the defaults' 150 Hz).
void BM_RefineDragBall(benchmark::State& state) {
  RunExampleFit(state, MakeExampleFit("drag-ball/drag-ball.toml", 1e-3, state.range(0)));
}
BENCHMARK(BM_RefineDragBall)->Arg(751)->Arg(40001)->Unit(benchmark::kMillisecond);

// examples/wall: the wall's position w unknown (true 1.0), 1 mm noise, 40 001 samples.
void BM_RefineWall(benchmark::State& state) {
  RunExampleFit(state, MakeExampleFit("wall/wall.toml", 1e-3, 0, {{"w", 1.0}}));
}
BENCHMARK(BM_RefineWall)->Unit(benchmark::kMillisecond);

// examples/driven-oscillator: a measured two-tone input u in φ, 1 mm noise, 40 001 samples.
void BM_RefineDriven(benchmark::State& state) {
  RunExampleFit(state, MakeExampleFit("driven-oscillator/driven-oscillator.toml", 1e-3, 0));
}
BENCHMARK(BM_RefineDriven)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace hysid

BENCHMARK_MAIN();
