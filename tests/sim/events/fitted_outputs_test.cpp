// The fitted model over the whole record (sim/events/fitted_outputs.hpp) on the bouncing ball, whose
// free fall has closed forms: h(t) = h0 − g t²/2 before the first impact at t1 = √(2h0/g); with only
// x0[h] uncertain (variance s²), sd(h) = s and sd(v) = 0 before it, and se(t1) = s·dt1/dh0 = s/√(2 g h0);
// a sample detected on the fall's side of the impact is read on the fall continued: h0 − g t²/2 < 0.
#include <catch2/catch.hpp>

#include <cmath>
#include <string>

#include "core/model_file/model_file.hpp"
#include "sim/events/fitted_outputs.hpp"

namespace hysid {
namespace {

constexpr double kG = 9.81, kH0 = 1.0, kS = 0.003;

struct Ball {
  Model model = ReadModelFile(std::string(HYSID_MODELS_DIR) + "/bouncing-ball.toml").model;
  std::vector<double> t;
  Mat y;
  IdentifyResult recursive;
  RefineResult r;
  Ball() {
    for (int k = 0; k <= 100; ++k) t.push_back(0.01 * k);
    y = Mat::Zero(2, 101);
    y.col(0) << kH0, 0.0;
    y.col(60) << 0.5, 0.0;  // the second chain's first sample (two-chain case)
    r.unknowns = Unknowns::Of(model);  // g, lambda, mu, x0[h], x0[v]
    r.estimate = HybridParameters{model.alpha(), model.beta(), Vec::Zero(2), model.gamma()};
    r.start = r.estimate;
    r.start.alpha[1] = 9.5;  // the recursive estimate's g
    r.reported = true;
    r.chain_x0 = {Vec(y.col(0))};
    r.chain_samples_used = {101};
    r.covariance = Mat::Zero(5, 5);
    r.covariance(3, 3) = kS * kS;
    r.chain_covariance = {r.covariance};
  }
};

TEST_CASE("fitted outputs: the fitted and recursive runs, the band and the jump's se in closed form") {
  Ball b;
  const FittedOutputs f = RunFittedModel(b.model, b.t, b.y, {}, Mat(), b.recursive, b.r);
  REQUIRE(f.reason.empty());
  const double t1 = std::sqrt(2 * kH0 / kG);
  for (long k = 0; b.t[std::size_t(k)] < t1; ++k) {
    const double tk = b.t[std::size_t(k)];
    CAPTURE(k);
    CHECK(f.x(0, k) == Approx(kH0 - kG * tk * tk / 2).margin(1e-7));
    CHECK(f.recursive(0, k) == Approx(kH0 - 9.5 * tk * tk / 2).margin(1e-7));
    CHECK(f.sd(0, k) == Approx(kS).epsilon(1e-6));
    CHECK(f.sd(1, k) == Approx(0.0).margin(1e-9));
    CHECK(f.in_fit[std::size_t(k)] == 1);
  }
  REQUIRE(!f.jumps.empty());
  CHECK(f.jumps[0].time == Approx(t1).epsilon(1e-8));
  CHECK(f.jumps[0].se == Approx(kS / std::sqrt(2 * kG * kH0)).epsilon(1e-5));
  CHECK(f.jumps[0].chain == 0);
  CHECK(f.jumps[0].in_fit);
  CHECK(f.mode.empty());  // one mode
}

TEST_CASE("fitted outputs: the residuals' run reads each sample on its detected segment") {
  Ball b;
  const double t1 = std::sqrt(2 * kH0 / kG);
  const auto k1 = static_cast<long>(std::ceil(t1 / 0.01));  // the first sample after the impact
  b.recursive.gamma.assign(101, 0);
  b.recursive.gamma[std::size_t(k1 + 1)] = 1;  // detected one sample late
  const FittedOutputs f = RunFittedModel(b.model, b.t, b.y, {}, Mat(), b.recursive, b.r);
  const double tk = b.t[std::size_t(k1)];
  CHECK(f.x(0, k1) >= 0.0);  // the model's own run: after its impact
  CHECK(f.matched(0, k1) == Approx(kH0 - kG * tk * tk / 2).margin(1e-7));  // the fall continued below 0
  CHECK(f.matched(0, k1) < 0.0);
  CHECK(f.matched(0, k1 - 1) == Approx(f.x(0, k1 - 1)).margin(1e-9));
  CHECK(f.matched(0, k1 + 1) == Approx(f.x(0, k1 + 1)).margin(1e-7));

  b.recursive.gamma.assign(101, 1);  // more detected segments than the model's jumps: the own run
  const FittedOutputs g = RunFittedModel(b.model, b.t, b.y, {}, Mat(), b.recursive, b.r);
  CHECK(g.matched(0, 50) == g.x(0, 50));
}

TEST_CASE("fitted outputs: the band and se of each chain from its own covariance - the fit's span - no fit reported") {
  Ball b;
  const std::vector<std::uint8_t> starts = [] {
    std::vector<std::uint8_t> s(101, 0);
    s[0] = s[60] = 1;
    return s;
  }();
  b.r.chain_x0.push_back(Vec(b.y.col(60)));
  b.r.chain_samples_used = {30, 41};
  constexpr double kS2 = 0.005;  // chain 2's x0[h] sd
  b.r.chain_covariance.push_back(Mat::Zero(5, 5));
  b.r.chain_covariance[1](3, 3) = kS2 * kS2;
  const FittedOutputs f = RunFittedModel(b.model, b.t, b.y, starts, Mat(), b.recursive, b.r);
  CHECK(f.in_fit[29] == 1);
  CHECK(f.in_fit[30] == 0);  // past chain 1's fitted span: the model's prediction
  CHECK(std::isfinite(f.x(0, 45)));
  CHECK(f.in_fit[60] == 1);
  CHECK(f.x(0, 60) == 0.5);
  CHECK(f.sd(0, 60) == Approx(kS2).epsilon(1e-6));
  CHECK(f.sd(0, 61) == Approx(kS2).epsilon(1e-6));
  CHECK(f.sd(0, 20) == Approx(kS).epsilon(1e-6));
  const double t2 = 0.6 + std::sqrt(2 * 0.5 / kG);
  bool found = false;
  for (const FittedJump& j : f.jumps) {
    if (j.chain != 1) continue;
    found = true;
    CHECK(j.time == Approx(t2).epsilon(1e-8));
    CHECK(j.se == Approx(kS2 / std::sqrt(2 * kG * 0.5)).epsilon(1e-5));
    break;
  }
  CHECK(found);
  // A chain without its covariance: no band, no se.
  b.r.chain_covariance[1].resize(0, 0);
  const FittedOutputs bare = RunFittedModel(b.model, b.t, b.y, starts, Mat(), b.recursive, b.r);
  CHECK(std::isnan(bare.sd(0, 60)));
  CHECK(bare.sd(0, 20) == Approx(kS).epsilon(1e-6));
  CHECK(f.jumps[0].in_fit == false);  // t1 ≈ 0.45 > t = 0.29, the last fitted sample of chain 1

  b.r.reported = false;
  const FittedOutputs none = RunFittedModel(b.model, b.t, b.y, starts, Mat(), b.recursive, b.r);
  CHECK(none.x.array().isNaN().all());
  CHECK(none.reason == "the refinement reported no fit");
  CHECK(none.recursive(0, 60) == 0.5);  // the recursive run from each chain's first sample
  CHECK(none.jumps.empty());
}

// The ball with quadratic drag of examples/drag-ball (v' = −g − k|v|v): the recursive estimate's
// negative k blows up in finite time (v' = −g + 50 v² on the way down grows without bound), where
// CVODE would take up to its own limit of 2 000 000 steps; its run has the budget of a run a fit
// evaluates (200 per sample + 1 000), and the fitted run beside it is whole.
TEST_CASE("fitted outputs: the recursive estimate's run stops at a fit's step budget") {
  const Model model = ReadModelFile(std::string(HYSID_EXAMPLES_DIR) + "/drag-ball/drag-ball.toml").model;
  std::vector<double> t;
  for (int k = 0; k <= 100; ++k) t.push_back(0.01 * k);
  Mat y = Mat::Zero(2, 101);
  y.col(0) << 10.0, 0.0;
  RefineResult r;
  r.unknowns = Unknowns::Of(model);
  r.estimate = HybridParameters{model.alpha(), model.beta(), y.col(0), model.gamma()};
  r.start = r.estimate;
  r.start.alpha[2] = -50.0;  // k
  r.reported = true;
  r.chain_x0 = {Vec(y.col(0))};
  r.chain_samples_used = {101};
  const FittedOutputs f = RunFittedModel(model, t, y, {}, Mat(), IdentifyResult{}, r);
  CHECK(f.reason.empty());
  CHECK(f.x.allFinite());
  CHECK(f.x(0, 100) < 10.0);
  CHECK(f.recursive_reason.find("step budget of 21200 CVODE steps") != std::string::npos);
  CHECK(std::isnan(f.recursive(0, 100)));
  CHECK(std::isfinite(f.recursive(0, 0)));
}

}  // namespace
}  // namespace hysid
