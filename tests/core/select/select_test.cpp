// Selection among candidate terms (core/select/select.hpp): on simulated data the true support of the
// paper's §5 system and of a ball with quadratic drag is recovered from 20-term libraries whose wrong
// terms are strongly correlated with the true ones; the bootstrap chooses the true terms in almost
// every draw; bad options are refused by name.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Cholesky>

#include "core/model_file/model_file.hpp"
#include "core/select/select.hpp"
#include "sim/measurement.hpp"
#include "sim/simulator.hpp"
#include "tests/testing/vec.hpp"

namespace hysid {
namespace {

using testing::V;

// The §5 system (a = 5, b = 0.1, λ = 0.99, μ = 0) as a model file, and the same with v' from a
// 20-term library (docs/model-files.md#candidate-terms).
constexpr const char* kSection5Tail = R"toml(
[jump]
psi = [["x", 0, 0], [0, "-v", 1]]
rows = ["v"]
[[guard]]
name = "wall"
h = "x"
direction = "falling"
project = { x = "0" }
[sets]
C = "x > 0 || (x == 0 && v >= 0)"
D = "x == 0 && v <= 0"
[defaults]
x0 = [20.0, 0.0]
t_end = 20.0
dt = 5e-4
)toml";

std::string Section5Truth() {
  return std::string(R"toml(
name = "impact-msd"
states = ["x", "v"]
alpha = [ { name = "one", value = 1.0, known = true }, { name = "a", value = 5.0 }, { name = "b", value = 0.1 } ]
beta = [ { name = "one_x", value = 1.0, known = true }, { name = "lambda", value = 0.99 }, { name = "mu", value = 0.0 } ]
[flow]
phi = [["v", 0, 0], [0, "-x", "-v"]]
rows = ["v"]
)toml") + kSection5Tail;
}

std::string Section5Library() {
  return std::string(R"toml(
name = "msd-library"
states = ["x", "v"]
alpha = [ { name = "one", value = 1.0, known = true } ]
beta = [ { name = "one_x", value = 1.0, known = true }, { name = "lambda", value = 0.99 }, { name = "mu", value = 0.0 } ]
[flow]
phi = [["v"], [0]]
rows = ["v"]
candidates = { v = ["1", "x", "v", "x^2", "x*v", "v^2", "x^3", "x^2*v", "x*v^2", "v^3",
                    "abs(v)*v", "abs(v)", "sign(v)", "x*abs(v)", "x*sign(v)", "x*abs(v)*v",
                    "x^2*abs(v)", "sin(x)", "cos(x)", "exp(-x)"] }
)toml") + kSection5Tail;
}

// A ball with quadratic drag: h' = v, v' = −g − c|v|v, v+ = −e v at h = 0.
constexpr const char* kBallTail = R"toml(
[jump]
psi = [["h", 0], [0, "-v"]]
rows = ["v"]
[[guard]]
name = "floor"
h = "h"
direction = "falling"
project = { h = "0" }
[sets]
C = "h > 0 || (h == 0 && v >= 0)"
D = "h == 0 && v <= 0"
[defaults]
x0 = [10.0, 0.0]
t_end = 10.0
dt = 1e-3
)toml";

std::string BallTruth() {
  return std::string(R"toml(
name = "drag-ball"
states = ["h", "v"]
alpha = [ { name = "one", value = 1.0, known = true }, { name = "g", value = 9.81 }, { name = "c", value = 0.1 } ]
beta = [ { name = "one_h", value = 1.0, known = true }, { name = "e", value = 0.9 } ]
[flow]
phi = [["v", 0, 0], [0, -1, "-abs(v)*v"]]
rows = ["v"]
)toml") + kBallTail;
}

std::string BallLibrary() {
  return std::string(R"toml(
name = "ball-library"
states = ["h", "v"]
alpha = [ { name = "one", value = 1.0, known = true } ]
beta = [ { name = "one_h", value = 1.0, known = true }, { name = "e", value = 0.9 } ]
[flow]
phi = [["v"], [0]]
rows = ["v"]
candidates = { v = ["1", "h", "v", "h^2", "h*v", "v^2", "h^3", "h^2*v", "h*v^2", "v^3",
                    "abs(v)*v", "abs(v)", "sign(v)", "h*abs(v)", "h*sign(v)", "h*abs(v)*v",
                    "abs(v)*v^2", "sin(h)", "cos(h)", "exp(-h)"] }
)toml") + kBallTail;
}

struct Data {
  Mat y;
  std::vector<std::uint8_t> gamma;
};

// The truth simulated over its defaults, noise σ per state, jumps labelled from the true j.
Data Simulated(const std::string& truth_text, const Vec& x0, double t_end, double dt, double sigma, std::uint64_t seed) {
  const Model truth = ParseModelFile(truth_text, "truth.toml").model;
  const Trajectory traj = Simulate(truth, x0, SampleGrid{t_end, dt});
  REQUIRE(traj.status.completed());
  Data d{AddMeasurementNoise(traj.x, Vec::Constant(2, sigma), NoiseKey{.seed = seed, .stream = 0}), {}};
  d.gamma.assign(traj.j.size(), 0);
  for (std::size_t k = 1; k < traj.j.size(); ++k) d.gamma[k] = traj.j[k] != traj.j[k - 1] ? 1 : 0;
  return d;
}

