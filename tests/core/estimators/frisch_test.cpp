// Recursive Frisch scheme: vertices = elementary regressions, box coverage of the truth with
// diagonal noise (cumulative vs BBRF-intersected windows), point error, degenerate data.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>

#include <Eigen/Dense>

#include "core/estimators/estimator.hpp"
#include "core/estimators/frisch.hpp"
#include "tests/testing/eiv_problem.hpp"

namespace hysid {
namespace {

using testing::EivData;
using testing::MakeEivData;

std::unique_ptr<Estimator> MakeFrisch(int p, int window, const std::string& box,
                                      const std::string& point = "rls", double confidence = 0.0) {
  EstimatorSettings s;
  s.kind = EstimatorKind::kFrisch;
  s.window = window;
  s.frisch_confidence = confidence;
  FindOption(EstimatorOptions(), "frisch_box")
      ->set(s, FindOption(EstimatorOptions(), "frisch_box")->Parse(box));
  FindOption(EstimatorOptions(), "frisch_point")
      ->set(s, FindOption(EstimatorOptions(), "frisch_point")->Parse(point));
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

TEST_CASE(
    "frisch box coverage with diagonal noise: plain BBRF loses the truth, the sampling allowance keeps it",
    "[frisch]") {
  Vec theta(2), sigma_phi(2);
  theta << 1.5, -0.7;
  sigma_phi << 0.4, 0.3;
  const double sigma_y = 0.3;
  const int runs = 300;
  const long rows = 2000;
  const int window = 200;
  // [confidence 0 (plain Frisch / BBRF), default 0.95] × [cumulative, intersect]
  int covered[2][2] = {}, empties = 0;
  double volume[2][2] = {}, err_clamped[2] = {}, err_centre = 0.0, err_rls = 0.0;
  for (int run = 0; run < runs; ++run) {
    const EivData d = MakeEivData(theta, sigma_phi, sigma_y, rows, 77, static_cast<unsigned>(run));
    for (int m = 0; m < 2; ++m) {
      for (int b = 0; b < 2; ++b) {
        auto e = MakeFrisch(2, window, b == 0 ? "cumulative" : "intersect", "rls", m == 0 ? 0.0 : 0.95);
        Feed(*e, d);
        const auto& f = dynamic_cast<const Frisch&>(*e);
        REQUIRE(f.status() == EstimatorStatus::kOk);
        REQUIRE(f.estimate().allFinite());
        covered[m][b] += f.Contains(theta) ? 1 : 0;
        volume[m][b] += f.BoxVolume();
        if (b == 0) {
          // Point "rls": RLS clamped into the intersected box (then into the reported one).
          err_clamped[m] += (f.estimate() - theta).norm();
          const bool inside = f.Contains(theta) && (theta.array() >= f.intersect_lower().array()).all() &&
                              (theta.array() <= f.intersect_upper().array()).all();
          if (inside) {
            // Clamping into boxes that contain θ cannot increase any coordinate's error.
            const Vec gap = (f.rls_estimate() - theta).cwiseAbs() - (f.estimate() - theta).cwiseAbs();
            CHECK(gap.minCoeff() >= -1e-12);
          }
          if (m == 0) err_rls += (f.rls_estimate() - theta).norm();
        } else if (m == 0) {
          empties += f.empty_intersections() > 0 ? 1 : 0;
        }
      }
    }
    auto centre = MakeFrisch(2, window, "cumulative", "centre");
    Feed(*centre, d);
    err_centre += (centre->estimate() - theta).norm();
  }
  auto rate = [&](int m, int b) { return double(covered[m][b]) / runs; };
  std::printf("[frisch] %d runs x %ld rows, window %d, sigma_phi (%.1f, %.1f), sigma_y %.1f\n", runs, rows,
              window, sigma_phi[0], sigma_phi[1], sigma_y);
  for (int m = 0; m < 2; ++m) {
    std::printf(
        "[frisch] confidence %.2f: coverage cumulative %.3f (mean box volume %.4f), intersect "
        "%.3f (volume %.4f); mean |theta_hat - theta| of RLS clamped into intersect %.4f\n",
        0.95 * m, rate(m, 0), volume[m][0] / runs, rate(m, 1), volume[m][1] / runs, err_clamped[m] / runs);
  }
  std::printf(
      "[frisch] mean |theta_hat - theta|: RLS %.4f, centre of the cumulative box %.4f; "
      "runs with an empty BBRF intersection %d\n",
      err_rls / runs, err_centre / runs, empties);
  // Plain Frisch (no allowance): the cumulative box keeps θ, the intersection of 10 sampled windows
  // misses it far more often (see frisch.hpp) — and that shrinkage is what makes the clamped RLS
  // point better than RLS.
  CHECK(rate(0, 0) >= 0.95);
  CHECK(rate(0, 1) <= rate(0, 0) - 0.2);
  CHECK(err_clamped[0] < 0.8 * err_rls);
  // With the default allowance (0.95) both boxes keep θ, and the point is
  // then no better than RLS: it gains only where the box has cut into RLS's sampling spread.
  CHECK(rate(1, 0) >= 0.95);
  CHECK(rate(1, 1) >= 0.95);
  CHECK(err_clamped[1] <= err_rls * (1.0 + 1e-12));
}

TEST_CASE("frisch with an exact column: the face box keeps the truth and is smaller", "[frisch]") {
  // Column 1 is an exact constant 1 (C_11 = 0). Solutions satisfy v = Σ⁻¹Σ̃v with Σ̃_11 = 0, so they
  // lie on the face spanned by the vertices of the noisy columns 0 and 2 (see frisch.hpp).
  Vec theta(2), sigma_phi(2);
  theta << 0.8, 0.7;
  sigma_phi << 0.5, 0.0;
  const double sigma_y = 0.5;
  Mat c = Mat::Zero(3, 3);
  c.diagonal() << 0.25, 0.0, 0.25;
  const int runs = 300;
  const long rows = 1000;
  int covered_face = 0, covered_full = 0, covered_plain = 0;
  double volume_face = 0.0, volume_full = 0.0, err_point = 0.0, err_rls = 0.0;
  for (int run = 0; run < runs; ++run) {
    // Column 1 was drawn noise-free as x₁ ~ N(0, 1): replace it by 1, so y = 0.8 x₀ + 0.7 + e.
    EivData d = MakeEivData(theta, sigma_phi, sigma_y, rows, 91, static_cast<unsigned>(run));
    d.y.array() += theta[1] * (1.0 - d.phi.col(1).array());
    d.phi.col(1).setOnes();
    EstimatorSettings s;
    s.kind = EstimatorKind::kFrisch;
    s.window = 250;  // default sampling allowance (confidence 0.95)
    s.noise_shape = c;
    auto face = MakeEstimator(s, Vec::Zero(2));
    s.frisch_confidence = 0.0;
    auto plain = MakeEstimator(s, Vec::Zero(2));
    s.frisch_confidence = 0.95;
    s.noise_shape = Mat();
    auto full = MakeEstimator(s, Vec::Zero(2));
    Feed(*face, d);
    Feed(*plain, d);
    Feed(*full, d);
    covered_plain += dynamic_cast<const Frisch&>(*plain).Contains(theta) ? 1 : 0;
    const auto& ff = dynamic_cast<const Frisch&>(*face);
    const auto& fu = dynamic_cast<const Frisch&>(*full);
    REQUIRE(ff.has_box());
    REQUIRE(ff.noisy_columns() == std::vector<Eigen::Index>{0, 2});
    if (run == 0) {
      // The face vertices are the full simplex's vertices 0 and 2.
      CHECK((ff.vertices().col(0) - fu.vertices().col(0)).norm() <= 1e-12 * fu.vertices().col(0).norm());
      CHECK((ff.vertices().col(1) - fu.vertices().col(2)).norm() <= 1e-12 * fu.vertices().col(2).norm());
    }
    covered_face += ff.Contains(theta) ? 1 : 0;
    covered_full += fu.Contains(theta) ? 1 : 0;
    volume_face += ff.BoxVolume();
    volume_full += fu.BoxVolume();
    err_point += (ff.estimate() - theta).norm();
    err_rls += (ff.rls_estimate() - theta).norm();
  }
  std::printf(
      "[frisch] exact column, %d runs x %ld rows: coverage face %.3f (mean volume %.4f; "
      "without the allowance %.3f), full simplex %.3f (mean volume %.4f); "
      "mean |theta_hat - theta| %.4f (RLS %.4f)\n",
      runs, rows, double(covered_face) / runs, volume_face / runs, double(covered_plain) / runs,
      double(covered_full) / runs, volume_full / runs, err_point / runs, err_rls / runs);
  CHECK(double(covered_face) / runs >= 0.95);
  CHECK(volume_face <= 0.5 * volume_full);
  // Without the allowance the face box is the population statement only: the intercept is the same at
  // both vertices (x₀ has mean 0), so its box is far thinner than its sampling error.
  CHECK(double(covered_plain) / runs <= 0.5);
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
  s.kind = EstimatorKind::kFrisch;
  s.window = 2;
  CHECK_THROWS_WITH(MakeEstimator(s, Vec::Zero(2)), Catch::Contains("window = 2"));
  s.window = 10;
  // Choices are enums in the library: a bad name is refused where text becomes one.
  CHECK_THROWS_WITH(FindOption(EstimatorOptions(), "frisch_box")->Parse("union"),
                    Catch::Contains("frisch_box = 'union'"));
  s.frisch_box = FrischBox::kIntersect;
  CHECK_THROWS_WITH(FindOption(EstimatorOptions(), "frisch_point")->Parse("median"),
                    Catch::Contains("frisch_point = 'median'"));
  s.frisch_point = FrischPoint::kClampedRls;
  s.frisch_confidence = 1.0;
  CHECK_THROWS_WITH(MakeEstimator(s, Vec::Zero(2)), Catch::Contains("frisch_confidence = 1"));
  s.frisch_confidence = 0.9;
  s.noise_shape = Mat::Identity(2, 2);
  CHECK_THROWS_WITH(MakeEstimator(s, Vec::Zero(2)), Catch::Contains("noise_shape is 2x2"));
  s.noise_shape = Mat();
  CHECK(MakeEstimator(s, Vec::Zero(2))->name() == "frisch");
}

}  // namespace
}  // namespace hysid
