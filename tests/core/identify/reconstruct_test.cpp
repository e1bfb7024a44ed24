// Reconstruction of unmeasured states: the Savitzky–Golay slope against closed forms (a polynomial,
// its variance under noise), the plan from the flow's structure, and a bouncing ball's velocity and
// bounces recovered from its height alone.
#include <catch2/catch.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <random>
#include <vector>

#include "core/builtin/bouncing_ball.hpp"
#include "core/identify/reconstruct.hpp"
#include "sim/simulator.hpp"

namespace hysid {
namespace {

TEST_CASE("the slope of a quadratic is exact at every sample, centred or shifted, on irregular times",
          "[reconstruct]") {
  std::vector<double> t;
  std::vector<double> y;
  for (int k = 0; k < 40; ++k) {
    const double tk = 0.1 * k + 0.03 * std::sin(1.7 * k);  // irregular steps
    t.push_back(tk);
    y.push_back(2.0 - 3.0 * tk + 0.7 * tk * tk);
  }
  std::vector<double> slope(t.size());
  SavitzkyGolaySlope(t, y.data(), 0, 40, 9, slope.data());
  for (std::size_t k = 0; k < t.size(); ++k) CHECK(slope[k] == Approx(-3.0 + 1.4 * t[k]).margin(1e-11));
  // Two samples: the chord; one: 0.
  SavitzkyGolaySlope(t, y.data(), 5, 7, 9, slope.data());
  CHECK(slope[5] == Approx((y[6] - y[5]) / (t[6] - t[5])).epsilon(1e-12));
  SavitzkyGolaySlope(t, y.data(), 10, 11, 9, slope.data());
  CHECK(slope[10] == 0.0);
}

TEST_CASE("a cubic's centred slope has the closed-form bias of the degree-2 fit", "[reconstruct]") {
  // For y = τ³ on the symmetric grid τ_i = iδ (|i| ≤ M), the fitted slope at 0 is Σ i⁴ δ² / Σ i².
  const int m = 11, half = m / 2;
  const double delta = 0.05;
  std::vector<double> t, y;
  double s2 = 0.0, s4 = 0.0;
  for (int i = -half; i <= half; ++i) {
    t.push_back(i * delta);
    y.push_back(std::pow(i * delta, 3));
    s2 += i * i;
    s4 += std::pow(i, 4);
  }
  CHECK(LocalSlope(t, y.data(), 0, m, half) == Approx(s4 / s2 * delta * delta).epsilon(1e-10));
}

TEST_CASE("the centred slope's noise sd is σ / (δt √(m(m²−1)/12))", "[reconstruct]") {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 1e-3);
  const double dt = 1.0 / 150.0;
  const int m = 15;
  const long size = 30000;
  std::vector<double> t(size), y(size), slope(size);
  for (long k = 0; k < size; ++k) {
    t[k] = k * dt;
    y[k] = 0.5 * t[k] * (1.0 - 0.01 * t[k]) + noise(rng);
  }
  SavitzkyGolaySlope(t, y.data(), 0, size, m, slope.data());
  double sum = 0.0;
  for (long k = m; k < size - m; ++k) sum += std::pow(slope[k] - (0.5 - 0.01 * t[k]), 2);
  const double rms = std::sqrt(sum / double(size - 2 * m));
  const double predicted = 1e-3 / (dt * std::sqrt(m * (m * m - 1.0) / 12.0));
  CHECK(rms == Approx(predicted).epsilon(0.03));
}

TEST_CASE("the plan reconstructs a velocity from its measured position, and refuses the reverse",
          "[reconstruct]") {
  const Model model{BouncingBall{}};
  const ReconstructionPlan plan = PlanReconstruction(model, {0});
  REQUIRE(plan.ok());
  CHECK(plan.reconstructed == std::vector<int>{1});
  CHECK(plan.source[1] == 0);
  CHECK(plan.scale[1] == 1.0);
  CHECK(plan.offset[1] == 0.0);
  const ReconstructionPlan reverse = PlanReconstruction(model, {1});
  CHECK_FALSE(reverse.ok());
  CHECK(reverse.error.find("state 'h'") != std::string::npos);
  CHECK_THROWS_AS(PlanReconstruction(model, {2}), std::invalid_argument);
}

// A bouncing ball's height at 150 Hz over four bounces.
Trajectory Ball(const Model& model) {
  Vec x0(2);
  x0 << 1.0, 0.0;
  return Simulate(model, x0, SampleGrid{2.5, 1.0 / 150.0});
}

TEST_CASE("a parabola's flight: the bounces and the velocity from the height alone (noise-free)",
          "[reconstruct]") {
  const Model model{BouncingBall{}};
  const Trajectory traj = Ball(model);
  REQUIRE(traj.status.completed());
  REQUIRE(traj.jumps.size() == 4);
  const ReconstructionPlan plan = PlanReconstruction(model, {0});
  const Reconstruction r = ReconstructStates(plan, traj.t, traj.x.topRows(1), {}, Vec());
  for (std::size_t k = 1; k < traj.t.size(); ++k) {
    INFO("sample " << k);
    CHECK(int(r.gamma[k]) == (traj.j[k] != traj.j[k - 1] ? 1 : 0));
  }
  CHECK(r.segments == 5);
  // The flight is an exact parabola between bounces: the degree-2 slope is exact up to integration error.
  CHECK((r.x.row(1) - traj.x.row(1)).cwiseAbs().maxCoeff() < 1e-6);
  CHECK(r.x.row(0) == traj.x.row(0));
}

TEST_CASE("a raised stop flag: the reconstruction returns marked stopped - a lowered one changes nothing",
          "[reconstruct][stop]") {
  const Model model{BouncingBall{}};
  const Trajectory traj = Ball(model);
  const ReconstructionPlan plan = PlanReconstruction(model, {0});
  const Reconstruction full = ReconstructStates(plan, traj.t, traj.x.topRows(1), {}, Vec());
  std::atomic<bool> stop{false};
  ReconstructOptions o;
  o.stop = &stop;
  const Reconstruction lowered = ReconstructStates(plan, traj.t, traj.x.topRows(1), {}, Vec(), o);
  CHECK_FALSE(full.stopped);
  CHECK_FALSE(lowered.stopped);
  CHECK(lowered.x == full.x);
  CHECK(lowered.gamma == full.gamma);
  stop = true;
  const Reconstruction raised = ReconstructStates(plan, traj.t, traj.x.topRows(1), {}, Vec(), o);
  CHECK(raised.stopped);
  CHECK(raised.segments == 0);
  const KinkDetection kinks = DetectKinks(traj.t, traj.x.topRows(1), {}, Vec(), o);
  CHECK(kinks.stopped);
  CHECK(std::count(kinks.gamma.begin(), kinks.gamma.end(), 1) == 0);
}

// The ball's height with Gaussian noise of sd sigma (the generator seeded with 11).
Mat NoisyHeight(const Trajectory& traj, double sigma) {
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, sigma);
  Mat h = traj.x.topRows(1);
  for (Eigen::Index k = 0; k < h.cols(); ++k) h(0, k) += noise(rng);
  return h;
}

