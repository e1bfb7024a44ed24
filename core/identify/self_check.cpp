#include "core/identify/self_check.hpp"

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include <fmt/format.h>

#include "core/model/automaton.hpp"
#include "core/model/noise_shape.hpp"
#include "core/model/regression.hpp"

namespace hysid {
namespace {

// The flow residuals of one identified row: e_k at the flow samples k, and the regressed left side there.
struct RowResiduals {
  std::vector<double> e, lhs;
  std::vector<Eigen::Index> sample;
};

bool ChainStarts(const IdentifyOptions& options, Eigen::Index k) {
  return !options.chain_start.empty() && options.chain_start[static_cast<std::size_t>(k)] != 0;
}

bool Flow(const IdentifyResult& r, Eigen::Index k) { return r.gamma[static_cast<std::size_t>(k)] == 0; }

// From rows built in one block (BuildFlowRows: one identified row, uniform, all samples finite).
RowResiduals FromBlock(const FlowRows& rows, const Vec& alpha_u, const IdentifyResult& r) {
  RowResiduals out;
  const auto u = static_cast<std::size_t>(alpha_u.size());
  for (Eigen::Index k = 1; k < rows.count; ++k) {
    if (!Flow(r, k)) continue;
    const double* phi = rows.phi.data() + static_cast<std::size_t>(k) * u;
    double fit = 0.0;
    for (std::size_t i = 0; i < u; ++i) fit += phi[i] * alpha_u[static_cast<Eigen::Index>(i)];
    out.e.push_back(rows.y[static_cast<std::size_t>(k)] - fit);
    out.lhs.push_back(rows.y[static_cast<std::size_t>(k)]);
    out.sample.push_back(k);
  }
  return out;
}

// Pair by pair, with chains, missing samples, times and inputs (one entry per identified row).
std::vector<RowResiduals> PairByPair(const Model& model, const Mat& y, double dt,
                                     const IdentifyOptions& options, const Vec& alpha_u,
                                     const IdentifyResult& r) {
  RegressionBuilder builder(model);
  const RegressionLayout& layout = builder.flow_layout();
  std::vector<RowResiduals> out(layout.rows.size());
  Mat phi(static_cast<Eigen::Index>(layout.rows.size()), alpha_u.size());
  Vec lhs(static_cast<Eigen::Index>(layout.rows.size()));
  Eigen::Index prev = -1;
  for (Eigen::Index k = 0; k < y.cols(); ++k) {
    if (ChainStarts(options, k)) prev = -1;
    if (!y.col(k).allFinite()) continue;
    if (prev >= 0 && Flow(r, k)) {
      const double step = options.times.empty() ? static_cast<double>(k - prev) * dt
                                                : options.times[static_cast<std::size_t>(k)] -
                                                      options.times[static_cast<std::size_t>(prev)];
      if (model.input_size() > 0) {
        const Context before{.t = options.times.empty() ? static_cast<double>(prev) * dt
                                                        : options.times[static_cast<std::size_t>(prev)],
                             .u = options.inputs.col(prev).data()};
        const Context after{.t = before.t + step, .u = options.inputs.col(k).data()};
        builder.Flow(y.col(prev), y.col(k), step, phi, lhs, before, after);
      } else {
        builder.Flow(y.col(prev), y.col(k), step, phi, lhs);
      }
      const Vec e = lhs - phi * alpha_u;
      for (std::size_t i = 0; i < out.size(); ++i) {
        out[i].e.push_back(e[static_cast<Eigen::Index>(i)]);
        out[i].lhs.push_back(lhs[static_cast<Eigen::Index>(i)]);
        out[i].sample.push_back(k);
      }
    }
    prev = k;
  }
  return out;
}

// σ̂ of state component `row` from the second differences of consecutive finite samples in one chain.
double NoiseSigma(const Mat& y, const IdentifyOptions& options, int row) {
  std::vector<double> d;
  for (Eigen::Index k = 2; k < y.cols(); ++k) {
    if (ChainStarts(options, k) || ChainStarts(options, k - 1)) continue;
    const double a = y(row, k - 2), b = y(row, k - 1), c = y(row, k);
    if (std::isfinite(a) && std::isfinite(b) && std::isfinite(c)) d.push_back(c - 2.0 * b + a);
  }
  if (d.size() < 2) return -1.0;
  return NoiseSigmaFromSecondDifferences(d);
}

double Rms(const std::vector<double>& v) {
  double sum = 0.0;
  for (const double x : v) sum += x * x;
  return std::sqrt(sum / static_cast<double>(v.size()));
}

// The verdict on one row's residuals with noise sd s (""  when consistent).
std::string RowVerdict(const Model& model, const RowResiduals& res, double s, bool no_jumps, int row,
                       const IdentifyOptions& options, double dt) {
  const std::string& name = model.spec().state_names[static_cast<std::size_t>(row)];
  const double rms = Rms(res.e);
  if (rms > kResidualRatio * s) {
    return fmt::format(
        "the flow residuals of {} are {:.3g} times the noise (RMS {:.3g} against sqrt(2)*sigma = {:.3g}, "
        "above "
        "{:g}): the estimate does not explain the samples taken for flow (jumps missed by the detector? a "
        "wrong "
        "estimate or model?)",
        name, rms / s, rms, s, kResidualRatio);
  }
  if (!no_jumps) return "";
  const double bound = (std::sqrt(2.0 * std::log(static_cast<double>(res.e.size()))) + kOutlierMargin) * s;
  std::size_t worst = 0;
  long beyond = 0;
  for (std::size_t i = 0; i < res.e.size(); ++i) {
    if (std::abs(res.e[i]) > bound) ++beyond;
    if (std::abs(res.e[i]) > std::abs(res.e[worst])) worst = i;
  }
  if (beyond == 0) return "";
  const Eigen::Index k = res.sample[worst];
  const double t =
      options.times.empty() ? static_cast<double>(k) * dt : options.times[static_cast<std::size_t>(k)];
  return fmt::format(
      "the detector found no jump, yet {} flow residuals of {} exceed {:.3g} noise sd (the largest, {:.3g} "
      "sd, "
      "at t = {:.6g}): the data jump where nothing was detected (try another detector or its options)",
      beyond, name, bound / s, std::abs(res.e[worst]) / s, t);
}

bool Applies(const Model& model, const IdentifyOptions& options, const IdentifyResult& r) {
  return options.labels.empty() && options.modes.empty() && !IsAutomaton(model.spec()) && !r.stopped &&
         !RegressionLayout::Flow(model).unknown.empty();
}

}  // namespace

std::string CheckFlowResiduals(const Model& model, const Mat& y, double dt,
                               const IdentifierSettings& settings, const IdentifyOptions& options,
                               const IdentifyResult& r) {
  if (!Applies(model, options, r)) return "";
  const RegressionLayout layout = RegressionLayout::Flow(model);
  const Vec alpha_u = layout.Unknown(r.alpha_hat);
  const bool block = layout.rows.size() == 1 && model.input_size() == 0 && options.times.empty() &&
                     options.chain_start.empty() && y.allFinite();
  std::vector<RowResiduals> rows;
  if (block) {
    const bool given = options.flow_rows != nullptr && !options.flow_rows->empty();
    rows.push_back(FromBlock(given ? *options.flow_rows : BuildFlowRows(model, y, dt), alpha_u, r));
  } else {
    rows = PairByPair(model, y, dt, options, alpha_u, r);
  }
  for (std::size_t i = 0; i < rows.size(); ++i) {
    if (static_cast<long>(rows[i].e.size()) < kMinSamples) continue;
    const int row = layout.rows[i];
    // σ given (> 0), else the data's own: a σ of 0 says noise-free, which rounding and integrator
    // error are not, and the second differences measure what is there.
    const bool given = settings.sigma.size() == y.rows() && settings.sigma[row] > 0.0;
    const double sigma = given ? settings.sigma[row] : NoiseSigma(y, options, row);
    if (!(sigma >= 0.0)) continue;
    const double s = std::max(std::sqrt(2.0) * sigma, kResidualFloor * Rms(rows[i].lhs));
    if (!(s > 0.0) || !std::isfinite(s)) continue;
    std::string why = RowVerdict(model, rows[i], s, r.jumps_detected == 0, row, options, dt);
    if (!why.empty()) return why;
  }
  return "";
}

}  // namespace hysid
