// The integral estimator against an independent batch computation: per segment, the running sums of
// the rows with the anchor as a sample at zero, one offset per identified row, least squares.
#include <catch2/catch.hpp>

#include <vector>

#include <Eigen/Dense>

#include "core/estimators/estimator.hpp"
#include "core/estimators/integral.hpp"
#include "sim/measurement.hpp"

namespace hysid {
namespace {

double Normal(std::uint64_t seed, std::uint64_t i, std::uint64_t j) {
  return StandardNormals(NoiseKey{seed, 0}, RandomPurpose::kMeasurementNoise, i, j).v[0];
}

// Segments of rows (rows_per_sample × p each), consecutive rows of one segment.
struct Segment {
  std::vector<Mat> phi;
  std::vector<Vec> y;
};

// ξ_{k,r} = c_r + I_{k,r} θ with the offsets c eliminated by explicit offset columns: the design
// [I_k | e_r ⊗ segment] over every sample, anchor included, solved by a QR of the stacked system
// with the ridge rows √(1/p0)·(θ − θ0).
Vec Batch(const std::vector<Segment>& segments, const Vec& theta0, double p0, Mat* a_out) {
  const Eigen::Index p = theta0.size();
  long samples = 0, offsets = 0;
  for (const Segment& s : segments) {
    samples += static_cast<long>(s.phi.size() + 1) * s.phi.front().rows();
    offsets += s.phi.front().rows();
  }
  Mat design = Mat::Zero(samples + p, p + offsets);
  Vec rhs = Vec::Zero(samples + p);
  long row = 0, offset = 0;
  for (const Segment& s : segments) {
    const Eigen::Index rows = s.phi.front().rows();
    Mat cum = Mat::Zero(rows, p);
    Vec z = Vec::Zero(rows);
    for (std::size_t k = 0; k <= s.phi.size(); ++k) {
      if (k > 0) {
        cum += s.phi[k - 1];
        z += s.y[k - 1];
      }
      for (Eigen::Index r = 0; r < rows; ++r, ++row) {
        design.block(row, 0, 1, p) = cum.row(r);
        design(row, p + offset + r) = 1.0;
        rhs[row] = z[r];
      }
    }
    offset += rows;
  }
  const double w = std::sqrt(1.0 / p0);
  design.block(samples, 0, p, p) = w * Mat::Identity(p, p);
  rhs.tail(p) = w * theta0;
  const Vec x = design.colPivHouseholderQr().solve(rhs);
  // A = the θ block of the normal equations with the offsets eliminated (Schur complement).
  const Mat n = design.topRows(samples).transpose() * design.topRows(samples);
  const Mat aoo = n.bottomRightCorner(offsets, offsets);
  *a_out =
      n.topLeftCorner(p, p) - n.topRightCorner(p, offsets) * aoo.ldlt().solve(n.bottomLeftCorner(offsets, p));
  return x.head(p);
}

std::vector<Segment> RandomSegments(const std::vector<int>& lengths, Eigen::Index rows, const Vec& theta,
                                    double noise, std::uint64_t seed) {
  std::vector<Segment> out;
  std::uint64_t i = 0;
  for (int len : lengths) {
    Segment s;
    for (int k = 0; k < len; ++k, ++i) {
      Mat phi(rows, theta.size());
      for (Eigen::Index r = 0; r < rows; ++r) {
        for (Eigen::Index c = 0; c < theta.size(); ++c) {
          phi(r, c) = 0.01 * (1.0 + c + 0.5 * Normal(seed, i, static_cast<std::uint64_t>(r * 8 + c)));
        }
      }
      Vec y = phi * theta;
      for (Eigen::Index r = 0; r < rows; ++r)
        y[r] += noise * Normal(seed + 1, i, static_cast<std::uint64_t>(r));
      s.phi.push_back(phi);
      s.y.push_back(y);
    }
    out.push_back(s);
  }
  return out;
}

void Feed(Estimator* e, const std::vector<Segment>& segments, bool rows_direct) {
  for (const Segment& s : segments) {
    for (std::size_t k = 0; k < s.phi.size(); ++k) {
      if (rows_direct) {
        const Vec row = s.phi[k].row(0).transpose();
        static_cast<IntegralLs*>(e)->UpdateRow(row.data(), s.y[k][0]);
      } else {
        e->Update(s.phi[k], s.y[k]);
      }
    }
    e->Break();
  }
}

TEST_CASE("integral estimator equals the batch offset-per-segment least squares", "[integral]") {
  for (int p : {1, 2, 3, 4}) {
    for (Eigen::Index rows : {1, 2}) {
      INFO("p = " << p << ", rows = " << rows);
      Vec theta(p), theta0 = Vec::Constant(p, 0.3);
      for (int i = 0; i < p; ++i) theta[i] = 1.0 - 0.7 * i;
      const auto segments = RandomSegments({40, 3, 200, 17}, rows, theta, 1e-3, 7 + p);
      for (double p0 : {1e-2, 1e8}) {
        EstimatorSettings s;
        s.kind = EstimatorKind::kIntegral;
        s.p0 = p0;
        auto e = MakeEstimator(s, theta0);
        Feed(e.get(), segments, false);
        Mat a;
        const Vec want = Batch(segments, theta0, p0, &a);
        CHECK(e->status() == EstimatorStatus::kOk);
        CHECK((e->estimate() - want).norm() <= 1e-9 * (1.0 + want.norm()));
        a.diagonal().array() += 1.0 / p0;
        const Mat cov = 0.5 * a.inverse();
        CHECK((*e->covariance_matrix() - cov).norm() <= 1e-8 * cov.norm());
      }
    }
  }
}

TEST_CASE("integral estimator: UpdateRow equals Update - noise-free rows give θ - Reset", "[integral]") {
  Vec theta(2), theta0 = Vec::Zero(2);
  theta << 5.0, 0.1;
  const auto noisy = RandomSegments({300, 50}, 1, theta, 1e-2, 3);
  IntegralLs a(theta0, Vec::Constant(2, 1e8)), b(theta0, Vec::Constant(2, 1e8));
  Feed(&a, noisy, false);
  Feed(&b, noisy, true);
  CHECK(a.estimate() == b.estimate());
  CHECK(*a.covariance_matrix() == *b.covariance_matrix());
  CHECK(a.updates() == 350);
  IntegralLs exact(theta0, Vec::Constant(2, 1e12));
  Feed(&exact, RandomSegments({100, 100}, 1, theta, 0.0, 4), false);
  CHECK((exact.estimate() - theta).norm() < 1e-8);
  exact.Reset();
  CHECK(exact.estimate() == theta0);
  CHECK(exact.status() == EstimatorStatus::kNotExcited);
}

TEST_CASE("integral estimator: not excited until p + 1 informative rows - non-finite rows skipped",
          "[integral]") {
  IntegralLs e(Vec::Zero(2), Vec::Constant(2, 1e8));
  Mat phi(1, 2);
  phi << 0.01, 0.02;
  e.Update(phi, Vec::Constant(1, 0.03));
  e.Update(phi * 2.0, Vec::Constant(1, 0.05));
  CHECK(e.status() == EstimatorStatus::kNotExcited);
  e.Update(Mat::Constant(1, 2, std::nan("")), Vec::Constant(1, 1.0));
  CHECK(e.skipped() == 1);
  phi << 0.03, -0.01;
  e.Update(phi, Vec::Constant(1, 0.01));
  CHECK(e.status() == EstimatorStatus::kOk);
  CHECK(e.estimate().allFinite());
}

TEST_CASE("integral estimator is for alpha only", "[integral]") {
  const EstimatorDescriptor& d = DescriptorOf(EstimatorKind::kIntegral);
  CHECK(d.traits.flow_only);
  CHECK(d.name == "integral");
  CHECK(ParseKind<EstimatorKind>("integral") == EstimatorKind::kIntegral);
}

}  // namespace
}  // namespace hysid