FlowSums Sums(const Model& library, const Data& d, double dt) {
  return SumFlowSegments(library, FlowSamples{.y = &d.y, .gamma = &d.gamma, .dt = dt});
}

// The candidate columns with the given terms chosen (true) and every other one not.
std::vector<bool> Support(const Model& library, const std::vector<std::string>& terms) {
  std::vector<bool> out;
  for (const CandidateTerm& c : library.spec().candidates)
    out.push_back(std::find(terms.begin(), terms.end(), c.term) != terms.end());
  return out;
}

// |correlation| of the centred integral columns i and j over every segment.
double Correlation(const FlowSums& sums, int i, int j) {
  double gij = 0.0, gii = 0.0, gjj = 0.0;
  for (const SegmentSums& s : sums.segments) {
    gij += s.rows[0].gram(i, j);
    gii += s.rows[0].gram(i, i);
    gjj += s.rows[0].gram(j, j);
  }
  return std::abs(gij) / std::sqrt(gii * gjj);
}

std::string Chosen(const Model& library, const std::vector<bool>& chosen) {
  std::string out;
  for (std::size_t j = 0; j < chosen.size(); ++j)
    if (chosen[j]) out += library.spec().candidates[j].term + " ";
  return out;
}

}  // namespace

TEST_CASE("§5 with 20 candidate terms of v': the support {x, v} is chosen, with a and b", "[select]") {
  const Model library = ParseModelFile(Section5Library(), "library.toml").model;
  REQUIRE(library.spec().candidates.size() == 20);
  const std::vector<bool> truth = Support(library, {"x", "v"});
  const std::vector<bool> selectable(20, true);
  for (const double sigma : {0.01, 0.1}) {
    for (const std::uint64_t seed : {1u, 2u, 3u}) {
      INFO("sigma " << sigma << ", seed " << seed);
      const Data d = Simulated(Section5Truth(), V(20.0, 0.0), 20.0, 5e-4, sigma, seed);
      const FlowSums sums = Sums(library, d, 5e-4);
      // Wrong terms the data cannot tell apart easily: the centred integrals of 1 and x^2 follow x's.
      CHECK(Correlation(sums, 0, 1) > 0.5);
      CHECK(Correlation(sums, 3, 1) > 0.9);
      const Selection s = SelectTerms(sums, selectable, SelectOptions{});
      REQUIRE(s.ok);
      INFO("chosen " << Chosen(library, s.chosen));
      CHECK(s.chosen == truth);
      CHECK(s.estimate[1] == Approx(-5.0).epsilon(0.01));
      CHECK(s.estimate[2] == Approx(-0.1).epsilon(0.1));
    }
  }
}

TEST_CASE("a ball with quadratic drag and 20 candidate terms of v': the support {1, |v|v} is chosen", "[select]") {
  const Model library = ParseModelFile(BallLibrary(), "library.toml").model;
  const std::vector<bool> truth = Support(library, {"1", "abs(v)*v"});
  for (const std::uint64_t seed : {1u, 2u, 3u}) {
    INFO("seed " << seed);
    const Data d = Simulated(BallTruth(), V(10.0, 0.0), 10.0, 1e-3, 0.01, seed);
    const FlowSums sums = Sums(library, d, 1e-3);
    CHECK(Correlation(sums, 10, 12) > 0.8);  // |v|v and sign(v)
    const Selection s = SelectTerms(sums, std::vector<bool>(20, true), SelectOptions{});
    REQUIRE(s.ok);
    INFO("chosen " << Chosen(library, s.chosen));
    CHECK(s.chosen == truth);
    CHECK(s.estimate[0] == Approx(-9.81).epsilon(0.01));
    CHECK(s.estimate[10] == Approx(-0.1).epsilon(0.05));
  }
}

TEST_CASE("the bootstrap of flow segments chooses the true terms of §5 in almost every draw", "[select]") {
  const Model library = ParseModelFile(Section5Library(), "library.toml").model;
  const Data d = Simulated(Section5Truth(), V(20.0, 0.0), 20.0, 5e-4, 0.05, 7);
  const FlowSums sums = Sums(library, d, 5e-4);
  const std::vector<bool> selectable(20, true), truth = Support(library, {"x", "v"});
  const BootstrapResult b = BootstrapSelection(sums, selectable, SelectOptions{}, 40, 11, truth);
  REQUIRE(b.draws == 40);
  CHECK(b.frequency[1] >= 0.95);
  CHECK(b.frequency[2] >= 0.9);
  CHECK(b.support_matches >= 32);
  // The same seed gives the same draws.
  const BootstrapResult again = BootstrapSelection(sums, selectable, SelectOptions{}, 40, 11, truth);
  CHECK(again.frequency == b.frequency);
}

