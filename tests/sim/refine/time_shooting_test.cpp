// Multiple shooting by time, the model finding its own events: the fit reaches the Cramér–Rao bound
// from starts 2× off with no detected label, with a hidden state, and over a gap; the residual tests
// refuse at their stated size.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "core/builtin/bouncing_ball.hpp"
#include "core/builtin/impact_msd.hpp"
#include "sim/measurement.hpp"
#include "sim/refine/refine.hpp"
#include "sim/refine/residual_tests.hpp"
#include "sim/refine/span.hpp"
#include "sim/refine/time_shooting.hpp"
#include "sim/sensitivity/crlb.hpp"
#include "tests/sim/refine/at_the_bound.hpp"

namespace hysid {
namespace {

struct Data {
  Model model;
  SampleGrid grid;
  Vec x0;
  Trajectory truth;
  Mat y;
  Data(Model m, SampleGrid g, Vec start, double sigma, std::uint64_t seed)
      : model(std::move(m)), grid(g), x0(std::move(start)), truth(Simulate(model, x0, grid)) {
    y = AddMeasurementNoise(truth.x, Vec::Constant(model.state_size(), sigma), NoiseKey{.seed = seed, .stream = 0});
  }
};

TEST_CASE("time shooting fits the §5 system from a start 2x off with no detected jump", "[time_shooting]") {
  const double sigma = 0.05;
  const Data d(Model(ImpactMsd{}), SampleGrid{6.0, 2e-3}, (Vec(2) << 20.0, 0.0).finished(), sigma, 11);
  REQUIRE(d.truth.jumps.size() >= 4);
  const std::vector<std::uint8_t> no_labels(d.truth.t.size(), 0);
  HybridParameters start = HybridParameters::Of(d.model, d.x0);
  const Unknowns unknown = Unknowns::Of(d.model);
  for (int i : unknown.alpha) start.alpha[i] *= 2.0;  // a = 10, b = 0.2
  for (int i : unknown.beta) start.beta[i] *= 0.5;    // λ = 0.495, μ = 0
  RefineOptions options;
  options.sigma = Vec::Constant(2, sigma);
  const RefineResult r = FitByTimeShooting(d.model, {RefineChain::Uniform(d.y, d.grid.dt, no_labels)}, start, options);
  const Unknowns u = Unknowns::Of(d.model);
  const Crlb bound = ComputeCrlb(d.model, d.x0, d.grid, Vec::Constant(2, sigma), u);
  RequireAtTheBound(r, HybridParameters::Of(d.model, d.x0).Theta(u), bound);
}

// The whole record's cost ½Σ((x(t_k) − y_k)/σ)² of the model run from x0 with θ (single shooting), by
// plain simulation at a tolerance far below the noise.
double SingleShootingCost(Model model, const std::vector<std::string>& names, const Vec& theta, int shared,
                          const SampleGrid& grid, const Mat& y, double sigma) {
  for (int i = 0; i < shared; ++i) model.SetParameter(names[std::size_t(i)], theta[i]);
  SimOptions tight;
  tight.rtol = tight.atol = 1e-11;
  const Trajectory run = Simulate(model, theta.tail(model.state_size()), grid, tight);
  REQUIRE(run.size() == y.cols());
  return 0.5 * ((run.x - y) / sigma).squaredNorm();
}

TEST_CASE("time shooting ends within two standard errors of the single-shooting optimum", "[time_shooting]") {
  // The gradient of the whole record's cost by central differences of plain simulations (steps of
  // 0.05 SE), measured in the fit's covariance: λ = √(gᵀCg), the Gauss–Newton step's length in
  // standard errors. The fit's own check (kOptimumStep) reads the same step off its sensitivities.
  const double sigma = 0.05;
  const Data d(Model(ImpactMsd{}), SampleGrid{6.0, 2e-3}, (Vec(2) << 20.0, 0.0).finished(), sigma, 23);
  const std::vector<std::uint8_t> no_labels(d.truth.t.size(), 0);
  HybridParameters start = HybridParameters::Of(d.model, d.x0);
  const Unknowns u = Unknowns::Of(d.model);
  for (int i : u.alpha) start.alpha[i] *= 1.5;
  for (int i : u.beta) start.beta[i] *= 0.7;
  RefineOptions options;
  options.sigma = Vec::Constant(2, sigma);
  const RefineResult r = FitByTimeShooting(d.model, {RefineChain::Uniform(d.y, d.grid.dt, no_labels)}, start, options);
  REQUIRE(r.ok());
  const int shared = u.shared();
  const Vec theta = r.refined.Theta(r.unknowns);  // θ, then the first node's state
  REQUIRE(theta.size() == shared + 2);
  REQUIRE(r.covariance.rows() == theta.size());
  Vec g(theta.size());
  for (Eigen::Index i = 0; i < theta.size(); ++i) {
    const double h = 0.05 * r.standard_errors[i];
    Vec up = theta, down = theta;
    up[i] += h;
    down[i] -= h;
    g[i] = (SingleShootingCost(d.model, r.names, up, shared, d.grid, d.y, sigma) -
            SingleShootingCost(d.model, r.names, down, shared, d.grid, d.y, sigma)) / (2.0 * h);
  }
  const double lambda = std::sqrt(g.dot(r.covariance * g));
  INFO("gradient " << g.transpose() << ", lambda " << lambda);
  CHECK(lambda < kOptimumStep);
}

TEST_CASE("time shooting fits a ball measured by its height alone, over a gap", "[time_shooting]") {
  const double sigma = 2e-3;
  const Data d(Model(BouncingBall{}), SampleGrid{3.0, 1.0 / 120}, (Vec(2) << 1.0, 0.0).finished(), sigma, 5);
  REQUIRE(d.truth.jumps.size() >= 3);
  // The height alone; samples 100–135 missing (a dropout of 0.3 s): two chains.
  const long K = d.truth.size(), gap_from = 100, gap_to = 136;
  auto chain = [&](long a, long b) {
    std::vector<double> t(d.truth.t.begin() + a, d.truth.t.begin() + b);
    Mat y = d.y.middleCols(a, b - a);
    // The velocity is not measured: its start the central differences of the heights (as a
    // reconstruction gives it), the fit's residuals the heights alone.
    for (long k = 0; k < b - a; ++k) {
      const long lo = std::max(0L, k - 1), hi = std::min(b - a - 1, k + 1);
      y(1, k) = (y(0, hi) - y(0, lo)) / (t[std::size_t(hi)] - t[std::size_t(lo)]);
    }
    return RefineChain::Of(std::move(t), std::move(y), std::vector<std::uint8_t>(std::size_t(b - a), 0));
  };
  HybridParameters start = HybridParameters::Of(d.model, d.x0);
  const Unknowns u = Unknowns::Of(d.model);
  REQUIRE(u.alpha.size() + u.beta.size() >= 2);
  for (int i : u.alpha) start.alpha[i] *= 0.8;
  for (int i : u.beta) start.beta[i] *= 0.8;
  RefineOptions options;
  options.sigma = Vec::Constant(1, sigma);
  options.measured = {0};
  const RefineResult r = FitByTimeShooting(d.model, {chain(0, gap_from), chain(gap_to, K)}, start, options);
  INFO(r.reason);
  REQUIRE(r.ok());
  const Vec theta = r.estimate.Theta(r.unknowns), truth = HybridParameters::Of(d.model, d.x0).Theta(r.unknowns);
  for (Eigen::Index i = 0; i < u.shared(); ++i) CHECK(std::abs(theta[i] - truth[i]) < 4 * r.standard_errors[i]);
}

// The detected labels of a simulated run: 1 at each sample whose interval holds a true jump, plus `extra`.
std::vector<std::uint8_t> TrueLabels(const Trajectory& truth, const std::vector<long>& extra = {}) {
  std::vector<std::uint8_t> gamma(truth.t.size(), 0);
  for (std::size_t k = 1; k < gamma.size(); ++k) gamma[k] = truth.j[k] != truth.j[k - 1];
  for (long k : extra) gamma[std::size_t(k)] = 1;
  return gamma;
}

TEST_CASE(
    "a ball bouncing to rest: time shooting is left out where the fitted model's jumps are less than two "
    "samples apart, and tried after a false detection",
    "[time_shooting]") {
  const double sigma = 0.01;
  RefineOptions options;
  options.sigma = Vec::Constant(2, sigma);
  {
    // The bounces accumulate at 4.07 s: the samples end there (as `hysid simulate`'s), the last
    // bounces a millisecond apart.
    const Data d(Model(BouncingBall{}), SampleGrid{4.2, 1e-3}, (Vec(2) << 1.0, 0.0).finished(), sigma, 1);
    REQUIRE(d.truth.status.stop == SimStop::kZeno);
    REQUIRE(d.truth.size() > 4000);
    const std::vector<RefineChain> chains = {RefineChain::Uniform(d.y, d.grid.dt, TrueLabels(d.truth))};
    const RefineResult r = Refine(d.model, chains, d.model.alpha(), d.model.beta(), options);
    INFO(r.reason << "; route " << r.route << "; " << r.samples_used << " samples; " << r.span_reason);
    REQUIRE(r.ok());
    REQUIRE(r.chain_span_reason.size() == 1);
    CHECK(r.chain_span_reason[0] == CloseJumpsReason(options));
    const long used = r.samples_used;
    REQUIRE(used < d.truth.size());
    // The truth's own jumps after the last fitted sample come less than two samples apart.
    bool unresolved = false;
    for (std::size_t j = 1; j < d.truth.jumps.size(); ++j) {
      unresolved = unresolved || (d.truth.jumps[j].t > d.truth.t[std::size_t(used - 1)] &&
                                  d.truth.jumps[j].t - d.truth.jumps[j - 1].t < 2 * d.grid.dt);
    }
    CHECK(unresolved);
    REQUIRE(r.routes_tried.size() == 2);
    CHECK(r.routes_tried[1].starts_with("multiple shooting by time: not tried"));
    const Vec theta = r.estimate.Theta(r.unknowns),
              truth = HybridParameters::Of(d.model, d.x0).Theta(r.unknowns);
    for (Eigen::Index i = 0; i < r.unknowns.shared(); ++i)
      CHECK(std::abs(theta[i] - truth[i]) < 4 * r.standard_errors[i]);
  }
  {
    // A false detection 6 samples after the fourth bounce: the span rule cuts there, the fitted model's
    // next jumps are far apart, and time shooting fits every sample.
    const Data d(Model(BouncingBall{}), SampleGrid{3.0, 1e-3}, (Vec(2) << 1.0, 0.0).finished(), sigma, 2);
    REQUIRE(d.truth.jumps.size() >= 5);
    const long fourth = static_cast<long>(std::ceil(d.truth.jumps[3].t / d.grid.dt));
    const std::vector<RefineChain> chains = {
        RefineChain::Uniform(d.y, d.grid.dt, TrueLabels(d.truth, {fourth + 6}))};
    RefineOptions labels_only = options;
    labels_only.routes = {RefineRoute::kLabels};
    labels_only.mend_detections = false;
    const RefineResult labelled = Refine(d.model, chains, d.model.alpha(), d.model.beta(), labels_only);
    INFO(labelled.reason);
    REQUIRE(labelled.ok());
    REQUIRE(labelled.chain_span_reason.size() == 1);
    CHECK(labelled.chain_span_reason[0] == CloseJumpsReason(options));
    double at = 0.0;
    CHECK_FALSE(ModelJumpsUnresolved(d.model, chains, labelled, options, &at));
    RefineOptions then_by_time = labels_only;
    then_by_time.routes = {RefineRoute::kLabels, RefineRoute::kTimeShooting};
    const RefineResult r = Refine(d.model, chains, d.model.alpha(), d.model.beta(), then_by_time);
    INFO(r.reason);
    REQUIRE(r.routes_tried.size() == 2);
    CHECK(r.routes_tried[1].starts_with("multiple shooting by time: ok on"));
    CHECK(r.ok());
    CHECK(r.samples_used == d.truth.size());
  }
}

TEST_CASE("with sigma estimated, residuals far above the data's own noise refuse the fit: outliers left in",
          "[time_shooting]") {
  const double sigma = 0.05;
  const Data d(Model(ImpactMsd{}), SampleGrid{6.0, 2e-3}, (Vec(2) << 20.0, 0.0).finished(), sigma, 11);
  const std::vector<std::uint8_t> no_labels(d.truth.t.size(), 0);
  const HybridParameters start = HybridParameters::Of(d.model, d.x0);
  const RefineOptions options;  // σ estimated
  const RefineResult clean =
      FitByTimeShooting(d.model, {RefineChain::Uniform(d.y, d.grid.dt, no_labels)}, start, options);
  INFO(clean.reason);
  REQUIRE(clean.ok());
  // σ̂ over the MAD estimate of the second differences: about 1 at the noise.
  CHECK(clean.normalized_rms == Approx(1.0).margin(0.1));
  // Every 100th sample of x 50 σ off: σ̂ about 5 σ, the second differences' MAD still about σ.
  Mat y = d.y;
  for (Eigen::Index k = 50; k < y.cols(); k += 100) y(0, k) += (k / 100) % 2 == 0 ? 50 * sigma : -50 * sigma;
  const RefineResult r =
      FitByTimeShooting(d.model, {RefineChain::Uniform(y, d.grid.dt, no_labels)}, start, options);
  INFO(r.reason);
  CHECK(r.status == RefineStatus::kResidualRms);
  CHECK(r.reported);
  CHECK(r.normalized_rms > 3.0);
  CHECK(r.reason.find("MAD estimate") != std::string::npos);
}

// N white residuals per draw: the tests refuse about `alpha` of the draws (σ given: level and whiteness).
TEST_CASE("the residual tests refuse white residuals at their stated size", "[time_shooting]") {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> normal;
  const int draws = 2000;
  int refused = 0;
  for (int i = 0; i < draws; ++i) {
    Mat e(2, 1500);
    for (Eigen::Index k = 0; k < e.size(); ++k) e.data()[k] = 0.3 * normal(rng);
    const ResidualTestResult t = ResidualTests({e}, Vec::Constant(2, 0.3), true, 4, RefineOptions{}.residual_test_size);
    refused += !(t.level_ok && t.white);
  }
  // Binomial(2000, 0.01): mean 20, sd 4.5.
  CHECK(refused >= 5);
  CHECK(refused <= 38);
}

TEST_CASE("the residual tests refuse coloured residuals and a wrong σ", "[time_shooting]") {
  std::mt19937_64 rng(4);
  std::normal_distribution<double> normal;
  Mat white(1, 5000), coloured(1, 5000);
  double ar = 0.0;
  for (Eigen::Index k = 0; k < white.cols(); ++k) {
    white(0, k) = normal(rng);
    ar = 0.1 * ar + normal(rng);
    coloured(0, k) = ar;
  }
  const Vec one = Vec::Ones(1);
  CHECK(ResidualTests({white}, one, true, 2, RefineOptions{}.residual_test_size).white);
  CHECK(ResidualTests({white}, one, true, 2, RefineOptions{}.residual_test_size).level_ok);
  CHECK_FALSE(ResidualTests({coloured}, one, false, 2, RefineOptions{}.residual_test_size).white);  // √N·0.1 ≈ 7
  CHECK_FALSE(ResidualTests({white}, Vec::Constant(1, 1.1), true, 2, RefineOptions{}.residual_test_size).level_ok);
  // Two chains: no lag across their boundary.
  Mat a = white.leftCols(2500), b = -white.rightCols(2500);
  CHECK(ResidualTests({a, b}, one, false, 2, RefineOptions{}.residual_test_size).white);
}

TEST_CASE("the Newey-West meat equals its definition summed term by term, chains scored on their own rows",
          "[time_shooting]") {
  // Rows 0-1 are shared (θ); each chain scores its own rows too; row 7 is no chain's; one chain is empty,
  // one has a single sample.
  const Eigen::Index P = 8;
  const std::vector<std::vector<Eigen::Index>> own = {{0, 1, 2, 3}, {0, 1, 4, 5}, {}, {0, 1, 6}, {0, 1, 2}};
  const std::vector<long> length = {30, 24, 0, 1, 21};
  std::mt19937_64 rng(5);
  std::normal_distribution<double> normal;
  std::vector<std::vector<Vec>> scores(own.size());
  for (std::size_t c = 0; c < own.size(); ++c) {
    for (long k = 0; k < length[c]; ++k) {
      Vec g = Vec::Zero(P);
      for (const Eigen::Index i : own[c]) g[i] = normal(rng);
      scores[c].push_back(g);
    }
  }
  const Mat meat = NeweyWestMeat(scores, P);
  // The definition: N = 76 scores, L = ⌊4 · 0.76^{2/9}⌋ = 3.
  const int L = 3;
  Mat reference = Mat::Zero(P, P);
  for (const auto& g : scores) {
    const auto K = static_cast<long>(g.size());
    for (long k = 0; k < K; ++k) {
      reference += g[std::size_t(k)] * g[std::size_t(k)].transpose();
      for (long l = 1; l <= L && l <= k; ++l) {
        const Vec& a = g[std::size_t(k)];
        const Vec& b = g[std::size_t(k - l)];
        reference += (1.0 - l / (L + 1.0)) * (a * b.transpose() + b * a.transpose());
      }
    }
  }
  CHECK((meat - reference).cwiseAbs().maxCoeff() <= 1e-12 * reference.cwiseAbs().maxCoeff());
  CHECK(meat == meat.transpose());
  CHECK(meat.row(7).isZero(0.0));
  CHECK(meat(2, 4) == 0.0);  // rows of two chains that share none but θ
  CHECK(meat(2, 3) != 0.0);
}

TEST_CASE("the Newey-West meat over N estimates the long-run variance of MA(1) scores", "[time_shooting]") {
  // g_k = e_k + e_{k−1}, e white of variance 1: long-run variance (1 + 1)² = 4; Bartlett's weight on lag 1
  // with L = ⌊4 · 200^{2/9}⌋ = 12 makes the expectation 2 + 2 · (12/13) ≈ 3.85 (sd ≈ 0.1 at N = 20 000).
  std::mt19937_64 rng(6);
  std::normal_distribution<double> normal;
  std::vector<std::vector<Vec>> scores(1);
  double previous = normal(rng);
  for (int k = 0; k < 20000; ++k) {
    const double e = normal(rng);
    scores[0].push_back(Vec::Constant(1, e + previous));
    previous = e;
  }
  double white = 0.0;  // Σ g² / N ≈ 2, the meat of white scores
  for (const Vec& g : scores[0]) white += g[0] * g[0] / 20000.0;
  const double lrv = NeweyWestMeat(scores, 1)(0, 0) / 20000.0;
  CHECK(lrv > 3.5);
  CHECK(lrv < 4.2);
  CHECK(white < 2.2);
}

}  // namespace
}  // namespace hysid
