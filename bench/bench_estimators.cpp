// Per-sample cost of Estimator::Update for every estimator of the factory (PluginNames<EstimatorKind>(): rls,
// gtls, frisch) at p = 2, 4, 8 unknown parameters (rows z = [φ; y] of length p + 1).
// One scalar row per update (the identified-row case of the §5 system), drawn from the static
// errors-in-variables problem of tests/testing/eiv_problem.hpp (x ~ N(0, I), θ_i = 1/(i+1), σ = 0.3 on every
// column), 4096 rows cycled. Settings are the defaults: gtls refactor_every = 500 (its O(p³)
// refactorisation amortised in the figure) with C = 0.09·I; frisch window = 200 (two O(p³) boxes and
// one Student-t quantile per window, amortised), confidence 0.95, point = RLS clamped into the
// boxes. frisch_growing: window = 0 (the jump regression's default), a box after every update.
#include <benchmark/benchmark.h>

#include <string>
#include <utility>
#include <vector>

#include "core/estimators/estimator.hpp"
#include "tests/testing/eiv_problem.hpp"

namespace hysid {
namespace {

constexpr long kRows = 4096;

void BM_EstimatorUpdate(benchmark::State& state, const std::string& name, int window) {
  const int p = static_cast<int>(state.range(0));
  Vec theta(p), sigma_phi = Vec::Constant(p, 0.3);
  for (int i = 0; i < p; ++i) theta[i] = 1.0 / (i + 1);
  const testing::EivData d = testing::MakeEivData(theta, sigma_phi, 0.3, kRows, 1, 0);
  const Mat rows = d.phi.transpose();  // p × kRows: each regression row contiguous
  EstimatorSettings settings;
  settings.kind = ParseKind<EstimatorKind>(name);
  Mat c = Mat::Identity(p + 1, p + 1) * 0.09;
  settings.noise_shape = c;
  settings.window = window;
  auto estimator = MakeEstimator(settings, Vec::Zero(p));
  long k = 0;
  for (auto _ : state) {
    const Eigen::Map<const Mat> row(rows.col(k).data(), 1, p);
    estimator->Update(row, d.y.segment(k, 1));
    benchmark::DoNotOptimize(estimator->estimate().data());
    k = (k + 1) % kRows;
  }
  if (!estimator->estimate().allFinite()) state.SkipWithError("non-finite estimate");
  state.SetLabel(ToString(estimator->status()));
}

}  // namespace
}  // namespace hysid

int main(int argc, char** argv) {
  std::vector<std::pair<std::string, int>> cases;
  for (const std::string& name : hysid::PluginNames<hysid::EstimatorKind>()) {
    cases.emplace_back(name, hysid::EstimatorSettings{}.window);
  }
  cases.emplace_back("frisch", 0);
  for (const auto& [name, window] : cases) {
    const std::string bench =
        "BM_EstimatorUpdate/" + name + (name == "frisch" && window == 0 ? "_growing" : "");
    benchmark::RegisterBenchmark(bench.c_str(), hysid::BM_EstimatorUpdate, name, window)
        ->Arg(2)
        ->Arg(4)
        ->Arg(8)
        ->Unit(benchmark::kNanosecond);
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
