// Matched sensitivities on samples at their own times: the same as the grid where the times are the
// grid's, and the simulator's states where they are not.
#include <catch2/catch.hpp>

#include <algorithm>
#include <vector>

#include "core/builtin/impact_msd.hpp"
#include "core/model_file/model_file.hpp"
#include "sim/input_signal.hpp"
#include "sim/sensitivity/sensitivity.hpp"

namespace hysid {
namespace {

constexpr double kDt = 1.0 / 1024.0;  // k·δt exact

TEST_CASE("times equal to the grid's give the grid's states and sensitivities bit for bit", "[sensitivity]") {
  const Model model{ImpactMsd{}};
  const Vec x0 = (Vec(2) << 20.0, 0.0).finished();
  const SampleGrid grid{5.0, kDt};
  const Trajectory truth = Simulate(model, x0, grid);
  const HybridParameters p = HybridParameters::Of(model, x0);
  const Unknowns u = Unknowns::Of(model);
  const SensitivityTrajectory on_grid = SimulateSensitivitiesMatched(model, p, u, grid, truth.j);
  const SensitivityTrajectory timed = SimulateSensitivitiesMatched(model, p, u, truth.t, truth.j);
  REQUIRE(on_grid.ok());
  REQUIRE(timed.ok());
  CHECK(timed.trajectory.x == on_grid.trajectory.x);
  CHECK(timed.sensitivities == on_grid.sensitivities);
}

// Records what a run hands its sink: each sample's state and S_k, and how many times each came.
class Recorder final : public SensitivitySink {
 public:
  Recorder(long n, long p, long k_count) : x(n, k_count), s(n * p, k_count), count(k_count, 0) {}
  void Sample(long k, const double* xk, const double* sk) override {
    x.col(k) = Eigen::Map<const Vec>(xk, x.rows());
    s.col(k) = Eigen::Map<const Vec>(sk, s.rows());
    ++count[static_cast<std::size_t>(k)];
  }
  Mat x, s;
  std::vector<int> count;
};

TEST_CASE("a sink takes every sample's state and sensitivities once, as the stored run has them",
          "[sensitivity]") {
  const Model model{ImpactMsd{}};
  const Vec x0 = (Vec(2) << 20.0, 0.0).finished();
  const Trajectory truth = Simulate(model, x0, SampleGrid{5.0, kDt});
  const HybridParameters p = HybridParameters::Of(model, x0);
  const Unknowns u = Unknowns::Of(model);
  const SensitivityTrajectory stored = SimulateSensitivitiesMatched(model, p, u, truth.t, truth.j);
  Recorder sink(2, stored.parameters, truth.size());
  const SensitivityTrajectory sunk =
      SimulateSensitivitiesMatched(model, p, u, truth.t, truth.j, {}, nullptr, &sink);
  REQUIRE(stored.ok());
  REQUIRE(sunk.ok());
  CHECK(sunk.sensitivities.size() == 0);
  CHECK(sunk.trajectory.x == stored.trajectory.x);
  CHECK(sink.x == stored.trajectory.x);
  CHECK(sink.s == stored.sensitivities);
  CHECK(std::all_of(sink.count.begin(), sink.count.end(), [](int c) { return c == 1; }));
  CHECK(sunk.jump_time_gradients == stored.jump_time_gradients);
}

TEST_CASE("irregular times: the states are the simulator's at those times", "[sensitivity]") {
  const Model model{ImpactMsd{}};
  const Vec x0 = (Vec(2) << 20.0, 0.0).finished();
  const Trajectory fine = Simulate(model, x0, SampleGrid{5.0, kDt / 8});
  std::vector<double> times;
  std::vector<int> segments;
  std::vector<long> index;
  for (long k = 0; 8 * k + 3 < fine.size(); ++k) {
    const long i = k == 0 ? 0 : 8 * k + (k % 3 == 0 ? -1 : (k % 3 == 1 ? 0 : 3));
    times.push_back(fine.t[static_cast<std::size_t>(i)]);
    segments.push_back(fine.j[static_cast<std::size_t>(i)]);
    index.push_back(i);
  }
  SensitivityOptions o;
  o.sim.rtol = o.sim.atol = 1e-11;
  const SensitivityTrajectory s = SimulateSensitivitiesMatched(model, HybridParameters::Of(model, x0),
                                                               Unknowns::Of(model), times, segments, o);
  REQUIRE(s.ok());
  double worst = 0.0;
  for (std::size_t k = 0; k < times.size(); ++k) {
    worst = std::max(worst, (s.trajectory.x.col(static_cast<Eigen::Index>(k)) - fine.x.col(index[k])).norm());
  }
  CHECK(worst < 1e-7);
  CHECK_THROWS_WITH(
      SimulateSensitivitiesMatched(model, HybridParameters::Of(model, x0), Unknowns::Of(model),
                                   std::vector<double>{0.0, 0.2, 0.1}, std::vector<int>{0, 0, 0}),
      "times[2] = 0.1 after 0.2: must increase");
}

// x' = a·u, u ≡ 1: x(t) = x0 + a t, ∂x/∂a = t. Times ending at 3.700000000000001 (a chain of
// data ending where rows were removed), with the input sampled at the same times: the run needs u
// on [0, times.back()] exactly, though (n − 1)·(times.back()/(n − 1)) rounds to 3.7000000000000015.
const char* kDriven = R"toml(name = "driven"
states = ["x"]
inputs = ["u"]
alpha = [{ name = "a", value = 2.0 }]
beta = [{ name = "e", value = 1.0 }]
[flow]
phi = [["u"]]
rows = ["x"]
[jump]
psi = [["x"]]
rows = ["x"]
[[guard]]
h = "x - 100"
direction = "rising"
[sets]
C = "x < 100"
D = "x >= 100"
[defaults]
x0 = [1.0]
)toml";

TEST_CASE("samples at their own times need the input up to the last time and not past it by rounding",
          "[sensitivity]") {
  const Model model = ParseModelFile(kDriven, "driven.toml").model;
  const double last = 3.700000000000001;
  const long n = 46;
  REQUIRE(static_cast<double>(n - 1) * (last / static_cast<double>(n - 1)) > last);  // the rounding
  InputSignal u;
  u.values = Mat::Ones(1, n);
  for (long k = 0; k < n; ++k) u.times.push_back(k == n - 1 ? last : last * static_cast<double>(k) / (n - 1));
  const HybridParameters p = HybridParameters::Of(model, Vec::Ones(1));
  const SensitivityTrajectory s =
      SimulateSensitivities(model, p, Unknowns::Of(model), u.times, SensitivityOptions{}, &u);
  REQUIRE(s.ok());
  CHECK(s.trajectory.x(0, n - 1) == Approx(1.0 + 2.0 * last).epsilon(1e-10));
  CHECK(s.sensitivities(0, n - 1) == Approx(last).epsilon(1e-10));  // ∂x/∂a, the first unknown
}

}  // namespace
}  // namespace hysid
