// Recursive generalized TLS: bias on a static errors-in-variables problem, and its special cases
// (C = diag(0,…,0,1) is least squares, C = I is TLS, a singular C is mixed LS-TLS), degenerate data.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>

#include <Eigen/Dense>

#include "core/estimators/estimator.hpp"
#include "core/estimators/gtls.hpp"
#include "tests/testing/eiv_problem.hpp"
#include "tests/testing/vec.hpp"

namespace hysid {
namespace {

using testing::EivData;
using testing::MakeEivData;
using testing::V;

std::unique_ptr<Estimator> Make(const std::string& name, const Mat& shape, int p, double forgetting = 1.0,
                                int refactor_every = 500) {
  EstimatorSettings s;
  s.kind = ParseKind<EstimatorKind>(name);
  s.noise_shape = shape;
  s.forgetting = forgetting;
  s.refactor_every = refactor_every;
  // RLS prior P0 = 1e6·I: a ridge of 1e-6 against ΦᵀΦ ≈ rows, i.e. a relative difference ~1e-9 from
  // plain LS. (Much larger p0 costs RLS its precision: P − ggᵀ/(1 + φᵀPφ) cancels ~1e12 terms.)
  s.p0 = 1e6;
  return MakeEstimator(s, Vec::Zero(p));
}

void Feed(Estimator& e, const EivData& d, int rows_per_update = 1) {
  for (long k = 0; k + rows_per_update <= d.phi.rows(); k += rows_per_update) {
    e.Update(d.phi.middleRows(k, rows_per_update), d.y.segment(k, rows_per_update));
  }
}

// θ from the right singular vector of the smallest singular value of the (weighted) [Φ y].
Vec BatchTls(const Mat& phi, const Vec& y, double lambda = 1.0) {
  Mat z(phi.rows(), phi.cols() + 1);
  z << phi, y;
  for (Eigen::Index k = 0; k < z.rows(); ++k) {
    z.row(k) *= std::sqrt(std::pow(lambda, static_cast<double>(z.rows() - 1 - k)));
  }
  const Eigen::JacobiSVD<Mat> svd(z, Eigen::ComputeFullV);
  const Vec v = svd.matrixV().col(z.cols() - 1);
  return -v.head(phi.cols()) / v[phi.cols()];
}

TEST_CASE("gtls with the true C removes the attenuation bias that RLS shows at low SNR", "[gtls]") {
  // x ~ N(0, I): plim θ_LS = (I + diag σ_φ²)⁻¹ θ, i.e. attenuation factors 1/(1 + σ_φi²).
  Vec theta(2), sigma_phi(2);
  theta << 1.5, -0.7;
  sigma_phi << 0.7, 0.5;
  const double sigma_y = 0.5;
  Mat c = Mat::Zero(3, 3);
  c.diagonal() << sigma_phi.array().square(), sigma_y * sigma_y;
  const int runs = 300;
  const long rows = 1000;
  Mat ls(2, runs), gt(2, runs);
  Vec noise_var(runs);
  for (int run = 0; run < runs; ++run) {
    const EivData d = MakeEivData(theta, sigma_phi, sigma_y, rows, 404, static_cast<unsigned>(run));
    auto rls = Make("rls", Mat(), 2);
    auto gtls = Make("gtls", c, 2);
    Feed(*rls, d);
    Feed(*gtls, d);
    REQUIRE(gtls->status() == EstimatorStatus::kOk);
    ls.col(run) = rls->estimate();
    gt.col(run) = gtls->estimate();
    noise_var[run] = dynamic_cast<const Gtls&>(*gtls).noise_variance();
  }
  auto mean = [](const Mat& x) -> Vec { return x.rowwise().mean(); };
  auto stderr_of = [](const Mat& x) -> Vec {
    const Vec m = x.rowwise().mean();
    return ((x.colwise() - m).array().square().rowwise().sum() / double(x.cols() - 1)).sqrt() /
           std::sqrt(double(x.cols()));
  };
  const Vec predicted = theta.array() / (1.0 + sigma_phi.array().square());
  const Vec ls_mean = mean(ls), ls_se = stderr_of(ls), gt_mean = mean(gt), gt_se = stderr_of(gt);
  std::printf("[gtls] %d runs x %ld rows, theta = (%.3f, %.3f)\n", runs, rows, theta[0], theta[1]);
  std::printf(
      "[gtls] RLS  mean (%.4f, %.4f) +- (%.4f, %.4f); predicted attenuation factors "
      "(%.4f, %.4f) -> (%.4f, %.4f)\n",
      ls_mean[0], ls_mean[1], ls_se[0], ls_se[1], predicted[0] / theta[0], predicted[1] / theta[1],
      predicted[0], predicted[1]);
  std::printf("[gtls] GTLS mean (%.4f, %.4f) +- (%.4f, %.4f); mean sigma^2 estimate %.4f\n", gt_mean[0],
              gt_mean[1], gt_se[0], gt_se[1], noise_var.mean());
  for (int i = 0; i < 2; ++i) {
    INFO("component " << i);
    // RLS: the predicted attenuation (finite-sample terms are O(1/rows) = 0.001, added to 3 SE).
    CHECK(std::abs(ls_mean[i] - predicted[i]) <= 3.0 * ls_se[i] + 1e-3);
    CHECK(std::abs(ls_mean[i] - theta[i]) >= 20.0 * ls_se[i]);
    // GTLS with the true C: unbiased within 3 standard errors.
    CHECK(std::abs(gt_mean[i] - theta[i]) <= 3.0 * gt_se[i]);
  }
  // C is in absolute units here, so σ̂² estimates 1.
  CHECK(noise_var.mean() == Approx(1.0).epsilon(0.02));
}

TEST_CASE("gtls with C = diag(0, ..., 0, 1) equals least squares and RLS", "[gtls]") {
  Vec theta(3), sigma_phi(3);
  theta << 0.5, -1.0, 2.0;
  sigma_phi << 0.3, 0.3, 0.3;
  const EivData d = MakeEivData(theta, sigma_phi, 0.4, 600, 7, 0);
  Mat c = Mat::Zero(4, 4);
  c(3, 3) = 1.0;
  const Vec batch = (d.phi.transpose() * d.phi).ldlt().solve(d.phi.transpose() * d.y);
  for (int rows_per_update : {1, 3}) {
    auto gtls = Make("gtls", c, 3, 1.0, 1000000);  // no refactorisation after the batch start
    auto rls = Make("rls", Mat(), 3);
    Feed(*gtls, d, rows_per_update);
    Feed(*rls, d, rows_per_update);
    INFO("rows per update " << rows_per_update);
    CHECK(gtls->status() == EstimatorStatus::kOk);
    CHECK((gtls->estimate() - batch).norm() <= 1e-9 * batch.norm());
    CHECK((gtls->estimate() - rls->estimate()).norm() <= 1e-8 * batch.norm());
  }
}

TEST_CASE("gtls covariance is (PhiT Phi)^-1 of the rows so far, like RLS's P without a prior", "[gtls]") {
  Vec theta(3), sigma_phi(3);
  theta << 0.5, -1.0, 2.0;
  sigma_phi << 0.3, 0.3, 0.3;
  const EivData d = MakeEivData(theta, sigma_phi, 0.4, 300, 5, 0);
  auto gtls = Make("gtls", Mat::Identity(4, 4), 3);
  CHECK(gtls->covariance_matrix() == nullptr);  // no rows yet
  Feed(*gtls, d);
  const Mat want = (d.phi.transpose() * d.phi).inverse();
  const Mat* got = gtls->covariance_matrix();
  REQUIRE(got != nullptr);
  CHECK((*got - want).norm() <= 1e-10 * want.norm());
  auto rls = Make("rls", Mat(), 3);
  Feed(*rls, d);
  CHECK((*rls->covariance_matrix() - want).norm() <= 1e-5 * want.norm());  // P0 = 1e6 ridge
}

TEST_CASE("gtls with C = I equals batch TLS (SVD), also with forgetting", "[gtls]") {
  Vec theta(2), sigma_phi(2);
  theta << 1.0, 0.5;
  sigma_phi << 0.4, 0.4;
  const EivData d = MakeEivData(theta, sigma_phi, 0.4, 800, 9, 0);
  const Mat identity = Mat::Identity(3, 3);
  SECTION("recursion only: inverse iteration tracks the exact solution") {
    auto gtls = Make("gtls", identity, 2, 1.0, 1000000);
    Feed(*gtls, d);
    const Vec tls = BatchTls(d.phi, d.y);
    // One warm-started sweep per update lags the exact solution by ≈ (ν₂/ν₁)·(its change per row),
    // here ~1e-4, two orders below the statistical error (~0.03 at 800 rows).
    const double lag = (gtls->estimate() - tls).norm();
    std::printf("[gtls] C = I, 800 rows: recursive vs SVD TLS %.2e", lag);
    CHECK(lag <= 1e-3);
    dynamic_cast<Gtls&>(*gtls).Refresh();
    std::printf(", after Refresh() %.2e\n", (gtls->estimate() - tls).norm());
    CHECK((gtls->estimate() - tls).norm() <= 1e-12 * tls.norm());
  }
  SECTION("forgetting 0.99 = exponentially weighted TLS") {
    auto gtls = Make("gtls", identity, 2, 0.99, 100);
    Feed(*gtls, d);
    const Vec tls = BatchTls(d.phi, d.y, 0.99);
    CHECK((gtls->estimate() - tls).norm() <= 2e-2);  // lag: the solution moves ~(1 − λ) per row
    dynamic_cast<Gtls&>(*gtls).Refresh();
    CHECK((gtls->estimate() - tls).norm() <= 1e-10 * tls.norm());
    // Forgetting matters: the unweighted TLS differs.
    CHECK((BatchTls(d.phi, d.y) - tls).norm() >= 1e-3);
  }
  SECTION("C given up to scale: the same estimate") {
    auto a = Make("gtls", identity, 2);
    auto b = Make("gtls", 37.0 * identity, 2);
    Feed(*a, d);
    Feed(*b, d);
    CHECK((a->estimate() - b->estimate()).norm() <= 1e-12);
  }
}

TEST_CASE("gtls with a singular C is mixed LS-TLS (exact column)", "[gtls]") {
  // Column 1 is an exact constant 1 (zero row/column in C): the solution is TLS on the Schur
  // complement of the exact block, θ_exact = −S_ee⁻¹ S_en v_n (as gmtls).
  const long rows = 500;
  Vec theta(3), sigma_phi(3);
  theta << 0.8, 0.0, -1.2;
  sigma_phi << 0.5, 0.0, 0.5;
  EivData d = MakeEivData(theta, sigma_phi, 0.5, rows, 13, 0);
  const double offset = 0.7;
  d.phi.col(1).setOnes();
  d.y.array() += offset;
  Mat c = Mat::Identity(4, 4);
  c(1, 1) = 0.0;
  auto gtls = Make("gtls", c, 3);
  Feed(*gtls, d);
  dynamic_cast<Gtls&>(*gtls).Refresh();
  Mat z(rows, 4);
  z << d.phi, d.y;
  const Mat s = z.transpose() * z;
  const std::vector<int> noisy = {0, 2, 3};
  Mat snn(3, 3), sen(1, 3);
  for (int i = 0; i < 3; ++i) {
    sen(0, i) = s(1, noisy[i]);
    for (int j = 0; j < 3; ++j) snn(i, j) = s(noisy[i], noisy[j]);
  }
  const Mat schur = snn - sen.transpose() * sen / s(1, 1);
  const Eigen::SelfAdjointEigenSolver<Mat> eig(schur);
  const Vec vn = eig.eigenvectors().col(0);  // smallest eigenvalue (C_nn = I)
  Vec v(4);
  v << vn[0], -(sen * vn)(0) / s(1, 1), vn[1], vn[2];
  const Vec expected = -v.head(3) / v[3];
  CHECK((gtls->estimate() - expected).norm() <= 1e-9 * expected.norm());
  CHECK(gtls->estimate()[1] == Approx(offset).margin(0.2));
}

TEST_CASE("gtls degenerate data gives a status, never NaN", "[gtls]") {
  Mat c = Mat::Identity(3, 3);
  SECTION("no excitation") {
    auto g = Make("gtls", c, 2, 0.95);
    for (int k = 0; k < 1000; ++k) g->Update(Mat::Zero(1, 2), Vec::Zero(1));
    CHECK(g->status() == EstimatorStatus::kNotExcited);
    CHECK(g->estimate() == Vec::Zero(2));
  }
  SECTION("repeated rows") {
    auto g = Make("gtls", c, 2);
    Mat row(1, 2);
    row << 1.0, 2.0;
    for (int k = 0; k < 100; ++k) g->Update(row, Vec::Constant(1, 3.0));
    CHECK(g->status() == EstimatorStatus::kNotExcited);
    CHECK(g->estimate().allFinite());
  }
  SECTION("a zero column") {
    const EivData d = MakeEivData(Vec::Ones(2), Vec::Constant(2, 0.1), 0.1, 200, 3, 0);
    Mat phi = d.phi;
    phi.col(1).setZero();
    auto g = Make("gtls", c, 2);
    for (long k = 0; k < 200; ++k) g->Update(phi.row(k), d.y.segment(k, 1));
    CHECK(g->status() == EstimatorStatus::kNotExcited);
    CHECK(g->estimate().allFinite());
  }
  SECTION("non-generic TLS: the extreme eigenvector has no y component") {
    // Orthogonal columns with norms 1, √2, 2: S = diag(1, 2, 4)·k, smallest eigenvector e₁.
    auto g = Make("gtls", c, 2);
    Mat rows(3, 2);
    rows << 1.0, 0.0, 0.0, std::sqrt(2.0), 0.0, 0.0;
    const Vec ys = Vec::Unit(3, 2) * 2.0;
    for (int k = 0; k < 20; ++k) g->Update(rows, ys);
    CHECK(g->status() == EstimatorStatus::kNonGeneric);
    CHECK(g->estimate().allFinite());
  }
  SECTION("noise-free data: exact, although S is singular") {
    Vec theta(2);
    theta << 2.0, -3.0;
    const EivData d = MakeEivData(theta, Vec::Zero(2), 0.0, 100, 5, 0);
    auto g = Make("gtls", c, 2, 1.0, 10);
    Feed(*g, d);
    CHECK(g->status() == EstimatorStatus::kOk);
    CHECK((g->estimate() - theta).norm() <= 1e-9);
  }
}

TEST_CASE("gtls is ill-conditioned, with its reason, when a regressor holds nothing but noise", "[gtls]") {
  // y = 1.5·x1 + noise; the second regressor is either x2 + noise (a direction well above the noise)
  // or pure noise (TLS then divides by the gap between two noise eigenvalues: the estimate is not
  // determined by the data, whatever value it lands on).
  const long rows = 4000;
  const EivData signal = MakeEivData(V(1.5, 0.0), V(0.3, 0.3), 0.3, rows, 31, 0);
  const EivData noise = MakeEivData(V(0.0), V(0.0), 0.3, rows, 31, 1);  // y = 0.3·e: pure noise
  const Mat shape = Mat::Identity(3, 3);
  auto good = Make("gtls", shape, 2);
  Feed(*good, signal);
  CHECK(good->status() == EstimatorStatus::kOk);
  CHECK(good->reason().empty());
  // The weakest regressor direction: unit signal variance over the noise variance 0.09.
  CHECK(dynamic_cast<const Gtls&>(*good).support() == Approx(1.0 / 0.09).epsilon(0.1));
  EivData weak = signal;
  weak.phi.col(1) = noise.y;
  auto bad = Make("gtls", shape, 2);
  Feed(*bad, weak);
  CHECK(bad->status() == EstimatorStatus::kIllConditioned);
  CHECK(bad->reason().find("within the noise") != std::string::npos);
  CHECK(dynamic_cast<const Gtls&>(*bad).support() < 0.2);
  CHECK(bad->estimate().allFinite());
}

TEST_CASE("gtls settings errors name the field", "[gtls]") {
  EstimatorSettings s;
  s.kind = EstimatorKind::kGtls;
  s.noise_shape = Mat::Identity(2, 2);
  CHECK_THROWS_WITH(MakeEstimator(s, Vec::Zero(2)), Catch::Contains("noise_shape is 2x2"));
  s.noise_shape = -Mat::Identity(3, 3);
  CHECK_THROWS_WITH(MakeEstimator(s, Vec::Zero(2)), Catch::Contains("positive semidefinite"));
  s.noise_shape = Mat::Zero(3, 3);
  CHECK_THROWS_WITH(MakeEstimator(s, Vec::Zero(2)), Catch::Contains("not be zero"));
  s.noise_shape = Mat();
  s.refactor_every = 0;
  CHECK_THROWS_WITH(MakeEstimator(s, Vec::Zero(2)), Catch::Contains("refactor_every"));
  // Empty shape: classical TLS.
  s.refactor_every = 10;
  auto g = MakeEstimator(s, Vec::Zero(2));
  CHECK(dynamic_cast<const Gtls&>(*g).noise_shape() == Mat::Identity(3, 3));
  CHECK(g->name() == "gtls");
}

}  // namespace
}  // namespace hysid
