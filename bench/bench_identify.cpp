// Per-sample cost of the identification step on the paper's §5 run (40001 samples, n = 2, m = 2).
#include <benchmark/benchmark.h>

#include <cmath>
#include <string>
#include <vector>

#include "core/builtin/impact_msd.hpp"
#include "core/identify/identifier.hpp"
#include "core/identify/lockstep.hpp"
#include "core/sets/sample_set.hpp"
#include "sim/measurement.hpp"
#include "sim/model_check/model_check.hpp"
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

// One case of the identification step on the §5 run: which settings, and how the samples are fed.
struct StepCase {
  const char* name;
  const char* detector = "paper";
  double sigma = 0.0;        // measurement noise of the samples
  bool sets = false;         // Algorithm 2's sample sets and hulls
  bool known_sigma = false;  // σ given to the identifier
  bool localize = false;     // sub-sample jump localisation
  const char* estimator = "rls";
  bool data_accuracy = false;  // the simulator's tolerances as the data's accuracy (as in sweeps)
  bool one_at_a_time = false;  // one Identifier::Step call per sample instead of Feed
  bool model_file = false;     // models/impact-msd.toml (muParser) instead of the built-in struct
};

// Every BM_IdentifyStep* case but the references below, registered in main. The paper detector has
// r = 220 and the estimator is RLS for α and β unless a case says otherwise; no sample sets.
const StepCase kStepCases[] = {
    {.name = "BM_IdentifyStep"},
    // One Identifier::Step call per sample (an application feeding samples as they come).
    {.name = "BM_IdentifyStepOneAtATime", .one_at_a_time = true},
    // The §5 model read from its model file (expressions evaluated by muParser).
    {.name = "BM_IdentifyStepModelFile", .model_file = true},
    // The integral estimator for α in place of RLS (β: rls), through the estimator interface.
    {.name = "BM_IdentifyStepIntegral", .estimator = "integral"},
    // Algorithm 2 (incremental hulls of Λ and Γ).
    {.name = "BM_IdentifyStepWithHulls", .sets = true},
    // Noisy samples (σ = 0.25): the hull of Λ keeps growing at the edges.
    {.name = "BM_IdentifyStepWithHullsNoisy", .sigma = 0.25, .sets = true},
    // The tuning-free residual detector in place of the paper's.
    {.name = "BM_IdentifyStepResidual", .detector = "residual"},
    // As in sweeps: σ not given, the simulator's tolerances as the data's accuracy (propagated
    // through the flow Jacobian every sample, like a known σ).
    {.name = "BM_IdentifyStepResidualDataAccuracy",
     .detector = "residual",
     .sigma = 0.25,
     .data_accuracy = true},
    // σ = 0.25 given: the noise is propagated through the flow Jacobian every sample.
    {.name = "BM_IdentifyStepResidualKnownSigma", .detector = "residual", .sigma = 0.25, .known_sigma = true},
    // The paper detector on the same noisy samples, for the comparison above.
    {.name = "BM_IdentifyStepNoisy", .sigma = 0.25},
    // The residual detector with jump localisation (14 located jumps per run).
    {.name = "BM_IdentifyStepResidualLocalized", .detector = "residual", .localize = true},
};

