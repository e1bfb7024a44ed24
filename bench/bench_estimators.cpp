// Per-sample cost of Estimator::Update for rls, gtls and frisch at p = 2, 4, 8 parameters.
// One scalar row per update (the identified-row case of the §5 system), drawn from the static
// errors-in-variables problem of tests/eiv_problem.hpp (x ~ N(0, I), θ_i = 1/(i+1), σ = 0.3 on every
// column), 4096 rows cycled. Settings are the defaults: gtls refactor_every = 500 (its O(p³)
// refactorisation amortised in the figure), frisch window = 200 (two O(p³) boxes per window),
// frisch point = RLS clamped into the box.
#include <benchmark/benchmark.h>

#include <string>

#include "core/estimator.hpp"
#include "tests/eiv_problem.hpp"

namespace hysid {
namespace {

constexpr long kRows = 4096;

void BM_EstimatorUpdate(benchmark::State& state, const std::string& name) {
  const int p = static_cast<int>(state.range(0));
  Vec theta(p), sigma_phi = Vec::Constant(p, 0.3);
  for (int i = 0; i < p; ++i) theta[i] = 1.0 / (i + 1);
  const testing::EivData d = testing::MakeEivData(theta, sigma_phi, 0.3, kRows, 1, 0);
  const Mat rows = d.phi.transpose();  // p × kRows: each regression row contiguous
  EstimatorSettings settings;
  settings.name = name;
  Mat c = Mat::Identity(p + 1, p + 1) * 0.09;
  settings.noise_shape = c;
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
  for (const char* name : {"rls", "gtls", "frisch"}) {
    const std::string bench = std::string("BM_EstimatorUpdate/") + name;
    benchmark::RegisterBenchmark(bench.c_str(), hysid::BM_EstimatorUpdate, std::string(name))
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