TEST_CASE("a parabola's flight with 1 mm noise: bounces found, velocity within its predicted sd",
          "[reconstruct]") {
  const Model model{BouncingBall{}};
  const Trajectory traj = Ball(model);
  const Mat h = NoisyHeight(traj, 1e-3);
  const Reconstruction r = ReconstructStates(PlanReconstruction(model, {0}), traj.t, h, {}, Vec());
  CHECK(r.sigma[0] == Approx(1e-3).epsilon(0.15));
  // Each bounce within one sample of its interval (a bounce just after a sample is a kink at that
  // sample within the noise), and no other detection.
  std::vector<long> truth, found;
  for (std::size_t k = 1; k < traj.t.size(); ++k) {
    if (traj.j[k] != traj.j[k - 1]) truth.push_back(long(k));
    if (r.gamma[k]) found.push_back(long(k));
  }
  REQUIRE(found.size() == truth.size());
  for (std::size_t i = 0; i < truth.size(); ++i) CHECK(std::abs(found[i] - truth[i]) <= 1);
  // Samples away from the bounces: the error within 6 sd of the shifted-window worst case (the end
  // slope's variance of a degree-2 fit is 16× the centre's); the RMS of the order of the centred sd.
  const double dt = 1.0 / 150.0, m = r.min_window;
  const double centre = 1e-3 / (dt * std::sqrt(m * (m * m - 1.0) / 12.0));
  double sum = 0.0, worst = 0.0;
  long count = 0;
  for (long k = 0; k < h.cols(); ++k) {
    if (std::any_of(truth.begin(), truth.end(), [&](long j) { return std::abs(k - j) <= 1; })) continue;
    const double e = std::abs(r.x(1, k) - traj.x(1, k));
    worst = std::max(worst, e);
    sum += e * e;
    ++count;
  }
  CHECK(worst < 6.0 * 4.0 * centre);
  CHECK(std::sqrt(sum / double(count)) < 2.0 * centre);
}

