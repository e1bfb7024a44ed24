#include "core/model/noise_shape.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include <fmt/format.h>

namespace hysid {
namespace {

void CheckInputs(const Model& model, ConstVecRef sigma, const Mat& states, const char* what) {
  const int n = model.state_size();
  if (sigma.size() != n) {
    throw std::invalid_argument(fmt::format("{}: sigma has {} entries, model '{}' has {} states", what,
                                            sigma.size(), model.name(), n));
  }
  for (Eigen::Index i = 0; i < sigma.size(); ++i) {
    if (!(sigma[i] >= 0.0) || !std::isfinite(sigma[i])) {
      throw std::invalid_argument(
          fmt::format("{}: sigma[{}] = {}: must be finite and >= 0", what, i, sigma[i]));
    }
  }
  if (states.rows() != n || states.cols() < 1) {
    throw std::invalid_argument(fmt::format("{}: states is {}x{}, expected {} x (at least 1)", what,
                                            states.rows(), states.cols(), n));
  }
  if (!states.allFinite()) throw std::invalid_argument(fmt::format("{}: states must be finite", what));
}

// Ĝ for one row r at state x: rows = unknown columns' gradients, last = −gradient of the known part.
// `map` evaluates φ (or ψ) into an n × parameter matrix.
template <class Map>
Mat AugmentedJacobian(const Map& map, const RegressionLayout& layout, const Vec& known_values, int r,
                      const Vec& x) {
  const int n = layout.state_size;
  const int u = static_cast<int>(layout.unknown.size());
  Mat out = Mat::Zero(u + 1, n);
  Mat plus(n, layout.parameter_size), minus(n, layout.parameter_size);
  Vec xp = x, xm = x;
  for (int l = 0; l < n; ++l) {
    const double h = 1e-6 * std::max(1.0, std::abs(x[l]));
    xp[l] = x[l] + h;
    xm[l] = x[l] - h;
    map(xp, plus);
    map(xm, minus);
    xp[l] = x[l];
    xm[l] = x[l];
    const double inv = 1.0 / (2.0 * h);
    for (int j = 0; j < u; ++j) {
      const int c = layout.unknown[static_cast<std::size_t>(j)];
      out(j, l) = (plus(r, c) - minus(r, c)) * inv;
    }
    double known = 0.0;
    for (int c : layout.known) known += (plus(r, c) - minus(r, c)) * inv * known_values[c];
    out(u, l) = -known;
  }
  return out;
}

// The mean over the columns x of `states` and the identified rows r of the layout of the per-row C,
// symmetrised. `map` evaluates φ (or ψ); add(Ĝ, σ², r, c) adds one row's C (with Ĝ from
// AugmentedJacobian) to c.
template <class Map, class AddRow>
Mat MeanShape(const Map& map, const RegressionLayout& layout, const Vec& known_values, ConstVecRef sigma,
              const Mat& states, const AddRow& add) {
  const Eigen::Index m = static_cast<Eigen::Index>(layout.unknown.size()) + 1;
  const Vec r2 = sigma.array().square();
  Mat c = Mat::Zero(m, m);
  for (Eigen::Index k = 0; k < states.cols(); ++k) {
    const Vec x = states.col(k);
    for (int r : layout.rows) add(AugmentedJacobian(map, layout, known_values, r, x), r2, r, c);
  }
  c /= static_cast<double>(states.cols() * static_cast<Eigen::Index>(layout.rows.size()));
  return 0.5 * (c + c.transpose());
}

}  // namespace

Mat FlowNoiseShape(const Model& model, ConstVecRef sigma, double dt, const Mat& states) {
  CheckInputs(model, sigma, states, "FlowNoiseShape");
  if (!(dt > 0.0) || !std::isfinite(dt)) {
    throw std::invalid_argument(fmt::format("FlowNoiseShape: dt = {}: must be > 0", dt));
  }
  auto map = [&](const Vec& x, Mat& out) { model.Phi(x, out); };
  // (δt²/2) Ĝ R Ĝᵀ + 2 R_rr in the last diagonal entry.
  auto add = [dt](const Mat& g, const Vec& r2, int r, Mat& c) {
    c += 0.5 * dt * dt * g * r2.asDiagonal() * g.transpose();
    c(c.rows() - 1, c.cols() - 1) += 2.0 * r2[r];
  };
  return MeanShape(map, RegressionLayout::Flow(model), model.alpha(), sigma, states, add);
}

Mat JumpNoiseShape(const Model& model, ConstVecRef sigma, const Mat& states) {
  CheckInputs(model, sigma, states, "JumpNoiseShape");
  auto map = [&](const Vec& x, Mat& out) { model.Psi(x, out); };
  // Ĵ R Ĵᵀ + R_rr in the last diagonal entry.
  auto add = [](const Mat& j, const Vec& r2, int r, Mat& c) {
    c += j * r2.asDiagonal() * j.transpose();
    c(c.rows() - 1, c.cols() - 1) += r2[r];
  };
  return MeanShape(map, RegressionLayout::Jump(model), model.beta(), sigma, states, add);
}

double NoiseSigmaFromSecondDifferences(std::vector<double>& d) {
  if (d.size() < 2) {
    throw std::invalid_argument(
        fmt::format("EstimateNoiseSigma: y has {} samples (columns), need at least 4", d.size() + 2));
  }
  if (!std::all_of(d.begin(), d.end(), [](double v) { return std::isfinite(v); })) {
    throw std::invalid_argument("EstimateNoiseSigma: y must be finite");
  }
  auto median = [](std::vector<double>& v) {
    const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
    std::nth_element(v.begin(), mid, v.end());
    double med = *mid;
    if (v.size() % 2 == 0) med = 0.5 * (med + *std::max_element(v.begin(), mid));
    return med;
  };
  const double centre = median(d);
  for (double& v : d) v = std::abs(v - centre);
  return 1.4826 * median(d) / std::sqrt(6.0);
}

Vec EstimateNoiseSigma(const Mat& y) {
  if (y.cols() < 4) {
    throw std::invalid_argument(
        fmt::format("EstimateNoiseSigma: y has {} samples (columns), need at least 4", y.cols()));
  }
  if (!y.allFinite()) throw std::invalid_argument("EstimateNoiseSigma: y must be finite");
  const Eigen::Index k = y.cols() - 2;
  Vec sigma(y.rows());
  std::vector<double> d(static_cast<std::size_t>(k));
  for (Eigen::Index i = 0; i < y.rows(); ++i) {
    for (Eigen::Index j = 0; j < k; ++j) {
      d[static_cast<std::size_t>(j)] = y(i, j + 2) - 2.0 * y(i, j + 1) + y(i, j);
    }
    sigma[i] = NoiseSigmaFromSecondDifferences(d);
  }
  return sigma;
}

}  // namespace hysid
