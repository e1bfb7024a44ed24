// The per-chain sums of the output-error fit and its compressed residual against the full weighted
// residuals and their Jacobian formed directly.
#include <catch2/catch.hpp>

#include <algorithm>
#include <random>

#include <Eigen/LU>
#include <Eigen/QR>

#include "core/builtin/impact_msd.hpp"
#include "sim/refine/chain_sums.hpp"
#include "sim/sensitivity/crlb.hpp"

namespace hysid {
namespace {

// A run of n states and p unknowns over K samples with random states and sensitivities, and data.
struct RandomRun {
  SensitivityTrajectory s;
  Mat y;  // the measured rows
  std::vector<int> rows;
  RandomRun(int n, int p, long k_count, std::vector<int> measured, std::uint32_t seed) : rows(std::move(measured)) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> normal;
    auto random = [&](Eigen::Index r, Eigen::Index c) { return Mat(Mat::NullaryExpr(r, c, [&] { return normal(rng); })); };
    s.parameters = p;
    s.trajectory.x = random(n, k_count);
    s.sensitivities = random(static_cast<Eigen::Index>(n) * p, k_count);
    y = s.trajectory.x(rows, Eigen::all) + random(static_cast<Eigen::Index>(rows.size()), k_count);
  }
  // The weighted residuals r = W(y − Hξ) stacked sample by sample, and their Jacobian −W H S.
  void Full(const Vec& w, Vec* r, Mat* j) const {
    const auto m = static_cast<Eigen::Index>(rows.size()), n = s.trajectory.x.rows();
    r->resize(m * y.cols());
    j->resize(m * y.cols(), s.parameters);
    for (Eigen::Index k = 0; k < y.cols(); ++k) {
      const Eigen::Map<const Mat> sk(s.sensitivities.col(k).data(), n, s.parameters);
      for (Eigen::Index i = 0; i < m; ++i) {
        (*r)[k * m + i] = w[i] * (y(i, k) - s.trajectory.x(rows[static_cast<std::size_t>(i)], k));
        j->row(k * m + i) = -w[i] * sk.row(rows[static_cast<std::size_t>(i)]);
      }
    }
  }
};

// The sums of `run` (two measured components) against its full weighted residuals and Jacobian.
void CheckSums(const ChainSums& sums, const RandomRun& run) {
  const Vec w = (Vec(2) << 2.0, 0.5).finished();
  Vec r;
  Mat j;
  run.Full(w, &r, &j);
  const Eigen::Index k = run.y.cols();
  CHECK(sums.samples == k);
  CHECK(sums.Cost(w) == Approx(r.squaredNorm()).epsilon(1e-12));
  CHECK((sums.Gradient(w) - j.transpose() * r).norm() < 1e-10 * (j.transpose() * r).norm());
  CHECK((sums.Information(w) - j.transpose() * j).norm() < 1e-10 * (j.transpose() * j).norm());
  for (int i = 0; i < 2; ++i) {
    const Vec ri = (run.y.row(i) - run.s.trajectory.x.row(run.rows[static_cast<std::size_t>(i)])).transpose();
    CHECK(sums.lag[i] == Approx(ri.head(k - 1).dot(ri.tail(k - 1))).epsilon(1e-12));
  }
}

TEST_CASE("chain sums give the full residuals' cost, gradient, Gauss-Newton matrix and lag-1 sums",
          "[refine]") {
  const RandomRun run(3, 5, 200, {0, 2}, 7);
  CheckSums(SumChain(run.s, run.y, run.rows), run);
}

TEST_CASE("chain sums taken sample by sample, in any order, equal the full residuals' sums", "[refine]") {
  // 300 samples (not a whole number of the summer's blocks) fed in a shuffled order, the data a view
  // of the first 300 columns of a longer record (a chain fit on a shorter span).
  const RandomRun run(3, 5, 300, {0, 2}, 5);
  Mat longer(2, 340);
  longer.leftCols(300) = run.y;
  longer.rightCols(40).setConstant(1e9);  // beyond the span: must not be read
  ChainSummer summer(longer.leftCols(300), run.rows, 3, 5);
  std::vector<long> order(300);
  for (long k = 0; k < 300; ++k) order[static_cast<std::size_t>(k)] = k;
  std::shuffle(order.begin(), order.end(), std::mt19937(3));
  for (const long k : order)
    summer.Sample(k, run.s.trajectory.x.col(k).data(), run.s.sensitivities.col(k).data());
  CheckSums(summer.Finish(run.s.trajectory.x), run);
  CHECK(summer.last_sensitivities() == run.s.S(299));
}

TEST_CASE("samples given as window weights sum as the interpolated samples themselves", "[refine]") {
  // Each window: random ends E_0..E_3 (n × p) and weights w_k; sample k's S_k = Σ_q w_kq E_q. One
  // summer takes the windows, the other the S_k; the last sample lies in the second window.
  const int n = 3, p = 5;
  const RandomRun run(n, p, 60, {0, 2}, 13);
  std::mt19937 rng(17);
  std::normal_distribution<double> normal;
  ChainSummer windowed(run.y, run.rows, n, p), direct(run.y, run.rows, n, p);
  Mat s(n * p, 60);
  for (const auto& [begin, end] : {std::pair<long, long>{0, 35}, {35, 60}}) {
    Mat ends(n * p, 4);
    for (double& v : ends.reshaped()) v = normal(rng);
    for (long k = end - 1; k >= begin; --k) {  // (any order)
      const Eigen::Vector4d w(normal(rng), normal(rng), normal(rng), normal(rng));
      s.col(k) = ends * w;
      windowed.WindowSample(k, run.s.trajectory.x.col(k).data(), w.data());
      direct.Sample(k, run.s.trajectory.x.col(k).data(), s.col(k).data());
    }
    windowed.CloseWindow(ends.col(0).data(), ends.col(1).data(), ends.col(2).data(), ends.col(3).data());
  }
  const ChainSums a = windowed.Finish(run.s.trajectory.x), b = direct.Finish(run.s.trajectory.x);
  for (std::size_t i = 0; i < 2; ++i) CHECK((a.gram[i] - b.gram[i]).norm() < 1e-12 * b.gram[i].norm());
  CHECK((a.h - b.h).norm() < 1e-12 * b.h.norm());
  CHECK(a.squares == b.squares);
  CHECK((windowed.last_sensitivities().reshaped() - s.col(59)).norm() < 1e-12 * s.col(59).norm());
}

TEST_CASE("a run's sums taken as it integrates equal the stored run's", "[refine]") {
  // The §5 system over 6 s (4 jumps) at the refinement's tolerances: the summer takes most samples
  // as window weights, those at the segments' starts as S_k.
  const Model model{ImpactMsd{}};
  const Vec x0 = (Vec(2) << 20.0, 0.0).finished();
  const SampleGrid grid{6.0, 5e-4};
  const Trajectory truth = Simulate(model, x0, grid);
  Mat y = truth.x;
  std::mt19937 rng(5);
  std::normal_distribution<double> normal;
  for (double& v : y.reshaped()) v += 0.1 * normal(rng);
  const Unknowns u = Unknowns::Of(model);
  const HybridParameters truth_p = HybridParameters::Of(model, x0);
  const Vec theta = truth_p.Theta(u);  // a point off the truth by 1 %, 2 % … in each unknown
  const HybridParameters at =
      truth_p.WithTheta(u, theta + (theta.cwiseAbs().array() + 0.1).matrix().cwiseProduct(
                                       Vec::LinSpaced(theta.size(), 0.01, 0.01 * static_cast<double>(theta.size()))));
  SensitivityOptions o;
  o.sim.rtol = o.sim.atol = 5e-7;
  const std::vector<int> rows{0, 1};
  const SensitivityTrajectory stored = SimulateSensitivitiesMatched(model, at, u, truth.t, truth.j, o);
  ChainSummer summer(y, rows, 2, static_cast<int>(theta.size()));
  const SensitivityTrajectory sunk = SimulateSensitivitiesMatched(model, at, u, truth.t, truth.j, o, nullptr, &summer);
  REQUIRE(stored.ok());
  REQUIRE(sunk.ok());
  REQUIRE(truth.jumps.size() >= 4);
  const ChainSums a = summer.Finish(sunk.trajectory.x), b = SumChain(stored, y, rows);
  for (std::size_t i = 0; i < 2; ++i) CHECK((a.gram[i] - b.gram[i]).norm() < 1e-11 * b.gram[i].norm());
  CHECK((a.h - b.h).norm() < 1e-11 * b.h.norm());
  CHECK(a.squares == b.squares);
  CHECK(a.lag == b.lag);
  CHECK((summer.last_sensitivities() - stored.S(truth.size() - 1)).norm() < 1e-12 * stored.S(truth.size() - 1).norm());
}

TEST_CASE("the compressed residual has the full residuals' cost, gradient and Gauss-Newton matrix", "[refine]") {
  RandomRun run(2, 4, 300, {0, 1}, 11);
  SECTION("full rank") {}
  SECTION("rank deficient: two unknowns with the same sensitivities") {
    for (Eigen::Index k = 0; k < run.s.sensitivities.cols(); ++k) {
      run.s.sensitivities.block(6, k, 2, 1) = run.s.sensitivities.block(4, k, 2, 1);  // θ_3 ≡ θ_2
    }
  }
  const ChainSums sums = SumChain(run.s, run.y, run.rows);
  const Vec w = (Vec(2) << 1.0, 3.0).finished();
  Vec r, compressed(5);
  Mat j, jc;
  run.Full(w, &r, &j);
  CompressedResidual(sums, w, compressed.data(), &jc);
  REQUIRE(jc.rows() == 5);
  REQUIRE(jc.cols() == 4);
  CHECK(compressed.squaredNorm() == Approx(r.squaredNorm()).epsilon(1e-12));
  const Vec g = j.transpose() * r;
  CHECK((jc.transpose() * compressed - g).norm() < 1e-9 * g.norm());
  CHECK((jc.transpose() * jc - j.transpose() * j).norm() < 1e-10 * (j.transpose() * j).norm());
  // The Gauss–Newton step of the compressed problem is the full one's (least-norm where singular).
  const Vec full_step = j.completeOrthogonalDecomposition().solve(-r);
  const Vec step = jc.completeOrthogonalDecomposition().solve(-compressed);
  CHECK((step - full_step).norm() < 1e-8 * full_step.norm());
}

// Per chain the information SᵀS of random sensitivities (s shared unknowns, then n of its ξ0), in
// very different units per unknown.
std::vector<Mat> RandomChainInformation(int chains, int s, int n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal;
  Vec scale(s + n);
  for (Eigen::Index a = 0; a < scale.size(); ++a) scale[a] = std::pow(10.0, static_cast<double>(a % 4) - 1.5);
  std::vector<Mat> blocks;
  for (int c = 0; c < chains; ++c) {
    const Mat rows = Mat::NullaryExpr(3 * (s + n), s + n, [&] { return normal(rng); }) * scale.asDiagonal();
    blocks.push_back(rows.transpose() * rows);
  }
  return blocks;
}

// The joint matrix formed directly, independently of ChainInformation::Joint.
Mat JointDirectly(const std::vector<Mat>& blocks, int s, int n) {
  const auto chains = static_cast<Eigen::Index>(blocks.size());
  Mat f = Mat::Zero(s + n * chains, s + n * chains);
  for (Eigen::Index c = 0; c < chains; ++c) {
    std::vector<Eigen::Index> at;
    for (Eigen::Index a = 0; a < s; ++a) at.push_back(a);
    for (Eigen::Index a = 0; a < n; ++a) at.push_back(s + n * c + a);
    for (Eigen::Index a = 0; a < s + n; ++a) {
      for (Eigen::Index b = 0; b < s + n; ++b) f(at[a], at[b]) += blocks[static_cast<std::size_t>(c)](a, b);
    }
  }
  return f;
}

TEST_CASE("each chain's initial state eliminated gives the joint information's inverse block", "[refine]") {
  const int s = 4, n = 2, chains = 6;
  const std::vector<Mat> blocks = RandomChainInformation(chains, s, n, 13);
  const ChainInformation info = ChainInformation::Of(blocks, s);
  const Mat joint = JointDirectly(blocks, s, n);
  CHECK((info.Joint() - joint).norm() <= 1e-14 * joint.norm());  // (SᵀS rounds to symmetric within this)
  const Mat inverse = joint.fullPivLu().inverse();
  for (const std::size_t c : {std::size_t{0}, std::size_t{3}}) {
    Mat block;
    REQUIRE(info.CovarianceBlock(c, &block));
    std::vector<Eigen::Index> at;
    for (Eigen::Index a = 0; a < s; ++a) at.push_back(a);
    for (Eigen::Index a = 0; a < n; ++a) at.push_back(s + n * static_cast<Eigen::Index>(c) + a);
    const Mat expected = inverse(at, at);
    for (Eigen::Index a = 0; a < s + n; ++a) {
      for (Eigen::Index b = 0; b < s + n; ++b) {
        CHECK(
            block(a, b) ==
            Approx(expected(a, b)).epsilon(1e-8).margin(1e-12 * std::sqrt(expected(a, a) * expected(b, b))));
      }
    }
  }
  Vec g(joint.rows());
  for (Eigen::Index k = 0; k < g.size(); ++k) g[k] = std::sin(1.7 * static_cast<double>(k + 1));
  CHECK(info.InverseQuadratic(g) == Approx(g.dot(inverse * g)).epsilon(1e-9));
}

TEST_CASE("a singular joint information is found singular per chain, as CrlbFromFisher finds it",
          "[refine]") {
  const int s = 3, n = 2;
  std::vector<Mat> blocks = RandomChainInformation(4, s, n, 17);
  SECTION("a chain's initial state not identifiable") {
    blocks[2].row(s).setZero();  // its first ξ0 component carries no information
    blocks[2].col(s).setZero();
  }
  SECTION("a shared direction not identifiable: two shared unknowns with the same sensitivities") {
    for (Mat& b : blocks) {
      b.row(1) = b.row(0);
      b.col(1) = b.col(0);
    }
  }
  const ChainInformation info = ChainInformation::Of(blocks, s);
  Mat block;
  CHECK_FALSE(info.CovarianceBlock(0, &block));
  CHECK(std::isinf(info.InverseQuadratic(Vec::Ones(s + 4 * n))));
  const Crlb joint = CrlbFromFisher(info.Joint(), Unknowns{}, std::vector<std::string>(s + 4 * n, "t"));
  CHECK(joint.status == CrlbStatus::kSingular);
}

}  // namespace
}  // namespace hysid
