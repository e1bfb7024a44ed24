// Per-sample cost of the identification step on the paper's §5 run (40001 samples, n = 2, m = 2).
#include <benchmark/benchmark.h>

#include "core/identifier.hpp"
#include "core/models/impact_msd.hpp"
#include "sim/measurement.hpp"
#include "sim/simulator.hpp"

namespace hysid {
namespace {

Mat PaperSamples(double sigma) {
  const Model model{ImpactMsd{}};
  Vec x0(2);
  x0 << 20.0, 0.0;
  const Trajectory traj = Simulate(model, x0, SampleGrid{20.0, 5e-4});
  return AddMeasurementNoise(traj.x, Vec::Constant(2, sigma), NoiseKey{1, 0});
}

// One iteration = a whole 40001-sample run through Identifier::Step; the counter is per sample.
void RunIdentifier(benchmark::State& state, bool sets, double sigma) {
  const Model model{ImpactMsd{}};
  const Mat y = PaperSamples(sigma);
  IdentifierSettings settings;
  settings.sets = sets;
  for (auto _ : state) {
    Identifier id(model, 5e-4, settings);
    for (Eigen::Index k = 0; k < y.cols(); ++k) benchmark::DoNotOptimize(id.Step(y.col(k)));
    benchmark::DoNotOptimize(id.alpha_hat().data());
  }
  state.counters["per_sample"] = benchmark::Counter(
      static_cast<double>(y.cols()),
      benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

// Detector (paper, r = 220) + regressions + RLS for α and β; no sample sets.
void BM_IdentifyStep(benchmark::State& state) { RunIdentifier(state, false, 0.0); }
BENCHMARK(BM_IdentifyStep)->Unit(benchmark::kMillisecond);

// The same plus Algorithm 2 (incremental hulls of Λ and Γ).
void BM_IdentifyStepWithHulls(benchmark::State& state) { RunIdentifier(state, true, 0.0); }
BENCHMARK(BM_IdentifyStepWithHulls)->Unit(benchmark::kMillisecond);

// Noisy samples (σ = 0.25): the hull of Λ keeps growing at the edges.
void BM_IdentifyStepWithHullsNoisy(benchmark::State& state) { RunIdentifier(state, true, 0.25); }
BENCHMARK(BM_IdentifyStepWithHullsNoisy)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace hysid

BENCHMARK_MAIN();