// A particle at constant speed between walls at −0.4 and 0.3, its speed times 0.75 at each wall,
// sampled every 0.02 s for 10 s from x = 0.2 at speed 3.35 towards the lower wall: 9 walls hit,
// 14 to 104 samples apart. Returns the positions and the samples that end an interval holding a hit.
std::pair<Mat, std::vector<long>> BetweenWalls(std::vector<double>& t, double sigma, unsigned seed) {
  const double dt = 0.02, lower = -0.4, upper = 0.3;
  const long size = 501;
  std::vector<double> hits;
  double at = 0.0, x = 0.2, v = -3.35;
  while (at < 10.0) {
    const double wall = v < 0 ? lower : upper;
    at += (wall - x) / v;
    x = wall;
    v *= -0.75;
    hits.push_back(at);
  }
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma);
  Mat y(1, size);
  t.resize(size);
  std::vector<long> samples;
  double from = 0.0, x_from = 0.2, v_from = -3.35;
  std::size_t next = 0;
  for (long k = 0; k < size; ++k) {
    t[k] = k * dt;
    while (next < hits.size() && hits[next] <= t[k]) {
      x_from += v_from * (hits[next] - from);
      from = hits[next++];
      v_from *= -0.75;
      samples.push_back(k);
    }
    y(0, k) = x_from + v_from * (t[k] - from) + noise(rng);
  }
  return {y, samples};
}

TEST_CASE("walls hit closer together than the longest chord: every hit found, within a sample",
          "[reconstruct]") {
  // The range over the duration (0.07 m/s) calls for a chord of about 40 samples, more than twice
  // the first hits' spacing (14 samples): the shorter chords of the ladder see those, the longer
  // ones the last, slow hits (a kink of 0.59 m/s is 12 noise sd with a chord of 10 samples).
  for (const unsigned seed : {1u, 2u, 3u}) {
    std::vector<double> t;
    const auto [y, truth] = BetweenWalls(t, 5e-3, seed);
    REQUIRE(truth.size() == 9);
    const KinkDetection d = DetectKinks(t, y, {}, Vec(), ReconstructOptions{});
    std::vector<long> found;
    for (std::size_t k = 0; k < t.size(); ++k) {
      if (d.gamma[k]) found.push_back(long(k));
    }
    INFO("seed " << seed << ", chord " << d.chord);
    REQUIRE(found.size() == truth.size());
    for (std::size_t i = 0; i < truth.size(); ++i) CHECK(std::abs(found[i] - truth[i]) <= 1);
  }
}

TEST_CASE("kinks far apart are located with the longest chord, each found once by the whole ladder",
          "[reconstruct]") {
  // A parabola's flight with 5 mm noise: the longest chord is about 20 samples, the bounces are 70
  // samples apart or more.
  const Model model{BouncingBall{}};
  const Trajectory traj = Ball(model);
  const Mat h = NoisyHeight(traj, 5e-3);
  ReconstructOptions o;
  const KinkDetection d = DetectKinks(traj.t, h, {}, Vec(), o);
  const double range = h.maxCoeff() - h.minCoeff(), duration = traj.t.back() - traj.t.front();
  const double dt = duration / double(h.cols() - 1);
  const long longest = long(std::ceil(2.0 * d.sigma[0] / (o.kink_precision * range / duration * dt)));
  INFO("longest " << longest);
  CHECK(d.chord == std::clamp<long>(longest, o.chord, h.cols() / 10));
  CHECK(d.chord > o.chord);
  long found = 0;
  for (std::size_t k = 1; k < traj.t.size(); ++k) found += d.gamma[k];
  CHECK(found == 4);
}

TEST_CASE("a smooth flow without kinks: no chord of the ladder finds one, noisy or noise-free",
          "[reconstruct]") {
  // A damped oscillation x = e^{−0.1t} cos 2.3t, 1 000 samples at 50 Hz: its curvature changes all the
  // time (the running median's work) and its range over the duration calls for long chords at 5 mm.
  const long size = 1000;
  std::vector<double> t(size);
  Mat clean(1, size);
  for (long k = 0; k < size; ++k) {
    t[k] = 0.02 * k;
    clean(0, k) = std::exp(-0.1 * t[k]) * std::cos(2.3 * t[k]);
  }
  const KinkDetection noise_free = DetectKinks(t, clean, {}, Vec(), ReconstructOptions{});
  CHECK(std::count(noise_free.gamma.begin(), noise_free.gamma.end(), 1) == 0);
  for (const unsigned seed : {1u, 2u, 3u, 4u, 5u}) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, 5e-3);
    Mat y = clean;
    for (long k = 0; k < size; ++k) y(0, k) += noise(rng);
    const KinkDetection d = DetectKinks(t, y, {}, Vec(), ReconstructOptions{});
    INFO("seed " << seed << ", chord " << d.chord);
    CHECK(d.chord > 8);  // a ladder of three chords or more was walked
    CHECK(std::count(d.gamma.begin(), d.gamma.end(), 1) == 0);
  }
}

}  // namespace
}  // namespace hysid
