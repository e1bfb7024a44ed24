// Selection among candidate terms of a jump row (core/select/select.hpp SumJumps): the jumps' rows are
// the jump regression's own (checked against ψ of the data by hand); on a simulated bouncing ball the
// restitution map's support is recovered from six candidate terms of the pre-impact state, by
// leave-one-jump-out cross-validation, for v+ = -e v and for v+ = -e v + c v|v|; the bootstrap over
// jumps chooses the true terms in almost every draw. With [[jump]] maps (a ball between a floor and a
// ceiling) each map's sums hold its own jumps in its β slice, and each map's support is chosen there.
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

TEST_CASE("jump sums: bad sizes are refused by name", "[select]") {
  const Model library = ParseModelFile(BallLibrary(), "library.toml").model;
  const Mat y(3, 10);
  const std::vector<std::uint8_t> gamma(10, 0);
  CHECK_THROWS_WITH(SumJumps(library, JumpSamples{.y = &y, .gamma = &gamma, .dt = 1e-3}),
                    Catch::Contains("sizes disagree"));
  CHECK_THROWS_WITH(SelectTerms(FlowSums{}, {}, SelectOptions{.folds = 1}),
                    Catch::Contains("SelectOptions::folds = 1: must be >= 2, or 0"));
}

namespace {

// A ball between a floor (h = 0) and a ceiling (h = 2), one [[jump]] map each: the truth's floor gives
// v+ = -0.98 v, its ceiling v+ = -0.9 v + 0.01 v|v| (`ceiling_psi`, `ceiling_beta`); the library's maps
// keep h and list candidate terms of v+ (`floor_terms`, `ceiling_terms`).
std::string TwoMaps(const std::string& floor_beta, const std::string& floor_psi, const std::string& floor_extra,
                    const std::string& ceiling_beta, const std::string& ceiling_psi, const std::string& ceiling_extra) {
  return "name = \"floor-ceiling\"\nstates = [\"h\", \"v\"]\n"
         "alpha = [ { name = \"one\", value = 1.0, known = true }, { name = \"g\", value = 9.81 } ]\n"
         "[flow]\nphi = [[\"v\", 0], [0, -1]]\nrows = [\"v\"]\n"
         "[[jump]]\nname = \"floor\"\nguard = \"floor\"\nbeta = [ { name = \"one_f\", value = 1.0, known = true }" +
         floor_beta + " ]\npsi = " + floor_psi + "\nrows = [\"v\"]\n" + floor_extra +
         "[[jump]]\nname = \"ceiling\"\nguard = \"ceiling\"\nbeta = [ { name = \"one_c\", value = 1.0, known = true }" +
         ceiling_beta + " ]\npsi = " + ceiling_psi + "\nrows = [\"v\"]\n" + ceiling_extra +
         "[[guard]]\nname = \"floor\"\nh = \"h\"\ndirection = \"falling\"\nproject = { h = \"0\" }\n"
         "[[guard]]\nname = \"ceiling\"\nh = \"h - 2\"\ndirection = \"rising\"\nproject = { h = \"2\" }\n"
         "[defaults]\nx0 = [1.0, 20.0]\nt_end = 3.0\ndt = 1e-3\n";
}

std::string TwoMapsTruth() {
  return TwoMaps(", { name = \"e_f\", value = 0.98 }", "[[\"h\", 0], [0, \"-v\"]]", "",
                 ", { name = \"e_c\", value = 0.9 }, { name = \"c_c\", value = 0.01 }",
                 "[[\"h\", 0, 0], [0, \"-v\", \"v*abs(v)\"]]", "");
}

std::string TwoMapsLibrary() {
  return TwoMaps("", "[[\"h\"], [0]]", "candidates = { v = [\"v\", \"v*abs(v)\", \"1\", \"h\"] }\n", "",
                 "[[\"h\"], [0]]", "candidates = { v = [\"v\", \"v*abs(v)\", \"1\", \"v^3\"] }\n");
}

// Four runs from h = 1 m at 14, 17, 20 and 23 m/s upward, 3 s each, noise σ on both states, as one
// sample matrix with chain starts; gamma and the map per sample from the simulated jumps.
struct MapData {
  Mat y;
  std::vector<std::uint8_t> gamma, chain_start;
  std::vector<int> maps;
};

MapData SimulatedTwoMaps(double sigma, std::uint64_t seed) {
  const Model truth = ParseModelFile(TwoMapsTruth(), "truth.toml").model;
  MapData d;
  std::vector<Mat> runs;
  for (const double v0 : {14.0, 17.0, 20.0, 23.0}) {
    const Trajectory traj = Simulate(truth, V(1.0, v0), SampleGrid{3.0, 1e-3});
    REQUIRE(traj.status.completed());
    runs.push_back(AddMeasurementNoise(traj.x, Vec::Constant(2, sigma),
                                       NoiseKey{.seed = seed, .stream = std::uint64_t(runs.size())}));
    for (std::size_t k = 0; k < traj.j.size(); ++k) {
      const bool jumped = k > 0 && traj.j[k] != traj.j[k - 1];
      d.gamma.push_back(jumped ? 1 : 0);
      d.chain_start.push_back(k == 0 ? 1 : 0);
      d.maps.push_back(jumped ? traj.jumps[std::size_t(traj.j[k] - 1)].map : -1);
    }
  }
  Eigen::Index cols = 0;
  for (const Mat& r : runs) cols += r.cols();
  d.y.resize(2, cols);
  cols = 0;
  for (const Mat& r : runs) {
    d.y.middleCols(cols, r.cols()) = r;
    cols += r.cols();
  }
  return d;
}

FlowSums MapSums(const Model& library, const MapData& d, int map) {
  return SumJumps(library, JumpSamples{.y = &d.y, .gamma = &d.gamma, .dt = 1e-3, .chain_start = &d.chain_start,
                                       .maps = &d.maps, .map = map});
}

}  // namespace