// One iteration = a whole 40001-sample run through Identifier::Feed (the path of Identify, hence of
// `hysid identify`, reproduce and sweeps), or one Identifier::Step call per sample; the counter is
// per sample.
void RunIdentifier(benchmark::State& state, const StepCase& c) {
  const Model model = c.model_file ? LoadModelFile(HYSID_MODELS_DIR "/impact-msd.toml") : Model{ImpactMsd{}};
  const Mat y = PaperSamples(c.sigma);
  IdentifierSettings settings;
  settings.sets = c.sets;
  settings.detector.kind = ParseKind<DetectorKind>(c.detector);
  settings.localize = c.localize;
  if (c.known_sigma) settings.sigma = Vec::Constant(2, c.sigma);
  settings.UseEstimator(ParseKind<EstimatorKind>(c.estimator));
  if (c.data_accuracy) {
    settings.data_rtol = SimOptions{}.rtol;
    settings.data_atol = SimOptions{}.atol;
  }
  std::vector<Decision> decisions(static_cast<std::size_t>(y.cols()));
  for (auto _ : state) {
    Identifier id(model, 5e-4, settings);
    if (c.one_at_a_time) {
      for (Eigen::Index k = 0; k < y.cols(); ++k) benchmark::DoNotOptimize(id.Step(y.col(k)));
    } else {
      id.Feed(y, decisions.data());
      benchmark::DoNotOptimize(decisions.data());
    }
    benchmark::DoNotOptimize(id.alpha_hat().data());
  }
  state.counters["per_sample"] =
      benchmark::Counter(static_cast<double>(y.cols()),
                         benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

// Reference, not hysid's code path: the same §5 step (paper detector r = 220, τ̂0 = 1e5, RLS with
// P0 = 1e8·I on the one identified row, no sets) written out by hand with compile-time sizes and
// everything in registers. It shows what the ≤ 25 ns target asks of the step; the gap to
// BM_IdentifyStep is the cost of the pluggable interfaces (type-erased model, virtual detector and
// estimator, run-time sizes). "jumps" must equal 14, as in BM_IdentifyStep.
void BM_IdentifyStepFusedReference(benchmark::State& state) {
  const Mat y = PaperSamples(0.0);
  const double dt = 5e-4, h = 0.5 * dt, half_r = 110.0, tau0 = 1e5;
  long jumps = 0;
  for (auto _ : state) {
    double a = 0.0, b = 0.0, p00 = 1e8, p01 = 0.0, p11 = 1e8;  // θ = (a, b), P
    long updates = 0;
    jumps = 0;
    double px = y(0, 0), pv = y(1, 0);
    for (Eigen::Index k = 1; k < y.cols(); ++k) {
      const double x = y(0, k), v = y(1, k);
      const double f0 = -h * (x + px), f1 = -h * (v + pv), dv = v - pv;  // Φ = (f0, f1), y = Δξ2
      const double d2 = ((x - px) * (x - px) + dv * dv) / (dt * dt);
      bool jump;
      if (updates < 2) {
        jump = d2 > tau0 * tau0;
      } else {
        const double s = std::sqrt(x * x + v * v) + std::sqrt(px * px + pv * pv);
        jump = d2 > half_r * half_r * (a * a + b * b) * s * s;
      }
      if (!jump) {
        const double g0 = p00 * f0 + p01 * f1, g1 = p01 * f0 + p11 * f1;
        const double inv = 1.0 / (1.0 + f0 * g0 + f1 * g1);
        const double e = dv - f0 * a - f1 * b;
        a += g0 * inv * e;
        b += g1 * inv * e;
        p00 -= g0 * g0 * inv;
        p01 -= g0 * g1 * inv;
        p11 -= g1 * g1 * inv;
        ++updates;
      } else {
        ++jumps;
      }
      px = x;
      pv = v;
    }
    benchmark::DoNotOptimize(a);
    benchmark::DoNotOptimize(b);
  }
  state.counters["jumps"] = static_cast<double>(jumps);
  state.counters["per_sample"] =
      benchmark::Counter(static_cast<double>(y.cols()),
                         benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_IdentifyStepFusedReference)->Unit(benchmark::kMillisecond);

// Reference, not hysid's code path: BM_IdentifyStepFusedReference plus what Identify keeps of every
// sample, its Decision (γ, the statistic D = ‖Δξ‖/δt and the threshold τ̂ = (r/2)·‖α̂‖·s, τ̂0 in the
// warm-up) written to an array. Three square roots per sample (‖ξ‖, carried to the next sample as the
// step carries it, D and τ̂) against the reference's two norms. "jumps" must equal 14.
void BM_IdentifyStepFusedRecordingReference(benchmark::State& state) {
  const Mat y = PaperSamples(0.0);
  const double dt = 5e-4, h = 0.5 * dt, half_r = 110.0, tau0 = 1e5;
  std::vector<Decision> decisions(static_cast<std::size_t>(y.cols()));
  long jumps = 0;
  for (auto _ : state) {
    double a = 0.0, b = 0.0, p00 = 1e8, p01 = 0.0, p11 = 1e8;  // θ = (a, b), P
    long updates = 0;
    jumps = 0;
    double px = y(0, 0), pv = y(1, 0), prev_norm = std::sqrt(px * px + pv * pv);
    for (Eigen::Index k = 1; k < y.cols(); ++k) {
      const double x = y(0, k), v = y(1, k);
      const double f0 = -h * (x + px), f1 = -h * (v + pv), dv = v - pv;  // Φ = (f0, f1), y = Δξ2
      const double d2 = ((x - px) * (x - px) + dv * dv) / (dt * dt);
      const double norm = std::sqrt(x * x + v * v);
      Decision d;
      d.statistic = std::sqrt(d2);
      if (updates < 2) {
        d.gamma = d2 > tau0 * tau0;
        d.threshold = tau0;
      } else {
        const double s = norm + prev_norm, l2 = a * a + b * b;
        d.gamma = d2 > half_r * half_r * l2 * s * s;
        d.threshold = half_r * std::sqrt(l2) * s;
      }
      if (!d.gamma) {
        const double g0 = p00 * f0 + p01 * f1, g1 = p01 * f0 + p11 * f1;
        const double inv = 1.0 / (1.0 + f0 * g0 + f1 * g1);
        const double e = dv - f0 * a - f1 * b;
        a += g0 * inv * e;
        b += g1 * inv * e;
        p00 -= g0 * g0 * inv;
        p01 -= g0 * g1 * inv;
        p11 -= g1 * g1 * inv;
        ++updates;
      } else {
        ++jumps;
      }
      decisions[static_cast<std::size_t>(k)] = d;
      px = x;
      pv = v;
      prev_norm = norm;
    }
    benchmark::DoNotOptimize(a);
    benchmark::DoNotOptimize(b);
    benchmark::DoNotOptimize(decisions.data());
  }
  state.counters["jumps"] = static_cast<double>(jumps);
  state.counters["per_sample"] =
      benchmark::Counter(static_cast<double>(y.cols()),
                         benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_IdentifyStepFusedRecordingReference)->Unit(benchmark::kMillisecond);

// Reference, not hysid's code path: only the RLS update of the step (P0 = 1e8·I, λ = 1) by hand, in
// scalars, over the §5 run's flow rows built beforehand (BuildFlowRows), every row taken as a flow
// row: the loop-carried chain the step cannot beat, with no detector, no decisions and no rows formed.
void BM_RlsUpdateReference(benchmark::State& state) {
  const Mat y = PaperSamples(0.0);
  const FlowRows rows = BuildFlowRows(Model{ImpactMsd{}}, y, 5e-4);
  for (auto _ : state) {
    double a = 0.0, b = 0.0, p00 = 1e8, p01 = 0.0, p11 = 1e8;
    for (Eigen::Index k = 1; k < y.cols(); ++k) {
      const double f0 = rows.phi[2 * k], f1 = rows.phi[2 * k + 1], dv = rows.y[k];
      const double g0 = p00 * f0 + p01 * f1, g1 = p01 * f0 + p11 * f1;
      const double inv = 1.0 / (1.0 + f0 * g0 + f1 * g1);
      const double e = dv - f0 * a - f1 * b;
      a += g0 * inv * e;
      b += g1 * inv * e;
      p00 -= g0 * g0 * inv;
      p01 -= g0 * g1 * inv;
      p11 -= g1 * g1 * inv;
    }
    benchmark::DoNotOptimize(a);
    benchmark::DoNotOptimize(b);
  }
  state.counters["per_sample"] =
      benchmark::Counter(static_cast<double>(y.cols()),
                         benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_RlsUpdateReference)->Unit(benchmark::kMillisecond);

// A sweep trial's paper-detector units: M = state.range(0) identifications of the §5 run (σ =
// state.range(1) / 100) that differ only in r (the robustness map's 220, 500, 1000, 50, 20, 5, the
// first M), on flow rows built once, no sets, statistics off. Lockstep: IdentifyLockstep with each
// unit's τ̂0 a little different (1e5 + i; no sample of the run is decided by τ̂0), so that no two are
// twins and all flow runs go side by side; twins: IdentifyLockstep as the sweep calls it (units that
// decide alike share one identifier); alone: one Identify after the other. All give the same bits.
// Counter: per unit-sample; "lockstep_share", "shared_share": the shares of unit-samples stepped in
// lockstep and decided by a twin.
enum class Units { kAlone, kLockstep, kTwins };
void RunUnits(benchmark::State& state, Units mode) {
  const Model model{ImpactMsd{}};
  const Mat y = PaperSamples(static_cast<double>(state.range(1)) / 100.0);
  const auto m = static_cast<std::size_t>(state.range(0));
  const double rs[] = {220.0, 500.0, 1000.0, 50.0, 20.0, 5.0};
  std::vector<IdentifierSettings> settings(m);
  for (std::size_t i = 0; i < m; ++i) {
    settings[i].sets = false;
    settings[i].detector.r = rs[i % 6];
    if (mode == Units::kLockstep) settings[i].detector.tau0 = 1e5 + static_cast<double>(i);
  }
  const FlowRows rows = BuildFlowRows(model, y, 5e-4);
  IdentifyOptions options;
  options.statistics = false;
  options.check_paper_bound = false;
  options.flow_rows = &rows;
  LockstepCounts counts;
  for (auto _ : state) {
    if (mode != Units::kAlone) {
      benchmark::DoNotOptimize(IdentifyLockstep(model, y, 5e-4, settings, options, &counts).data());
    } else {
      for (const IdentifierSettings& s : settings) benchmark::DoNotOptimize(Identify(model, y, 5e-4, s, options));
    }
  }
  state.counters["per_sample"] =
      benchmark::Counter(static_cast<double>(y.cols()) * static_cast<double>(m),
                         benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  if (mode != Units::kAlone) {
    state.counters["lockstep_share"] = static_cast<double>(counts.lockstep) / static_cast<double>(counts.total);
    state.counters["shared_share"] = static_cast<double>(counts.shared) / static_cast<double>(counts.total);
  }
}

void BM_IdentifyStepLockstep(benchmark::State& state) { RunUnits(state, Units::kLockstep); }
BENCHMARK(BM_IdentifyStepLockstep)
    ->Args({1, 0})->Args({2, 0})->Args({4, 0})->Args({6, 0})->Args({6, 25})
    ->Unit(benchmark::kMillisecond);
void BM_IdentifyStepTwins(benchmark::State& state) { RunUnits(state, Units::kTwins); }
BENCHMARK(BM_IdentifyStepTwins)->Args({6, 0})->Args({6, 25})->Unit(benchmark::kMillisecond);
void BM_IdentifyStepUnitsAlone(benchmark::State& state) { RunUnits(state, Units::kAlone); }
BENCHMARK(BM_IdentifyStepUnitsAlone)->Args({1, 0})->Args({6, 0})->Args({6, 25})->Unit(benchmark::kMillisecond);

// The hull update alone: the 40001 samples of the §5 run (σ = state.range(0) / 100) added to one
// SampleSet, as Λ receives them. Counter: per sample; "vertices" is the final hull size.
void BM_SampleSetAdd(benchmark::State& state) {
  const Mat y = PaperSamples(static_cast<double>(state.range(0)) / 100.0);
  long vertices = 0;
  for (auto _ : state) {
    SampleSet set(2);
    for (Eigen::Index k = 0; k < y.cols(); ++k) set.Add(y.col(k));
    vertices = static_cast<long>(set.vertices().cols());
    benchmark::DoNotOptimize(vertices);
  }
  state.counters["per_sample"] =
      benchmark::Counter(static_cast<double>(y.cols()),
                         benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  state.counters["vertices"] = static_cast<double>(vertices);
}
BENCHMARK(BM_SampleSetAdd)->Arg(0)->Arg(25)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace hysid

int main(int argc, char** argv) {
  for (const hysid::StepCase& c : hysid::kStepCases) {
    benchmark::RegisterBenchmark(c.name, hysid::RunIdentifier, c)->Unit(benchmark::kMillisecond);
  }
  // Each estimator of the factory for α and β: the paper detector, σ = 0.25 given (gtls / frisch derive
  // their noise shapes once in the constructor). The names outlive the run (StepCase keeps pointers).
  static const std::vector<std::string> estimators = hysid::PluginNames<hysid::EstimatorKind>();
  for (const std::string& name : estimators) {
    const std::string bench = "BM_IdentifyStepEstimator/" + name;
    const hysid::StepCase c{.name = "", .sigma = 0.25, .known_sigma = true, .estimator = name.c_str()};
    benchmark::RegisterBenchmark(bench.c_str(), hysid::RunIdentifier, c)->Unit(benchmark::kMillisecond);
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
