// Cost of one simulated trajectory (CVODE + root finding + dense-output sampling).
#include <benchmark/benchmark.h>

#include "core/builtin/bouncing_ball.hpp"
#include "core/builtin/impact_msd.hpp"
#include "core/builtin/impact_pendulum.hpp"
#include "bench/default_inputs.hpp"
#include "sim/measurement.hpp"
#include "sim/model_check/model_check.hpp"
#include "sim/simulator.hpp"

namespace hysid {
namespace {

// The paper's §5 trajectory: 20 s, 14 jumps, 40001 samples (δt = 0.5 ms); the argument is δt in µs.
void BM_SimulateImpactMsd(benchmark::State& state) {
  const Model model{ImpactMsd{}};
  const SampleGrid grid{20.0, static_cast<double>(state.range(0)) * 1e-6};
  for (auto _ : state) {
    Trajectory traj = Simulate(model, DefaultState(model), grid);
    benchmark::DoNotOptimize(traj.x.data());
  }
  // Seconds per sample (printed with an SI prefix, e.g. 75n = 75 ns).
  state.counters["per_sample"] =
      benchmark::Counter(static_cast<double>(grid.size()),
                         benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_SimulateImpactMsd)->Arg(500)->Arg(100)->Arg(5000)->Unit(benchmark::kMillisecond);

void BM_SimulateBouncingBallZeno(benchmark::State& state) {
  const Model model{BouncingBall{}};
  for (auto _ : state) {
    Trajectory traj = Simulate(model, DefaultState(model), SampleGrid{10.0, 1e-3});
    benchmark::DoNotOptimize(traj.x.data());
  }
}
BENCHMARK(BM_SimulateBouncingBallZeno)->Unit(benchmark::kMillisecond);

void BM_SimulateImpactPendulum(benchmark::State& state) {
  const Model model{ImpactPendulum{}};
  for (auto _ : state) {
    Trajectory traj = Simulate(model, DefaultState(model), SampleGrid{20.0, 1e-3});
    benchmark::DoNotOptimize(traj.x.data());
  }
}
BENCHMARK(BM_SimulateImpactPendulum)->Unit(benchmark::kMillisecond);

// A model with a measured input: examples/driven-oscillator (φ reads u, a two-tone default input given
// at the 40 001 sample times, 40 s at δt = 1 ms, 11 jumps), as `hysid simulate` runs it; the run loop
// stops CVODE at every input sample (u is linear between samples).
void BM_SimulateInputs40001(benchmark::State& state) {
  const Model model = LoadModelFile(HYSID_EXAMPLES_DIR "/driven-oscillator/driven-oscillator.toml");
  const SampleGrid grid{model.spec().default_t_end, model.spec().default_dt};
  const InputSignal inputs = DefaultInputs(model, grid);
  Exogenous exo;
  exo.inputs = &inputs;
  long jumps = 0;
  for (auto _ : state) {
    Trajectory traj = Simulate(model, DefaultState(model), grid, SimOptions{}, exo);
    jumps = static_cast<long>(traj.jumps.size());
    benchmark::DoNotOptimize(traj.x.data());
  }
  state.counters["samples"] = static_cast<double>(grid.size());
  state.counters["jumps"] = static_cast<double>(jumps);
  state.counters["per_sample"] =
      benchmark::Counter(static_cast<double>(grid.size()),
                         benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_SimulateInputs40001)->Unit(benchmark::kMillisecond);

// Measurement noise for the §5 trajectory (2 × 40001 normals from the ziggurat stream).
void BM_AddMeasurementNoise(benchmark::State& state) {
  const Mat x = Mat::Zero(2, 40001);
  const Vec sigma = Vec::Constant(2, 0.25);
  std::uint64_t trial = 0;
  for (auto _ : state) {
    Mat y = AddMeasurementNoise(x, sigma, NoiseKey{1, trial++});
    benchmark::DoNotOptimize(y.data());
  }
  state.counters["per_sample"] =
      benchmark::Counter(static_cast<double>(x.cols()),
                         benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_AddMeasurementNoise)->Unit(benchmark::kMicrosecond);

// The earlier per-sample draw (one Philox call and one Box–Muller pair per sample), for comparison.
void BM_AddMeasurementNoisePerSample(benchmark::State& state) {
  const Mat x = Mat::Zero(2, 40001);
  const Vec sigma = Vec::Constant(2, 0.25);
  std::uint64_t trial = 0;
  for (auto _ : state) {
    Mat y = AddMeasurementNoisePerSample(x, sigma, NoiseKey{1, trial++});
    benchmark::DoNotOptimize(y.data());
  }
  state.counters["per_sample"] =
      benchmark::Counter(static_cast<double>(x.cols()),
                         benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_AddMeasurementNoisePerSample)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace hysid

BENCHMARK_MAIN();