TEST_CASE("jump sums of [[jump]] maps: each map's jumps only, psi of that map in its beta slice", "[select]") {
  const Model library = ParseModelFile(TwoMapsLibrary(), "library.toml").model;
  REQUIRE(library.spec().beta.size() == 10);
  const MapData d = SimulatedTwoMaps(0.01, 1);
  for (const int map : {0, 1}) {
    INFO("map " << map);
    const FlowSums sums = MapSums(library, d, map);
    CHECK(sums.columns == std::vector<int>{1, 2, 3, 4, 6, 7, 8, 9});
    std::size_t g = 0;
    for (Eigen::Index k = 1; k < d.y.cols(); ++k) {
      if (d.gamma[std::size_t(k)] == 0 || d.chain_start[std::size_t(k)] != 0 || d.maps[std::size_t(k)] != map)
        continue;
      const double h = d.y(0, k - 1), v = d.y(1, k - 1), plus = d.y(1, k);
      const Vec own = map == 0 ? (Vec(4) << v, v * std::abs(v), 1.0, h).finished()
                               : (Vec(4) << v, v * std::abs(v), 1.0, v * v * v).finished();
      Vec psi = Vec::Zero(8);
      psi.segment(map == 0 ? 0 : 4, 4) = own;
      REQUIRE(g < sums.segments.size());
      const RowSums& r = sums.segments[g++].rows.at(0);
      CHECK(r.square == Approx(plus * plus).epsilon(1e-14));
      CHECK((r.cross - psi * plus).norm() <= 1e-12 * (psi * plus).norm());
      CHECK((r.gram - psi * psi.transpose()).norm() <= 1e-12 * (psi * psi.transpose()).norm());
    }
    CHECK(g == sums.segments.size());
    CHECK(g >= 15);
  }
  CHECK_THROWS_WITH(SumJumps(library, JumpSamples{.y = &d.y, .gamma = &d.gamma, .dt = 1e-3}),
                    Catch::Contains("has 2 [[jump]] maps: give each sample's map"));
  CHECK_THROWS_WITH(MapSums(library, d, 2), Catch::Contains("and a map in [0, 2), not 2"));
}

TEST_CASE("a ball between a floor and a ceiling: each map's support chosen on its own jumps", "[select]") {
  const Model library = ParseModelFile(TwoMapsLibrary(), "library.toml").model;
  for (const std::uint64_t seed : {1u, 2u, 3u}) {
    INFO("seed " << seed);
    const MapData d = SimulatedTwoMaps(0.01, seed);
    for (const int map : {0, 1}) {
      INFO("map " << map);
      const FlowSums all = MapSums(library, d, map);
      const FlowSums sums = KeepColumns(all, map == 0 ? std::vector<int>{0, 1, 2, 3} : std::vector<int>{4, 5, 6, 7});
      const Selection s = SelectTerms(sums, std::vector<bool>(4, true), kLeaveOneOut);
      REQUIRE(s.ok);
      CHECK(s.chosen == (map == 0 ? std::vector<bool>{true, false, false, false}
                                  : std::vector<bool>{true, true, false, false}));
      CHECK(s.estimate[0] == Approx(map == 0 ? -0.98 : -0.9).margin(0.02));
      if (map == 1) CHECK(s.estimate[1] == Approx(0.01).margin(0.003));
    }
  }
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
