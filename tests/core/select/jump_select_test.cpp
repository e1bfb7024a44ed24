// Selection among candidate terms of a jump row (core/select/select.hpp SumJumps): the jumps' rows are
// the jump regression's own (checked against ψ of the data by hand); on a simulated bouncing ball the
// restitution map's support is recovered from six candidate terms of the pre-impact state, by
// leave-one-jump-out cross-validation, for v+ = -e v and for v+ = -e v + c v|v|; the bootstrap over
// jumps chooses the true terms in almost every draw.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "core/model_file/model_file.hpp"
#include "core/select/select.hpp"
#include "sim/measurement.hpp"
#include "sim/simulator.hpp"
#include "tests/testing/vec.hpp"

namespace hysid {
namespace {

using testing::V;

constexpr const char* kBallTail = R"toml(
[[guard]]
name = "floor"
h = "h"
direction = "falling"
project = { h = "0" }
[sets]
C = "h > 0 || (h == 0 && v >= 0)"
D = "h == 0 && v <= 0"
[defaults]
x0 = [1.0, 0.0]
t_end = 15.0
dt = 1e-3
)toml";

// A ball falling from 1 m, g = 9.81, v+ = -0.95 v + c v|v| (c = 0: Newton's restitution).
std::string BallTruth(double c) {
  return "name = \"bounce\"\nstates = [\"h\", \"v\"]\n"
         "alpha = [ { name = \"one\", value = 1.0, known = true }, { name = \"g\", value = 9.81 } ]\n"
         "beta = [ { name = \"one_h\", value = 1.0, known = true }, { name = \"e\", value = 0.95 }, "
         "{ name = \"c\", value = " +
         std::to_string(c) +
         " } ]\n[flow]\nphi = [[\"v\", 0], [0, -1]]\nrows = [\"v\"]\n"
         "[jump]\npsi = [[\"h\", 0, 0], [0, \"-v\", \"v*abs(v)\"]]\nrows = [\"v\"]\n" +
         kBallTail;
}

// The library of analysis/select/bounce_library.toml: v+ from six candidate terms.
constexpr const char* kTerms = R"x(["v", "v*abs(v)", "1", "v^3", "h", "sqrt(abs(v))"])x";

std::string BallLibrary() {
  return std::string("name = \"bounce-library\"\nstates = [\"h\", \"v\"]\n"
                     "alpha = [ { name = \"one\", value = 1.0, known = true }, { name = \"g\", value = 9.81 } ]\n"
                     "beta = [ { name = \"one_h\", value = 1.0, known = true } ]\n"
                     "[flow]\nphi = [[\"v\", 0], [0, -1]]\nrows = [\"v\"]\n"
                     "[jump]\npsi = [[\"h\"], [0]]\nrows = [\"v\"]\ncandidates = { v = ") +
         kTerms + " }\n" + kBallTail;
}

struct Data {
  Mat y;
  std::vector<std::uint8_t> gamma;
};

// The truth simulated from h = 1 m at rest, noise σ per state, jumps labelled from the true j: 15 s
// (37 impacts; the impacts accumulate at 17.6 s) for c = 0, else 8 s (26 impacts of c = 0.02, which
// accumulate at 9.7 s).
Data Simulated(double c, double sigma, std::uint64_t seed) {
  const Model truth = ParseModelFile(BallTruth(c), "truth.toml").model;
  const Trajectory traj = Simulate(truth, V(1.0, 0.0), SampleGrid{c == 0.0 ? 15.0 : 8.0, 1e-3});
  REQUIRE(traj.status.completed());
  Data d{AddMeasurementNoise(traj.x, Vec::Constant(2, sigma), NoiseKey{.seed = seed, .stream = 0}), {}};
  d.gamma.assign(traj.j.size(), 0);
  for (std::size_t k = 1; k < traj.j.size(); ++k) d.gamma[k] = traj.j[k] != traj.j[k - 1] ? 1 : 0;
  return d;
}

FlowSums Sums(const Model& library, const Data& d) {
  return SumJumps(library, JumpSamples{.y = &d.y, .gamma = &d.gamma, .dt = 1e-3});
}

const SelectOptions kLeaveOneOut{.folds = 0};

std::string Chosen(const Model& library, const std::vector<bool>& chosen) {
  std::string out;
  for (std::size_t j = 0; j < chosen.size(); ++j)
    if (chosen[j]) out += library.spec().jump_candidates[j].term + " ";
  return out;
}

}  // namespace

