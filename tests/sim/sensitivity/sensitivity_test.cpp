// Hybrid forward sensitivities against central differences of the simulator (all three built-in
// models), the matched (hybrid time domain) mode against central differences of itself, the §5
// CRLB against the independent figures (and with ξ0 known), and the mean Gaussian norm against closed
// forms.
#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>

#include "core/builtin/bouncing_ball.hpp"
#include "core/builtin/impact_msd.hpp"
#include "core/builtin/impact_pendulum.hpp"
#include "sim/sensitivity/crlb.hpp"

namespace hysid {
namespace {

Vec DefaultX0(const Model& m) {
  const auto& v = m.spec().default_x0;
  return Eigen::Map<const Vec>(v.data(), static_cast<Eigen::Index>(v.size()));
}

// States of Simulate at θ (the unknown α, β entries set by name; ξ0 the last n entries).
Trajectory SimulateAt(Model model, const Unknowns& u, const Vec& theta, const SampleGrid& grid) {
  const auto names = u.Names(model);
  const auto np = static_cast<Eigen::Index>(u.alpha.size() + u.beta.size());
  for (Eigen::Index i = 0; i < np; ++i) model.SetParameter(names[static_cast<std::size_t>(i)], theta[i]);
  return Simulate(model, theta.tail(model.state_size()), grid);
}

// Largest |S_k − central difference| over samples whose jump count agrees in the ± runs, per column
// relative to the column's largest |S|.
double WorstRelativeError(const Model& model, const SampleGrid& grid) {
  const Unknowns u = Unknowns::Of(model);
  const HybridParameters nominal = HybridParameters::Of(model, DefaultX0(model));
  const SensitivityTrajectory s = SimulateSensitivities(model, nominal, u, grid);
  REQUIRE(s.ok());
  const Vec theta = nominal.Theta(u);
  const int n = model.state_size();
  double worst = 0.0;
  for (Eigen::Index i = 0; i < theta.size(); ++i) {
    const double h = 1e-4 * std::max(1.0, std::abs(theta[i]));
    Vec tp = theta, tm = theta;
    tp[i] += h;
    tm[i] -= h;
    const Trajectory plus = SimulateAt(model, u, tp, grid), minus = SimulateAt(model, u, tm, grid);
    REQUIRE(plus.size() == s.trajectory.size());
    REQUIRE(minus.size() == s.trajectory.size());
    double scale = 0.0, err = 0.0;
    long compared = 0;
    for (long k = 0; k < s.trajectory.size(); ++k) {
      const auto ku = static_cast<std::size_t>(k);
      const Vec sk = s.S(k).col(i);
      scale = std::max(scale, sk.cwiseAbs().maxCoeff());
      if (plus.j[ku] != s.trajectory.j[ku] || minus.j[ku] != s.trajectory.j[ku]) continue;
      const Vec fd = (plus.x.col(k) - minus.x.col(k)) / (2 * h);
      err = std::max(err, (fd - sk).cwiseAbs().maxCoeff());
      ++compared;
    }
    CHECK(compared > s.trajectory.size() - 4 * static_cast<long>(s.trajectory.jumps.size()) - 4);
    worst = std::max(worst, err / scale);
    UNSCOPED_INFO("column " << i << ": " << err / scale);
    (void)n;
  }
  return worst;
}

TEST_CASE("sensitivities match central differences: impact-msd (§5, 14 jumps)", "[sensitivity]") {
  const Model model{ImpactMsd{}};
  const double worst = WorstRelativeError(model, SampleGrid{20.0, 5e-4});
  CHECK(worst < 1e-5);
}

TEST_CASE("sensitivities match central differences: bouncing ball before its Zeno time", "[sensitivity]") {
  const Model model{BouncingBall{}};
  const double worst = WorstRelativeError(model, SampleGrid{3.0, 1e-3});
  CHECK(worst < 1e-5);
}

TEST_CASE("sensitivities match central differences: impact pendulum (nonlinear flow)", "[sensitivity]") {
  const Model model{ImpactPendulum{}};
  const double worst = WorstRelativeError(model, SampleGrid{8.0, 1e-3});
  CHECK(worst < 1e-5);
}

TEST_CASE("matched mode: same as plain on the true segments, smooth in θ off them", "[sensitivity]") {
  const Model model{ImpactMsd{}};
  const SampleGrid grid{6.0, 5e-4};
  const Unknowns u = Unknowns::Of(model);
  const HybridParameters nominal = HybridParameters::Of(model, DefaultX0(model));
  const SensitivityTrajectory plain = SimulateSensitivities(model, nominal, u, grid);
  REQUIRE(plain.ok());
  REQUIRE(plain.trajectory.jumps.size() >= 3);
  const SensitivityTrajectory same =
      SimulateSensitivitiesMatched(model, nominal, u, grid, plain.trajectory.j);
  REQUIRE(same.ok());
  CHECK(same.extra_jumps == 0);
  CHECK((same.trajectory.x - plain.trajectory.x).cwiseAbs().maxCoeff() < 1e-8);
  CHECK((same.sensitivities - plain.sensitivities).cwiseAbs().maxCoeff() <
        1e-6 * plain.sensitivities.cwiseAbs().maxCoeff());
  // Move each detected jump 3 samples late (first jump) and 3 early (second): those samples are
  // read from the continued flow of the neighbouring segment.
  std::vector<int> seg = plain.trajectory.j;
  const long k1 = static_cast<long>(std::lround(plain.trajectory.jumps[0].t / grid.dt));
  const long k2 = static_cast<long>(std::lround(plain.trajectory.jumps[1].t / grid.dt));
  for (long k = k1 - 3; k <= k1 + 3; ++k) seg[static_cast<std::size_t>(k)] = 0;
  for (long k = k2 - 3; k <= k2 + 3; ++k) seg[static_cast<std::size_t>(k)] = 2;
  const SensitivityTrajectory moved = SimulateSensitivitiesMatched(model, nominal, u, grid, seg);
  REQUIRE(moved.ok());
  const Vec theta = nominal.Theta(u);
  for (Eigen::Index i = 0; i < theta.size(); ++i) {
    const double h = 1e-4 * std::max(1.0, std::abs(theta[i]));
    Vec tp = theta, tm = theta;
    tp[i] += h;
    tm[i] -= h;
    const auto plus = SimulateSensitivitiesMatched(model, nominal.WithTheta(u, tp), u, grid, seg,
                                                   {.sim = {}, .sensitivities = false});
    const auto minus = SimulateSensitivitiesMatched(model, nominal.WithTheta(u, tm), u, grid, seg,
                                                    {.sim = {}, .sensitivities = false});
    REQUIRE(plus.ok());
    REQUIRE(minus.ok());
    double err = 0.0, scale = 0.0;
    for (long k = 0; k < moved.trajectory.size(); ++k) {
      const Vec fd = (plus.trajectory.x.col(k) - minus.trajectory.x.col(k)) / (2 * h);
      err = std::max(err, (fd - moved.S(k).col(i)).cwiseAbs().maxCoeff());
      scale = std::max(scale, moved.S(k).col(i).cwiseAbs().maxCoeff());
    }
    CHECK(err < 1e-5 * scale);
  }
}

TEST_CASE("matched mode: a model with fewer jumps than the data reports them missing", "[sensitivity]") {
  const Model model{ImpactMsd{}};
  const SampleGrid grid{3.0, 5e-4};
  const Unknowns u = Unknowns::Of(model);
  const HybridParameters nominal = HybridParameters::Of(model, DefaultX0(model));
  const SensitivityTrajectory plain = SimulateSensitivities(model, nominal, u, grid);
  std::vector<int> seg = plain.trajectory.j;
  const int last = seg.back();
  for (std::size_t k = seg.size() - 10; k < seg.size(); ++k) seg[k] = last + 1;
  const SensitivityTrajectory s = SimulateSensitivitiesMatched(model, nominal, u, grid, seg);
  CHECK_FALSE(s.ok());
  CHECK(s.missing_jumps == 1);
  std::vector<int> fewer = plain.trajectory.j;
  for (int& j : fewer) j = std::min(j, last - 1);
  const SensitivityTrajectory more = SimulateSensitivitiesMatched(model, nominal, u, grid, fewer);
  CHECK(more.ok());
  CHECK(more.extra_jumps == 1);
}

TEST_CASE("CRLB of the §5 system (x0 unknown) within 2 % of the independent figures", "[sensitivity]") {
  const Model model{ImpactMsd{}};
  const Crlb c =
      ComputeCrlb(model, DefaultX0(model), SampleGrid{20.0, 5e-4}, Vec::Ones(2), Unknowns::Of(model));
  REQUIRE(c.ok());
  CHECK(c.jumps == 14);
  const double expected[] = {2.0825e-4, 1.0913e-3, 8.3699e-4, 1.0947e-2, 9.6756e-3, 1.7499e-2};
  REQUIRE(c.sd.size() == 6);
  for (int i = 0; i < 6; ++i) CHECK(c.sd[i] == Approx(expected[i]).epsilon(0.02));
  CHECK(c.mean_e_alpha == Approx(9.12e-4).epsilon(0.02));
  CHECK(c.mean_e_beta == Approx(8.81e-3).epsilon(0.02));
  // ξ0 known, and linear scaling with σ.
  const Crlb known = ComputeCrlb(model, DefaultX0(model), SampleGrid{20.0, 5e-4}, Vec::Constant(2, 0.25),
                                 Unknowns::Of(model, false));
  REQUIRE(known.ok());
  const double expected_known[] = {1.593e-4, 1.033e-3, 7.684e-4, 8.402e-3};
  for (int i = 0; i < 4; ++i) CHECK(known.sd[i] == Approx(0.25 * expected_known[i]).epsilon(0.02));
}

TEST_CASE("the bound on the samples present: the information of those samples alone", "[sensitivity]") {
  const Model model{ImpactMsd{}};
  const Unknowns u = Unknowns::Of(model);
  const SampleGrid grid{20.0, 5e-4};
  const SensitivityTrajectory s =
      SimulateSensitivities(model, HybridParameters::Of(model, DefaultX0(model)), u, grid);
  REQUIRE(s.ok());
  const auto k_count = static_cast<std::size_t>(s.trajectory.size());
  // Every other sample of the first half, and a gap of the second: the two sets and their complement.
  std::vector<std::uint8_t> some(k_count, 0), rest(k_count, 1), all(k_count, 1);
  for (std::size_t k = 0; k < k_count; ++k) {
    some[k] = (k < k_count / 2 && k % 2 == 0) || k > 3 * k_count / 4 ? 1 : 0;
    rest[k] = 1 - some[k];
  }
  const Mat whole = FisherInformation(s, Vec::Ones(2));
  CHECK((FisherInformation(s, Vec::Ones(2), {}, all) - whole).norm() == 0.0);
  const Mat parts =
      FisherInformation(s, Vec::Ones(2), {}, some) + FisherInformation(s, Vec::Ones(2), {}, rest);
  CHECK((parts - whole).norm() <= 1e-12 * whole.norm());
  // The first 10 s alone: the bound of the grid that ends there.
  std::vector<std::uint8_t> first(k_count, 0);
  const SampleGrid half{10.0, 5e-4};
  std::fill(first.begin(), first.begin() + half.size(), 1);
  const Crlb cut = ComputeCrlb(model, DefaultX0(model), grid, Vec::Ones(2), u, {}, {}, nullptr, first);
  const Crlb shorter = ComputeCrlb(model, DefaultX0(model), half, Vec::Ones(2), u);
  REQUIRE(cut.ok());
  REQUIRE(shorter.ok());
  CHECK(cut.samples == half.size());
  for (Eigen::Index i = 0; i < cut.sd.size(); ++i) CHECK(cut.sd[i] == Approx(shorter.sd[i]).epsilon(1e-6));
  CHECK_THROWS_WITH(FisherInformation(s, Vec::Ones(2), {}, std::vector<std::uint8_t>(3, 1)),
                    Catch::Contains("present has 3 entries for"));
}

TEST_CASE("x0 known: every component held is the bound without x0 in theta", "[sensitivity]") {
  const Model model{ImpactMsd{}};
  const SampleGrid grid{20.0, 5e-4};
  const Unknowns with_x0 = Unknowns::Of(model);
  const Crlb c = ComputeCrlb(model, DefaultX0(model), grid, Vec::Ones(2), with_x0);
  const Crlb without = ComputeCrlb(model, DefaultX0(model), grid, Vec::Ones(2), Unknowns::Of(model, false));
  REQUIRE(c.ok());
  REQUIRE(without.ok());
  const Crlb held = HoldKnownX0(c, with_x0, {0, 1}, 2);
  REQUIRE(held.ok());
  REQUIRE(held.sd.size() == 6);
  for (int i = 0; i < 4; ++i) CHECK(held.sd[i] == Approx(without.sd[i]).epsilon(1e-9));
  CHECK(held.sd[4] == 0.0);
  CHECK(held.sd[5] == 0.0);
  CHECK(held.samples == c.samples);
  CHECK(held.jumps == 14);
  // One component held: between the two; none held: the bound itself.
  const Crlb one = HoldKnownX0(c, with_x0, {1}, 2);
  REQUIRE(one.ok());
  CHECK(one.sd[5] == 0.0);
  for (int i = 0; i < 4; ++i) CHECK((one.sd[i] <= c.sd[i] && one.sd[i] >= held.sd[i] * (1 - 1e-12)));
  CHECK((HoldKnownX0(c, with_x0, {}, 2).sd.array() == c.sd.array()).all());
}

TEST_CASE(
    "determined sd: a singular F gives each entry off its null direction the sd of any generalised inverse",
    "[sensitivity]") {
  // θ = (a, b, c, d) with d's column 2.5 times c's: (0, 0, 2.5, −1) spans the null space. b in units
  // 1e6 times larger: equilibration, not the raw scale, decides.
  Mat J(40, 4);
  for (int k = 0; k < 40; ++k) {
    const double t = 0.1 * k;
    J(k, 0) = std::sin(t) + 0.3;
    J(k, 1) = 1e6 * std::cos(1.7 * t) * t;
    J(k, 2) = std::exp(-0.4 * t) + 0.5 * std::sin(t);
    J(k, 3) = 2.5 * J(k, 2);
  }
  const Mat F = J.transpose() * J;
  const Vec sd = DeterminedSd(F);
  REQUIRE(sd.size() == 4);
  CHECK(std::isnan(sd[2]));
  CHECK(std::isnan(sd[3]));
  // Holding c or d known (either one removes the null direction) gives a and b the same sd.
  for (const int known : {2, 3}) {
    const Crlb held = CrlbFromFisher(F, Unknowns{.alpha = {0, 1, 2, 3}, .beta = {}, .gamma = {}, .x0 = false},
                                     {"a", "b", "c", "d"}, {known});
    REQUIRE(held.ok());
    CHECK(sd[0] == Approx(held.sd[0]).epsilon(1e-7));
    CHECK(sd[1] == Approx(held.sd[1]).epsilon(1e-7));
    // A held α entry leaves the α block's mean error to the other three.
    const std::vector<Eigen::Index> kept =
        known == 2 ? std::vector<Eigen::Index>{0, 1, 3} : std::vector<Eigen::Index>{0, 1, 2};
    CHECK(held.mean_e_alpha == Approx(MeanGaussianNorm(held.covariance(kept, kept))).epsilon(1e-12));
  }
  // Full rank: the inverse's sd.
  const Mat full = J.leftCols(3).transpose() * J.leftCols(3);
  const Crlb bound = CrlbFromFisher(full, Unknowns{.alpha = {0, 1, 2}, .beta = {}, .gamma = {}, .x0 = false},
                                    {"a", "b", "c"});
  REQUIRE(bound.ok());
  const Vec all = DeterminedSd(full);
  for (int i = 0; i < 3; ++i) CHECK(all[i] == Approx(bound.sd[i]).epsilon(1e-7));
  // A null direction through every entry: none is determined.
  Mat K = J.leftCols(3);
  K.col(2) = J.col(0) - 1e-6 * J.col(1);
  const Vec none = DeterminedSd(K.transpose() * K);
  for (int i = 0; i < 3; ++i) CHECK(std::isnan(none[i]));
  CHECK(DeterminedSd(Mat()).size() == 0);
}

TEST_CASE("mean Gaussian norm: closed forms in 1, 2 and 3 dimensions", "[sensitivity]") {
  const double s = 0.3;
  CHECK(MeanGaussianNorm(Mat::Identity(1, 1) * s * s) ==
        Approx(s * std::sqrt(2 / std::numbers::pi)).epsilon(1e-10));
  CHECK(MeanGaussianNorm(Mat::Identity(2, 2) * s * s) ==
        Approx(s * std::sqrt(std::numbers::pi / 2)).epsilon(1e-10));
  CHECK(MeanGaussianNorm(Mat::Identity(3, 3) * s * s) ==
        Approx(2 * s * std::sqrt(2 / std::numbers::pi)).epsilon(1e-10));
  // Rotation invariance: a correlated 2-D covariance with eigenvalues 4 and 0 is |N(0, 4)|.
  Mat c(2, 2);
  c << 2, 2, 2, 2;
  CHECK(MeanGaussianNorm(c) == Approx(2 * std::sqrt(2 / std::numbers::pi)).epsilon(1e-9));
  CHECK(MeanGaussianNorm(Mat()) == 0.0);
}

TEST_CASE("bad inputs name the field", "[sensitivity]") {
  const Model model{ImpactMsd{}};
  Unknowns u = Unknowns::Of(model);
  u.alpha.push_back(7);
  CHECK_THROWS_WITH(
      SimulateSensitivities(model, HybridParameters::Of(model, DefaultX0(model)), u, SampleGrid{1.0, 1e-3}),
      Catch::Contains("Unknowns::alpha has index 7"));
  std::vector<int> seg(1001, 0);
  seg[5] = 2;
  seg[6] = 1;
  CHECK_THROWS_WITH(SimulateSensitivitiesMatched(model, HybridParameters::Of(model, DefaultX0(model)),
                                                 Unknowns::Of(model), SampleGrid{1.0, 1e-3}, seg),
                    Catch::Contains("segment_of_sample[6] = 1 after 2"));
}

}  // namespace
}  // namespace hysid
