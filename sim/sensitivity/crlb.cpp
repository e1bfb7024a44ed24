#include "sim/sensitivity/crlb.hpp"

#include <cmath>
#include <stdexcept>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <fmt/format.h>

namespace hysid {

const char* ToString(CrlbStatus status) {
  switch (status) {
    case CrlbStatus::kOk: return "ok";
    case CrlbStatus::kSimulationFailed: return "simulation-failed";
    case CrlbStatus::kSingular: return "singular";
  }
  return "unknown";
}

Mat FisherInformation(const SensitivityTrajectory& s, const Vec& sigma) {
  const Eigen::Index n = s.trajectory.x.rows();
  if (sigma.size() != n || !sigma.allFinite() || !(sigma.array() > 0.0).all()) {
    throw std::invalid_argument(fmt::format("FisherInformation: sigma must have {} finite entries > 0", n));
  }
  const Eigen::Index p = s.parameters;
  const Eigen::Index k_count = s.sensitivities.cols();
  // Rows of all S_k scaled by 1/σ_i, stacked: F = WᵀW, accumulated in blocks.
  Mat fisher = Mat::Zero(p, p);
  constexpr Eigen::Index kBlock = 1024;
  Mat w(kBlock * n, p);
  for (Eigen::Index k0 = 0; k0 < k_count; k0 += kBlock) {
    const Eigen::Index count = std::min(kBlock, k_count - k0);
    for (Eigen::Index k = 0; k < count; ++k) {
      const Eigen::Map<const Mat> sk(s.sensitivities.col(k0 + k).data(), n, p);
      w.middleRows(k * n, n) = sigma.cwiseInverse().asDiagonal() * sk;
    }
    fisher.selfadjointView<Eigen::Lower>().rankUpdate(w.topRows(count * n).transpose());
  }
  return fisher.selfadjointView<Eigen::Lower>();
}

double MeanGaussianNorm(const Mat& covariance) {
  if (covariance.size() == 0) return 0.0;
  const Vec lambda =
      Eigen::SelfAdjointEigenSolver<Mat>(covariance, Eigen::EigenvaluesOnly).eigenvalues().cwiseMax(0.0);
  const double scale = lambda.sum();
  if (!(scale > 0.0)) return 0.0;
  // E√X with X = Σ λ_i χ²₁ = scale·X', X' = Σ (λ_i/scale) χ²₁; integrate in u = ln s.
  const Vec l = lambda / scale;
  auto integrand = [&](double u) {
    const double s = std::exp(u);
    double log_m = 0.0;
    for (Eigen::Index i = 0; i < l.size(); ++i) log_m -= 0.5 * std::log1p(2.0 * l[i] * s);
    return -std::expm1(log_m) * std::exp(-0.5 * u);
  };
  constexpr double kLo = -60.0, kHi = 80.0, kStep = 0.05;
  double sum = 0.0;
  for (double u = kLo; u <= kHi + 1e-12; u += kStep) sum += integrand(u);
  return std::sqrt(scale) * sum * kStep / (2.0 * std::sqrt(M_PI));
}

Crlb CrlbFromFisher(const Mat& fisher, const Unknowns& unknowns, std::vector<std::string> names) {
  Crlb out;
  out.names = std::move(names);
  out.fisher = fisher;
  const Eigen::LDLT<Mat> ldlt(fisher);
  // The rank test on the equilibrated D·F·D (D = diag(F)^(−1/2)): parameters in other units (a state
  // scaled by 1e6 scales ξ0's and μ's information by 1e-12) do not make F singular.
  const Vec diag = fisher.diagonal();
  const bool positive_diagonal = (diag.array() > 0.0).all() && diag.allFinite();
  const Vec d = positive_diagonal ? Vec(diag.cwiseSqrt().cwiseInverse()) : Vec::Ones(diag.size());
  const Eigen::LDLT<Mat> equilibrated(d.asDiagonal() * fisher * d.asDiagonal());
  if (!positive_diagonal || ldlt.info() != Eigen::Success || !ldlt.isPositive() ||
      equilibrated.info() != Eigen::Success || !equilibrated.isPositive() ||
      !(equilibrated.vectorD().minCoeff() > 1e-14)) {
    out.status = CrlbStatus::kSingular;
    out.message =
        "the Fisher information is singular: some direction of the parameters is not "
        "identifiable from these samples";
    return out;
  }
  out.covariance = ldlt.solve(Mat::Identity(fisher.rows(), fisher.cols()));
  out.covariance = 0.5 * (out.covariance + out.covariance.transpose()).eval();
  out.sd = out.covariance.diagonal().cwiseSqrt();
  const auto na = static_cast<Eigen::Index>(unknowns.alpha.size());
  const auto nb = static_cast<Eigen::Index>(unknowns.beta.size());
  out.mean_e_alpha = MeanGaussianNorm(out.covariance.topLeftCorner(na, na));
  out.mean_e_beta = MeanGaussianNorm(out.covariance.block(na, na, nb, nb));
  return out;
}

Crlb ComputeCrlb(const Model& model, const Vec& x0, const SampleGrid& grid, const Vec& sigma,
                 const Unknowns& unknowns, const SensitivityOptions& options, const InputSignal* inputs) {
  if (sigma.size() != model.state_size() || !sigma.allFinite() || !(sigma.array() > 0.0).all()) {
    throw std::invalid_argument(fmt::format("sigma must have {} finite entries > 0", model.state_size()));
  }
  const SensitivityTrajectory s =
      SimulateSensitivities(model, HybridParameters::Of(model, x0), unknowns, grid, options, inputs);
  if (!s.ok()) {
    Crlb out;
    out.status = CrlbStatus::kSimulationFailed;
    out.message = fmt::format("the sensitivity simulation stopped: {}: {}",
                              ToString(s.trajectory.status.stop), s.trajectory.status.message);
    out.names = unknowns.Names(model);
    return out;
  }
  Crlb out = CrlbFromFisher(FisherInformation(s, sigma), unknowns, unknowns.Names(model));
  out.samples = s.trajectory.size();
  out.jumps = static_cast<int>(s.trajectory.jumps.size());
  return out;
}

}  // namespace hysid