TEST_CASE("jump sums: one uncentred group per jump, its rows psi(y-) and v+ of the data", "[select]") {
  const Model library = ParseModelFile(BallLibrary(), "library.toml").model;
  const Data d = Simulated(0.0, 0.01, 1);
  const FlowSums sums = Sums(library, d);
  CHECK_FALSE(sums.centred);
  CHECK(sums.columns == std::vector<int>{1, 2, 3, 4, 5, 6});
  long jumps = 0;
  for (std::size_t k = 1; k < d.gamma.size(); ++k) jumps += d.gamma[k];
  REQUIRE(jumps == 37);
  REQUIRE(sums.segments.size() == std::size_t(jumps));
  std::size_t g = 0;
  for (Eigen::Index k = 1; k < d.y.cols(); ++k) {
    if (d.gamma[std::size_t(k)] == 0) continue;
    const double h = d.y(0, k - 1), v = d.y(1, k - 1), plus = d.y(1, k);
    const Vec psi = (Vec(6) << v, v * std::abs(v), 1.0, v * v * v, h, std::sqrt(std::abs(v))).finished();
    const RowSums& r = sums.segments[g++].rows.at(0);
    CHECK(r.count == 1);
    CHECK(r.square == Approx(plus * plus).epsilon(1e-14));
    CHECK((r.cross - psi * plus).norm() <= 1e-12 * (psi * plus).norm());
    CHECK((r.gram - psi * psi.transpose()).norm() <= 1e-12 * (psi * psi.transpose()).norm());
  }
}

TEST_CASE("a bouncing ball with 6 candidate terms of v+: the support of v+ = -e v is chosen, with e", "[select]") {
  const Model library = ParseModelFile(BallLibrary(), "library.toml").model;
  REQUIRE(library.spec().jump_candidates.size() == 6);
  const std::vector<bool> truth{true, false, false, false, false, false};
  for (const double sigma : {0.01, 0.03}) {
    for (const std::uint64_t seed : {1u, 2u, 3u}) {
      INFO("sigma " << sigma << ", seed " << seed);
      const FlowSums sums = Sums(library, Simulated(0.0, sigma, seed));
      const Selection s = SelectTerms(sums, std::vector<bool>(6, true), kLeaveOneOut);
      REQUIRE(s.ok);
      INFO("chosen " << Chosen(library, s.chosen));
      CHECK(s.chosen == truth);
      CHECK(s.estimate[0] == Approx(-0.95).margin(0.01));
      CHECK(s.rows == long(sums.segments.size()));  // one row per jump, no offsets
    }
  }
}

// Cross-validation alone keeps the pre-impact height h beside the truth in some draws (seed 3): h ≈ |v|τ,
// τ the time from the sample before the impact to the impact, which shifts v+ of the samples by about
// g(1 + e)τ − gδt; the bootstrap chooses it in few draws and the stability rule drops it.
TEST_CASE("a bouncing ball with v+ = -e v + c v|v|: the support {v, v|v|} is chosen, with e and c", "[select]") {
  const Model library = ParseModelFile(BallLibrary(), "library.toml").model;
  const std::vector<bool> selectable(6, true), truth{true, true, false, false, false, false};
  for (const std::uint64_t seed : {1u, 2u, 3u}) {
    INFO("seed " << seed);
    const FlowSums sums = Sums(library, Simulated(0.02, 0.01, seed));
    const Selection cv = SelectTerms(sums, selectable, kLeaveOneOut);
    REQUIRE(cv.ok);
    const BootstrapResult b = BootstrapSelection(sums, selectable, kLeaveOneOut, 100, seed, cv.chosen);
    const Selection s = KeepStable(sums, selectable, cv, b, kLeaveOneOut);
    REQUIRE(s.ok);
    INFO("chosen " << Chosen(library, s.chosen));
    CHECK(s.chosen == truth);
    CHECK(s.estimate[0] == Approx(-0.95).margin(0.02));
    CHECK(s.estimate[1] == Approx(0.02).margin(0.005));
  }
}

