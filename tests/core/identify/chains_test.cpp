// The identifier on chains: samples at their own times (each trapezoid row and detector statistic with
// its own δt) and chain restarts (no regression across a break), against the simulator's truth.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "core/builtin/impact_msd.hpp"
#include "core/identify/identifier.hpp"
#include "core/identify/metrics.hpp"
#include "sim/simulator.hpp"

namespace hysid {
namespace {

constexpr double kDt = 1.0 / 2048.0;  // a power of two: k·δt and its differences are exact

TEST_CASE("times on an exact grid give the block path's result bit for bit", "[identify][chains]") {
  const Model model{ImpactMsd{}};
  const Trajectory traj = Simulate(model, DefaultState(model), SampleGrid{10.0, kDt});
  REQUIRE(traj.status.completed());
  for (const DetectorKind kind : {DetectorKind::kPaper, DetectorKind::kResidual}) {
    IdentifierSettings settings;
    settings.detector.kind = kind;
    const IdentifyResult block = Identify(model, traj.x, kDt, settings);
    IdentifyOptions options;
    options.times = traj.t;
    const IdentifyResult timed = Identify(model, traj.x, kDt, settings, options);
    CHECK(timed.alpha_hat == block.alpha_hat);
    CHECK(timed.beta_hat == block.beta_hat);
    CHECK(timed.gamma == block.gamma);
    CHECK(timed.chains == 1);
  }
}

// Noise-free §5 samples at t_k = k·δt + m_k·δt/64, m_k ∈ {−1, 0, 1} (±1.6 % of δt), read exactly from
// a simulation on the fine grid δt/64.
void IrregularSamples(const Model& model, Mat* y, std::vector<double>* t, std::vector<int>* j) {
  const Trajectory fine = Simulate(model, DefaultState(model), SampleGrid{10.0, kDt / 64.0});
  REQUIRE(fine.status.completed());
  const long count = (fine.size() - 2) / 64;
  y->resize(2, count);
  for (long k = 0; k < count; ++k) {
    const long m = k == 0 ? 0 : (k * 7919) % 3 - 1;
    const long i = 64 * k + m;
    y->col(k) = fine.x.col(i);
    t->push_back(fine.t[static_cast<std::size_t>(i)]);
    j->push_back(fine.j[static_cast<std::size_t>(i)]);
  }
}

TEST_CASE("irregular times: each pair uses its own δt", "[identify][chains]") {
  const Model model{ImpactMsd{}};
  Mat y;
  std::vector<double> t;
  std::vector<int> j;
  IrregularSamples(model, &y, &t, &j);
  IdentifierSettings settings;
  settings.detector.kind = DetectorKind::kResidual;
  IdentifyOptions options;
  options.times = t;
  const IdentifyResult timed = Identify(model, y, kDt, settings, options);
  const Confusion c = CompareJumps(j, timed.gamma);
  CHECK(c.fn == 0);
  CHECK(c.fp == 0);
  const ParameterErrors e = CompareParameters(model, timed.alpha_hat, timed.beta_hat);
  INFO("own steps: e_alpha " << e.e_alpha << ", e_beta " << e.e_beta);
  CHECK(e.e_alpha < 1e-4);
  // The same samples taken as uniform: the rows carry the timing error (measured: 3.1e-6 against
  // 4.1e-7; the random timing errors mostly average out in α̂).
  const IdentifyResult uniform = Identify(model, y, kDt, settings);
  const ParameterErrors eu = CompareParameters(model, uniform.alpha_hat, uniform.beta_hat);
  INFO("uniform δt assumed: e_alpha " << eu.e_alpha);
  CHECK(eu.e_alpha > 5 * e.e_alpha);
  // The paper detector's statistic is the Euler derivative ‖ξ_k − ξ_{k−1}‖ / (t_k − t_{k−1}) of each
  // pair with its own step, computed here independently.
  IdentifierSettings paper;
  const IdentifyResult p = Identify(model, y, kDt, paper, options);
  double worst = 0.0;
  for (Eigen::Index k = 1; k < y.cols(); ++k) {
    const auto u = static_cast<std::size_t>(k);
    const double d = (y.col(k) - y.col(k - 1)).norm() / (t[u] - t[u - 1]);
    worst = std::max(worst, std::abs(p.statistic[u] - d) / d);
  }
  CHECK(worst < 1e-12);
}

TEST_CASE("a chain break: no trapezoid row or detector statistic across it", "[identify][chains]") {
  const Model model{ImpactMsd{}};
  const Trajectory traj = Simulate(model, DefaultState(model), SampleGrid{20.0, 5e-4});
  REQUIRE(traj.status.completed());
  std::size_t first_jump = 1;
  while (traj.j[first_jump] == traj.j[first_jump - 1]) ++first_jump;
  IdentifierSettings settings;  // the paper detector: all 14 jumps of this trajectory without breaks
  REQUIRE(Identify(model, traj.x, traj.dt, settings).jumps_detected == 14);
  IdentifyOptions options;
  options.chain_start.assign(traj.t.size(), 0);
  options.chain_start[first_jump] = 1;  // the pair across the first jump is not regressed
  const IdentifyResult r = Identify(model, traj.x, traj.dt, settings, options);
  CHECK(r.chains == 2);
  CHECK(r.jumps_detected == 13);
  CHECK(r.gamma[first_jump] == 0);
  CHECK(r.statistic[first_jump] == 0.0);
  CHECK(r.gamma[first_jump + 1] == 0);  // the next pair is a flow pair again
  // A non-finite sample is missing: skipped, and the chain goes on; the pair across it (a step of 2δt)
  // holds the first jump, which is still detected, at the sample after it.
  Mat y = traj.x;
  y(1, static_cast<Eigen::Index>(first_jump) - 1) = std::numeric_limits<double>::quiet_NaN();
  const IdentifyResult skipped = Identify(model, y, traj.dt, settings);
  CHECK(skipped.skipped_samples == 1);
  CHECK(skipped.chains == 1);
  CHECK(skipped.jumps_detected == 14);
  CHECK(skipped.gamma[first_jump] == 1);
  const ParameterErrors e = CompareParameters(model, skipped.alpha_hat, skipped.beta_hat);
  CHECK(e.e_alpha < 1e-4);
  // The integral estimator (sums of consecutive rows) on two chains: a break ends its segment
  // (Estimator::Break) as a jump does.
  IdentifierSettings integral;
  integral.UseEstimator(EstimatorKind::kIntegral);
  const IdentifyResult ri = Identify(model, traj.x, traj.dt, integral, options);
  CHECK(ri.chains == 2);
  CHECK(CompareParameters(model, ri.alpha_hat, ri.beta_hat).e_alpha < 1e-6);
}

}  // namespace
}  // namespace hysid
