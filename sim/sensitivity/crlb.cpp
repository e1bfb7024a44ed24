#include "sim/sensitivity/crlb.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
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

Mat FisherInformation(const SensitivityTrajectory& s, const Vec& sigma, const std::vector<int>& measured,
                      const std::vector<std::uint8_t>& present) {
  const Eigen::Index n = s.trajectory.x.rows();
  std::vector<int> rows = measured;
  if (rows.empty()) {
    for (int i = 0; i < n; ++i) rows.push_back(i);
  }
  const auto m = static_cast<Eigen::Index>(rows.size());
  if (sigma.size() != m || !sigma.allFinite() || !(sigma.array() > 0.0).all()) {
    throw std::invalid_argument(fmt::format("FisherInformation: sigma must have {} finite entries > 0", m));
  }
  for (const int i : rows) {
    if (i < 0 || i >= n) throw std::invalid_argument(fmt::format("FisherInformation: measured state {} of {}", i, n));
  }
  const Eigen::Index p = s.parameters;
  const Eigen::Index k_count = s.sensitivities.cols();
  if (!present.empty() && static_cast<Eigen::Index>(present.size()) != k_count) {
    throw std::invalid_argument(
        fmt::format("FisherInformation: present has {} entries for {} samples", present.size(), k_count));
  }
  // Rows of all H S_k scaled by 1/σ_i, stacked: F = WᵀW, accumulated in blocks.
  Mat fisher = Mat::Zero(p, p);
  constexpr Eigen::Index kBlock = 1024;
  Mat w(kBlock * m, p);
  const Vec inverse = sigma.cwiseInverse();
  for (Eigen::Index k0 = 0; k0 < k_count; k0 += kBlock) {
    Eigen::Index count = 0;
    for (Eigen::Index k = k0; k < std::min(k0 + kBlock, k_count); ++k) {
      if (!present.empty() && present[std::size_t(k)] == 0) continue;
      const Eigen::Map<const Mat> sk(s.sensitivities.col(k).data(), n, p);
      w.middleRows(count++ * m, m) = inverse.asDiagonal() * sk(rows, Eigen::all);
    }
    fisher.selfadjointView<Eigen::Lower>().rankUpdate(w.topRows(count * m).transpose());
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

std::vector<double> MeanEBetaPerMap(const ModelSpec& spec, const Unknowns& unknowns, const Crlb& c) {
  const auto offset = static_cast<Eigen::Index>(unknowns.alpha.size());
  std::vector<double> out;
  for (const JumpMap& map : spec.jumps) {
    std::vector<Eigen::Index> block;
    for (std::size_t i = 0; i < unknowns.beta.size(); ++i) {
      const int b = unknowns.beta[i];
      if (b >= map.beta_first && b < map.beta_first + map.beta_count) block.push_back(offset + Eigen::Index(i));
    }
    out.push_back(block.empty() ? std::numeric_limits<double>::quiet_NaN()
                                : MeanGaussianNorm(c.covariance(block, block)));
  }
  return out;
}

namespace {

// The eigenvector of the smallest eigenvalue of the equilibrated F, its largest entries named
// (Direction): "direction 0.71 x0[v] - 0.70 g; smallest eigenvalue ..." ("F is not finite" when it
// is not).
std::string WeakestDirection(const Mat& equilibrated, const std::vector<std::string>& names) {
  if (!equilibrated.allFinite() || equilibrated.size() == 0) return "F is not finite";
  const Eigen::SelfAdjointEigenSolver<Mat> eigen(equilibrated);
  return fmt::format("{}; smallest eigenvalue {:.3g} of the equilibrated F",
                     Direction(eigen.eigenvectors().col(0), names), eigen.eigenvalues()[0]);
}

// CrlbFromFisher with `held` entries known: the bound of the others, scattered back.
Crlb CrlbHolding(const Mat& fisher, const Unknowns& unknowns, std::vector<std::string> names,
                 const std::vector<int>& held) {
  std::vector<int> free;
  std::vector<std::string> free_names;
  for (int i = 0; i < static_cast<int>(fisher.rows()); ++i) {
    if (std::find(held.begin(), held.end(), i) != held.end()) continue;
    free.push_back(i);
    if (static_cast<std::size_t>(i) < names.size()) free_names.push_back(names[static_cast<std::size_t>(i)]);
  }
  // The unknowns left: each of the α, β and γ blocks without its held entries (θ's order), no ξ0.
  Unknowns shared;
  shared.x0 = false;
  int at = 0;
  auto keep = [&](const std::vector<int>& block, std::vector<int>& kept) {
    for (const int entry : block) {
      if (std::find(held.begin(), held.end(), at++) == held.end()) kept.push_back(entry);
    }
  };
  keep(unknowns.alpha, shared.alpha);
  keep(unknowns.beta, shared.beta);
  keep(unknowns.gamma, shared.gamma);
  Crlb reduced = CrlbFromFisher(fisher(free, free), shared, std::move(free_names));
  Crlb out = reduced;
  out.names = std::move(names);
  out.fisher = fisher;
  if (!reduced.ok()) return out;
  out.covariance = Mat::Zero(fisher.rows(), fisher.cols());
  out.sd = Vec::Zero(fisher.rows());
  for (std::size_t a = 0; a < free.size(); ++a) {
    const auto ia = static_cast<Eigen::Index>(a);
    out.sd[free[a]] = reduced.sd[ia];
    for (std::size_t b = 0; b < free.size(); ++b) {
      out.covariance(free[a], free[b]) = reduced.covariance(ia, static_cast<Eigen::Index>(b));
    }
  }
  return out;
}

}  // namespace

std::string Direction(const Vec& v, const std::vector<std::string>& names) {
  std::vector<Eigen::Index> order(static_cast<std::size_t>(v.size()));
  for (Eigen::Index i = 0; i < v.size(); ++i) order[static_cast<std::size_t>(i)] = i;
  std::stable_sort(order.begin(), order.end(),
                   [&](auto a, auto b) { return std::abs(v[a]) > std::abs(v[b]); });
  const double sign = v.size() > 0 && v[order.front()] < 0.0 ? -1.0 : 1.0;
  std::string text = "direction";
  for (std::size_t r = 0; r < std::min<std::size_t>(3, order.size()); ++r) {
    const Eigen::Index i = order[r];
    if (r > 0 && std::abs(v[i]) < 0.1) break;
    const std::string name = static_cast<std::size_t>(i) < names.size() ? names[static_cast<std::size_t>(i)]
                                                                        : fmt::format("theta[{}]", i);
    text +=
        fmt::format(" {}{:.2g} {}", r == 0 ? "" : (sign * v[i] < 0.0 ? "- " : "+ "), std::abs(v[i]), name);
  }
  return text;
}

Crlb CrlbFromFisher(const Mat& fisher, const Unknowns& unknowns, std::vector<std::string> names,
                    const std::vector<int>& held) {
  if (!held.empty()) return CrlbHolding(fisher, unknowns, std::move(names), held);
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
    out.message = fmt::format(
        "the Fisher information is singular: some direction of the parameters is not identifiable from "
        "these samples ({})",
        WeakestDirection(d.asDiagonal() * fisher * d.asDiagonal(), out.names));
    return out;
  }
  out.covariance = ldlt.solve(Mat::Identity(fisher.rows(), fisher.cols()));
  out.covariance = 0.5 * (out.covariance + out.covariance.transpose()).eval();
  out.sd = out.covariance.diagonal().cwiseSqrt();
  const auto na = static_cast<Eigen::Index>(unknowns.alpha.size());
  const auto nb = static_cast<Eigen::Index>(unknowns.beta.size());
  out.mean_e_alpha = MeanGaussianNorm(out.covariance.topLeftCorner(na, na));
  out.mean_e_beta = MeanGaussianNorm(out.covariance.block(na, na, nb, nb));
  const auto ng = static_cast<Eigen::Index>(unknowns.gamma.size());
  out.mean_e_gamma = MeanGaussianNorm(out.covariance.block(na + nb, na + nb, ng, ng));
  return out;
}

Vec DeterminedSd(const Mat& fisher) {
  if (fisher.rows() != fisher.cols() || fisher.size() == 0 || !fisher.allFinite()) return {};
  const Vec diag = fisher.diagonal();
  const Vec d =
      (diag.array() > 0.0)
          .select(diag.cwiseMax(std::numeric_limits<double>::min()).cwiseSqrt().cwiseInverse(), 1.0);
  const Eigen::SelfAdjointEigenSolver<Mat> eigen(d.asDiagonal() * fisher * d.asDiagonal());
  if (eigen.info() != Eigen::Success) return {};
  const Vec& lambda = eigen.eigenvalues();  // increasing
  const Mat& v = eigen.eigenvectors();
  const double cut = 1e-10 * std::max(lambda.tail(1)[0], 0.0);
  Eigen::Index null = 0;
  while (null < lambda.size() && lambda[null] <= cut) ++null;
  Vec sd(fisher.rows());
  for (Eigen::Index i = 0; i < sd.size(); ++i) {
    if (v.row(i).head(null).squaredNorm() >= 1e-6) {
      sd[i] = std::numeric_limits<double>::quiet_NaN();
      continue;
    }
    double var = 0.0;
    for (Eigen::Index j = null; j < lambda.size(); ++j) var += v(i, j) * v(i, j) / lambda[j];
    sd[i] = d[i] * std::sqrt(var);
  }
  return sd;
}

Crlb HoldKnownX0(Crlb c, const Unknowns& unknowns, const std::vector<int>& known, int n) {
  if (known.empty() || !unknowns.x0 || c.status == CrlbStatus::kSimulationFailed) return c;
  std::vector<int> held;
  for (const int i : known) held.push_back(unknowns.size(n) - n + i);
  Crlb h = CrlbFromFisher(c.fisher, unknowns, c.names, held);
  h.samples = c.samples;
  h.jumps = c.jumps;
  return h;
}

Crlb ComputeCrlb(const Model& model, const Vec& x0, const SampleGrid& grid, const Vec& sigma,
                 const Unknowns& unknowns, const SensitivityOptions& options,
                 const std::vector<int>& measured, const InputSignal* inputs,
                 const std::vector<std::uint8_t>& present) {
  return ComputeCrlb(model, HybridParameters::Of(model, x0), grid, sigma, unknowns, options, measured, inputs,
                     present);
}

Crlb ComputeCrlb(const Model& model, const HybridParameters& at, const SampleGrid& grid, const Vec& sigma,
                 const Unknowns& unknowns, const SensitivityOptions& options,
                 const std::vector<int>& measured, const InputSignal* inputs,
                 const std::vector<std::uint8_t>& present) {
  const auto m = measured.empty() ? model.state_size() : static_cast<int>(measured.size());
  if (sigma.size() != m || !sigma.allFinite() || !(sigma.array() > 0.0).all()) {
    throw std::invalid_argument(fmt::format("sigma must have {} finite entries > 0", m));
  }
  for (std::size_t i = 0; i < measured.size(); ++i) {
    if (measured[i] < 0 || measured[i] >= model.state_size() || (i > 0 && measured[i] <= measured[i - 1])) {
      throw std::invalid_argument(fmt::format("measured: entry {} = {}: must increase within [0, {})", i + 1,
                                              measured[i], model.state_size()));
    }
  }
  HybridParameters p = at;
  if (p.gamma.size() == 0) p.gamma = model.gamma();
  const SensitivityTrajectory s = SimulateSensitivities(model, p, unknowns, grid, options, inputs);
  if (!s.ok()) {
    Crlb out;
    out.status = CrlbStatus::kSimulationFailed;
    out.message = fmt::format("the sensitivity simulation stopped: {}: {}",
                              ToString(s.trajectory.status.stop), s.trajectory.status.message);
    out.names = unknowns.Names(model);
    return out;
  }
  if (!present.empty() && static_cast<long>(present.size()) != s.trajectory.size()) {
    throw std::invalid_argument(
        fmt::format("present has {} entries for {} samples", present.size(), s.trajectory.size()));
  }
  Crlb out = CrlbFromFisher(FisherInformation(s, sigma, measured, present), unknowns, unknowns.Names(model));
  out.samples = present.empty() ? s.trajectory.size() : std::count(present.begin(), present.end(), 1);
  out.jumps = static_cast<int>(s.trajectory.jumps.size());
  return out;
}

}  // namespace hysid