TEST_CASE("the bootstrap over jumps chooses v in every draw and the other terms seldom", "[select]") {
  const Model library = ParseModelFile(BallLibrary(), "library.toml").model;
  const FlowSums sums = Sums(library, Simulated(0.0, 0.01, 4));
  const std::vector<bool> selectable(6, true), truth{true, false, false, false, false, false};
  const BootstrapResult b = BootstrapSelection(sums, selectable, kLeaveOneOut, 50, 7, truth);
  REQUIRE(b.draws == 50);
  CHECK(b.frequency[0] >= 0.95);
  for (int j = 1; j < 6; ++j) CHECK(b.frequency[j] < 0.5);
  const Selection s = KeepStable(sums, selectable, SelectTerms(sums, selectable, kLeaveOneOut), b, kLeaveOneOut);
  REQUIRE(s.ok);
  CHECK(s.chosen == truth);
}

TEST_CASE("jump sums: [[jump]] maps and bad sizes are refused by name", "[select]") {
  const Model library = ParseModelFile(BallLibrary(), "library.toml").model;
  const Mat y(3, 10);
  const std::vector<std::uint8_t> gamma(10, 0);
  CHECK_THROWS_WITH(SumJumps(library, JumpSamples{.y = &y, .gamma = &gamma, .dt = 1e-3}),
                    Catch::Contains("sizes disagree"));
  CHECK_THROWS_WITH(SelectTerms(FlowSums{}, {}, SelectOptions{.folds = 1}),
                    Catch::Contains("SelectOptions::folds = 1: must be >= 2, or 0"));
}

// The rule's choice between leave-one-jump-out and 5-fold cross-validation over jumps, measured (run by
// hand: jump_select_test "[.study]"): exact supports in 50 draws per σ and truth, true jump labels.
TEST_CASE("study: leave-one-jump-out against 5-fold cross-validation over the jumps", "[.study]") {
  const Model library = ParseModelFile(BallLibrary(), "library.toml").model;
  const std::vector<bool> selectable(6, true);
  for (const double c : {0.0, 0.02}) {
    const std::vector<bool> truth{true, c != 0.0, false, false, false, false};
    for (const double sigma : {0.01, 0.03}) {
      int exact[4] = {0, 0, 0, 0};  // LOO, 5-fold, each without and with the stability rule
      for (std::uint64_t seed = 1; seed <= 50; ++seed) {
        const FlowSums sums = Sums(library, Simulated(c, sigma, seed));
        int i = 0;
        for (const SelectOptions& o : {kLeaveOneOut, SelectOptions{}}) {
          const Selection s = SelectTerms(sums, selectable, o);
          const BootstrapResult b = BootstrapSelection(sums, selectable, o, 100, seed, s.chosen);
          exact[i] += s.ok && s.chosen == truth;
          exact[i + 1] += s.ok && KeepStable(sums, selectable, s, b, o).chosen == truth;
          i += 2;
        }
      }
      std::printf("c = %g, sigma = %g: exact in 50 draws: leave-one-out %d (with stability %d), 5-fold %d (%d)\n",
                  c, sigma, exact[0], exact[1], exact[2], exact[3]);
    }
  }
}

}  // namespace hysid