TEST_CASE("terms that are not selectable are always kept - bad options and sizes are refused by name", "[select]") {
  const Model library = ParseModelFile(Section5Library(), "library.toml").model;
  const Data d = Simulated(Section5Truth(), V(20.0, 0.0), 4.0, 5e-4, 0.01, 1);
  const FlowSums sums = Sums(library, d, 5e-4);
  std::vector<bool> selectable(20, true);
  selectable[5] = false;  // v^2: kept whatever its coefficient
  const Selection s = SelectTerms(sums, selectable, SelectOptions{});
  REQUIRE(s.ok);
  CHECK(s.chosen[5]);
  CHECK(s.chosen[1]);
  CHECK_THROWS_WITH(SelectTerms(sums, selectable, SelectOptions{.thresholds = 0}),
                    Catch::Contains("SelectOptions::thresholds = 0"));
  CHECK_THROWS_WITH(SelectTerms(sums, std::vector<bool>(3, true), SelectOptions{}),
                    Catch::Contains("3 selectable flags for 20 columns"));
  const Mat y(3, 10);
  const std::vector<std::uint8_t> gamma(10, 0);
  CHECK_THROWS_WITH(SumFlowSegments(library, FlowSamples{.y = &y, .gamma = &gamma, .dt = 1e-3}),
                    Catch::Contains("sizes disagree"));
}

// Integral sums of one row over 12 segments of 40 samples: z = I·(1, 2, 0) + noise, I three columns
// drawn at random (a fixed generator), centred per segment as SumFlowSegments centres them.
FlowSums HandSums() {
  std::mt19937 rng(5);
  std::normal_distribution<double> unit(0.0, 1.0);
  FlowSums sums;
  sums.columns = {0, 1, 2};
  for (int s = 0; s < 12; ++s) {
    Mat x(40, 3);
    Vec z(40);
    for (int k = 0; k < 40; ++k) {
      for (int c = 0; c < 3; ++c) x(k, c) = unit(rng);
      z[k] = x(k, 0) + 2.0 * x(k, 1) + 0.1 * unit(rng);
    }
    const Mat xc = x.rowwise() - x.colwise().mean();
    const Vec zc = z.array() - z.mean();
    sums.segments.push_back({.chain = 0,
                             .rows = {RowSums{.gram = xc.transpose() * xc, .cross = xc.transpose() * zc,
                                              .square = zc.squaredNorm(), .count = 40}}});
  }
  return sums;
}

TEST_CASE("a chosen candidate the bootstrap seldom chose is dropped and the rest refitted by least squares",
          "[select]") {
  const FlowSums sums = HandSums();
  const std::vector<bool> selectable{false, true, true};
  Selection chosen;
  chosen.ok = true;
  chosen.chosen = {true, true, true};
  chosen.estimate = V(1.0, 2.0, 0.0);
  chosen.bic = -1.0;
  BootstrapResult b;
  b.draws = 100;
  b.frequency = V(0.2, 0.9, 0.3);  // column 0 is no candidate: kept whatever its share
  const Selection s = KeepStable(sums, selectable, chosen, b, SelectOptions{});
  REQUIRE(s.ok);
  CHECK(s.chosen == std::vector<bool>{true, true, false});
  // The least squares on columns 0 and 1 from the summed normal equations, computed here.
  Mat gram = Mat::Zero(2, 2);
  Vec cross = Vec::Zero(2);
  double square = 0.0;
  for (const SegmentSums& seg : sums.segments) {
    gram += seg.rows[0].gram.topLeftCorner(2, 2);
    cross += seg.rows[0].cross.head(2);
    square += seg.rows[0].square;
  }
  const Vec alpha = gram.ldlt().solve(cross);
  CHECK(s.estimate[0] == Approx(alpha[0]).epsilon(1e-10));
  CHECK(s.estimate[1] == Approx(alpha[1]).epsilon(1e-10));
  CHECK(s.estimate[2] == 0.0);
  CHECK(std::abs(alpha[1] - 2.0) < 0.05);
  const double n = 12.0 * 40.0 - 12.0, rss = square - alpha.dot(cross);
  CHECK(s.bic == Approx(n * std::log(rss / n) + 2.0 * std::log(n)).epsilon(1e-9));
  CHECK(s.runner_up == chosen.chosen);
  CHECK(s.runner_up_bic == -1.0);
  // Every candidate at half its draws or more: the selection as it was.
  b.frequency = V(0.2, 0.9, 0.5);
  const Selection same = KeepStable(sums, selectable, chosen, b, SelectOptions{});
  CHECK(same.chosen == chosen.chosen);
  CHECK(same.estimate == chosen.estimate);
  // No bootstrap draws: nothing to judge by.
  CHECK(KeepStable(sums, selectable, chosen, BootstrapResult{.frequency = V(0.0, 0.0, 0.0)}, SelectOptions{})
            .chosen == chosen.chosen);
  CHECK_THROWS_WITH(KeepStable(sums, selectable, chosen, b, SelectOptions{.min_share = 1.5}),
                    Catch::Contains("SelectOptions::min_share = 1.5: must be in [0, 1]"));
  CHECK_THROWS_WITH(KeepStable(sums, {true}, chosen, b, SelectOptions{}),
                    Catch::Contains("KeepStable: 3 columns, 1 selectable flags"));
}

}  // namespace hysid
