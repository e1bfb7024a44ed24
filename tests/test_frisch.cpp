// Recursive Frisch scheme: vertices = elementary regressions, box coverage of the truth with
// diagonal noise (cumulative vs BBRF-intersected windows), point error, degenerate data.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>

#include <Eigen/Dense>

#include "core/estimator.hpp"
#include "core/estimators/frisch.hpp"
#include "tests/eiv_problem.hpp"

namespace hysid {
namespace {

using testing::EivData;
using testing::MakeEivData;

std::unique_ptr<Estimator> MakeFrisch(int p, int window, const std::string& box,
                                      const std::string& point = "rls") {
  EstimatorSettings s;
  s.name = "frisch";
  s.window = window;
  s.frisch_box = box;
  s.frisch_point = point;
  return MakeEstimator(s, Vec::Zero(p));
}

void Feed(Estimator& e, const EivData& d) {
  for (long k = 0; k < d.phi.rows(); ++k) e.Update(d.phi.middleRows(k, 1), d.y.segment(k, 1));
}

TEST_CASE("frisch vertices are the elementary regressions", "[frisch]") {
  Vec theta(2), sigma_phi(2);
  theta << 1.5, -0.7;
  sigma_phi << 0.3, 0.3;
  const EivData d = MakeEivData(theta, sigma_phi, 0.3, 400, 21, 0);
  auto e = MakeFrisch(2, 400, "cumulative");
  Feed(*e, d);
  const auto& f = dynamic_cast<const Frisch&>(*e);
  REQUIRE(f.has_box());
  Mat z(d.phi.rows(), 3);
  z << d.phi, d.y;
  // Elementary regression i: z_i on the other columns (all noise on column i), written as v with
  // v_i = 1, then normalised to v_last = −1.
  for (int i = 0; i < 3; ++i) {
    Mat others(z.rows(), 2);
    int col = 0;
    for (int j = 0; j < 3; ++j) {
      if (j != i) others.col(col++) = z.col(j);
    }
    const Vec b = (others.transpose() * others).ldlt().solve(others.transpose() * z.col(i));
    Vec v(3);
    col = 0;
    for (int j = 0; j < 3; ++j) v[j] = j == i ? 1.0 : -b[col++];
    const Vec vertex = -v.head(2) / v[2];
    INFO("vertex " << i);
    CHECK((f.vertices().col(i) - vertex).norm() <= 1e-9 * vertex.norm());
  }
  // The last vertex is least squares; the box bounds all vertices.
  const Vec ls = (d.phi.transpose() * d.phi).ldlt().solve(d.phi.transpose() * d.y);
  CHECK((f.vertices().col(2) - ls).norm() <= 1e-9 * ls.norm());
  CHECK((f.lower().array() <= f.vertices().rowwise().minCoeff().array() + 1e-15).all());
  CHECK((f.upper().array() >= f.vertices().rowwise().maxCoeff().array() - 1e-15).all());
  CHECK(f.kalman_condition());
}

TEST_CASE("frisch box coverage with diagonal noise: cumulative keeps the truth, BBRF loses it",
          "[frisch]") {
  Vec theta(2), sigma_phi(2);
  theta << 1.5, -0.7;
  sigma_phi << 0.4, 0.3;
  const double sigma_y = 0.3;
  const int runs = 300;
  const long rows = 2000;
  const int window = 200;
  int covered_cumulative = 0, covered_intersect = 0, empties = 0;
  double err_centre = 0.0, err_intersect = 0.0, err_rls = 0.0, err_clamped = 0.0;
  double volume_cumulative = 0.0, volume_intersect = 0.0;
  for (int run = 0; run < runs; ++run) {
    const EivData d = MakeEivData(theta, sigma_phi, sigma_y, rows, 77, static_cast<unsigned>(run));
    auto cumulative = MakeFrisch(2, window, "cumulative");
    auto intersect = MakeFrisch(2, window, "intersect", "centre");
    auto centre = MakeFrisch(2, window, "cumulative", "centre");
    Feed(*cumulative, d);
    Feed(*intersect, d);
    Feed(*centre, d);
    const auto& fc = dynamic_cast<const Frisch&>(*cumulative);
    const auto& fi = dynamic_cast<const Frisch&>(*intersect);
    REQUIRE(fc.status() == EstimatorStatus::kOk);
    REQUIRE(fc.estimate().allFinite());
    covered_cumulative += fc.Contains(theta) ? 1 : 0;
    covered_intersect += fi.Contains(theta) ? 1 : 0;
    empties += fi.empty_intersections() > 0 ? 1 : 0;
    err_centre += (centre->estimate() - theta).norm();
    err_intersect += (fi.estimate() - theta).norm();
    err_rls += (fc.rls_estimate() - theta).norm();
    err_clamped += (fc.estimate() - theta).norm();  // default point: RLS clamped into BBRF box
    volume_cumulative += fc.BoxVolume();
    volume_intersect += fi.BoxVolume();
  }
  const double rate_c = double(covered_cumulative) / runs, rate_i = double(covered_intersect) / runs;
  std::printf("[frisch] %d runs x %ld rows, window %d, sigma_phi (%.1f, %.1f), sigma_y %.1f\n",
              runs, rows, window, sigma_phi[0], sigma_phi[1], sigma_y);
  std::printf("[frisch] coverage: cumulative %.3f (mean box volume %.4f), intersect (BBRF) %.3f "
              "(volume %.5f, runs with an empty intersection %d)\n",
              rate_c, volume_cumulative / runs, rate_i, volume_intersect / runs, empties);
  std::printf("[frisch] mean |theta_hat - theta|: centre(cumulative) %.4f, centre(intersect) %.4f, "
              "RLS clamped into intersect %.4f, RLS %.4f\n",
              err_centre / runs, err_intersect / runs, err_clamped / runs, err_rls / runs);
  CHECK(rate_c >= 0.95);
  // The intersection of 10 sampled windows misses θ far more often (see frisch.hpp).
  CHECK(rate_i <= rate_c - 0.2);
  // The default point (RLS clamped into the intersected box) corrects part of the attenuation.
  CHECK(err_clamped < 0.8 * err_rls);
}

TEST_CASE("frisch degenerate data gives a status, never NaN", "[frisch]") {
  SECTION("no excitation") {
    auto e = MakeFrisch(2, 10, "intersect");
    for (int k = 0; k < 500; ++k) e->Update(Mat::Zero(1, 2), Vec::Zero(1));
    const auto& f = dynamic_cast<const Frisch&>(*e);
    CHECK(e->status() == EstimatorStatus::kNotExcited);
    CHECK_FALSE(f.has_box());
    CHECK(f.skipped_windows() == 50);
    CHECK(e->estimate().allFinite());
  }
  SECTION("repeated rows") {
    auto e = MakeFrisch(2, 0, "cumulative");
    Mat row(1, 2);
    row << 1.0, -1.0;
    for (int k = 0; k < 100; ++k) e->Update(row, Vec::Constant(1, 0.5));
    CHECK(e->status() == EstimatorStatus::kNotExcited);
    CHECK(e->estimate().allFinite());
  }
  SECTION("a zero column") {
    const EivData d = MakeEivData(Vec::Ones(2), Vec::Constant(2, 0.2), 0.2, 300, 3, 0);
    Mat phi = d.phi;
    phi.col(0).setZero();
    auto e = MakeFrisch(2, 50, "cumulative");
    for (long k = 0; k < 300; ++k) e->Update(phi.row(k), d.y.segment(k, 1));
    CHECK(e->status() == EstimatorStatus::kNotExcited);
    CHECK(e->estimate().allFinite());
  }
  SECTION("noise-free data: Σ singular, windows skipped, the RLS estimate stands") {
    Vec theta(2);
    theta << 2.0, -1.0;
    const EivData d = MakeEivData(theta, Vec::Zero(2), 0.0, 400, 4, 0);
    auto e = MakeFrisch(2, 100, "intersect");
    Feed(*e, d);
    CHECK(e->status() == EstimatorStatus::kNotExcited);
    CHECK((e->estimate() - theta).norm() <= 1e-6);
  }
}

TEST_CASE("frisch settings errors name the field", "[frisch]") {
  EstimatorSettings s;
  s.name = "frisch";
  s.window = 2;
  CHECK_THROWS_WITH(MakeEstimator(s, Vec::Zero(2)), Catch::Contains("window = 2"));
  s.window = 10;
  s.frisch_box = "union";
  CHECK_THROWS_WITH(MakeEstimator(s, Vec::Zero(2)), Catch::Contains("frisch_box = 'union'"));
  s.frisch_box = "intersect";
  s.frisch_point = "median";
  CHECK_THROWS_WITH(MakeEstimator(s, Vec::Zero(2)), Catch::Contains("frisch_point = 'median'"));
  s.frisch_point = "rls";
  CHECK(MakeEstimator(s, Vec::Zero(2))->name() == "frisch");
}

}  // namespace
}  // namespace hysid
