#include "experiments/cli/compare_fit.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>
#include <stdexcept>

#include <fmt/format.h>

#include "core/identify/identifier.hpp"
#include "experiments/cli/cli.hpp"
#include "sim/events/fitted_outputs.hpp"

namespace hysid::cli {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// One run of identify's pipeline with its defaults: the data as the refinement saw them (the hidden
// states reconstructed: n × K), the measured rows as read, the recursive result and the refinement.
struct FitRun {
  SampleData data;
  Mat measured_y;
  IdentifyResult recursive;
  RefineStep step;
};

FitRun RunPipeline(const Model& model, SampleData data) {
  FitRun f;
  IdentifierSettings settings;
  SetPluginKinds("rls", "residual", &settings);
  const std::vector<int> measured = MeasuredIndices(model);
  f.measured_y = data.y;
  IdentifyOptions options;
  std::vector<double> kinks;
  const PartialOutputs partial = Reconstruct(model, "", measured, Vec(), data, options, &kinks);
  if (!data.uniform) {
    options.times = data.t;
    options.chain_start = data.chain_start;
  }
  options.inputs = data.u;
  f.recursive = Identify(model, data.y, data.dt, settings, options);
  const RefineArgs args;  // --refine ml, nothing known
  f.step = RunRefineStep(model, data, f.recursive, Vec(), args, partial, Truth{});
  f.data = std::move(data);
  return f;
}

int FittedChains(const RefineResult& r) {
  return static_cast<int>(std::count_if(r.chain_x0.begin(), r.chain_x0.end(), [](const Vec& v) { return v.size() > 0; }));
}

// The samples of `data` at `keep` (increasing indices), every per-sample array cut alike.
SampleData Subset(const SampleData& data, const std::vector<long>& keep) {
  SampleData s = data;
  const auto K = static_cast<Eigen::Index>(keep.size());
  s.y.resize(data.y.rows(), K);
  s.u.resize(data.u.rows(), data.u.rows() > 0 ? K : 0);
  s.t.clear();
  s.chain_start.clear();
  s.run.clear();
  s.line.clear();
  for (Eigen::Index i = 0; i < K; ++i) {
    const auto k = static_cast<std::size_t>(keep[std::size_t(i)]);
    s.y.col(i) = data.y.col(Eigen::Index(k));
    if (data.u.rows() > 0) s.u.col(i) = data.u.col(Eigen::Index(k));
    s.t.push_back(data.t[k]);
    s.chain_start.push_back(data.chain_start.empty() ? std::uint8_t(i == 0) : data.chain_start[k]);
    if (k < data.run.size()) s.run.push_back(data.run[k]);
    if (k < data.line.size()) s.line.push_back(data.line[k]);
  }
  s.j.reset();
  s.map.reset();
  s.q.reset();
  return s;
}

// [first, end) of every chain.
std::vector<std::pair<long, long>> Chains(const SampleData& data) {
  const auto K = static_cast<long>(data.t.size());
  std::vector<std::pair<long, long>> out;
  for (long k = 0; k < K; ++k) {
    if (k > 0 && (data.chain_start.empty() || data.chain_start[std::size_t(k)] == 0)) continue;
    if (!out.empty()) out.back().second = k;
    out.emplace_back(k, K);
  }
  return out;
}

}  // namespace

bool ComparisonSettings::IsValid(std::string* error) const {
  if (!(holdout >= 0.0 && holdout <= 0.9)) {
    if (error != nullptr) *error = fmt::format("ComparisonSettings::holdout = {}: must be in [0, 0.9]", holdout);
    return false;
  }
  if (min_holdout_samples < 1) {
    if (error != nullptr)
      *error = fmt::format("ComparisonSettings::min_holdout_samples = {}: must be >= 1", min_holdout_samples);
    return false;
  }
  return true;
}

SampleData ReadComparisonData(const Model& model, const std::vector<std::string>& paths) {
  const std::vector<int> measured = MeasuredIndices(model);
  std::vector<std::string> names;
  for (const int i : measured) names.push_back(model.spec().state_names[std::size_t(i)]);
  return ReadSampleData(paths, static_cast<int>(measured.size()),
                        {.inputs = model.spec().inputs, .state_names = names});
}

ComparisonFit FitForComparison(const Model& model, const SampleData& data) {
  const FitRun f = RunPipeline(model, data);
  const RefineResult& r = f.step.result;
  const std::vector<int> measured = MeasuredIndices(model);
  const int n = model.state_size(), m = static_cast<int>(measured.size());
  const Eigen::Index K = f.measured_y.cols();
  ComparisonFit c;
  c.status = ToString(r.status);
  c.reason = r.reason;
  c.route = r.route;
  c.reported = r.reported;
  c.samples = K;
  c.samples_fitted = r.samples_used;
  c.chains = static_cast<int>(f.data.chains());
  c.chains_fitted = FittedChains(r);
  c.parameters = static_cast<int>(r.names.size()) - n + n * c.chains_fitted + m;
  for (const int i : measured) c.outputs.push_back(model.spec().state_names[std::size_t(i)]);
  c.names = r.names;
  c.estimates = r.estimate.Theta(r.unknowns);
  c.standard_errors = r.standard_errors;
  c.chain_x0 = r.chain_x0;
  const auto& modes = model.spec().modes;
  for (std::size_t i = 0; i < r.chain_x0.size(); ++i) {
    const int q = i < r.chain_mode.size() ? r.chain_mode[i] : r.initial_mode;
    c.chain_mode.push_back(q >= 0 && std::size_t(q) < modes.size() ? modes[std::size_t(q)] : std::string());
  }
  c.residuals = Mat::Constant(m, K, kNaN);
  const Mat& x = f.step.outputs.x;
  if (x.cols() == K) {
    for (int j = 0; j < m; ++j) c.residuals.row(j) = f.measured_y.row(j) - x.row(measured[std::size_t(j)]);
  }
  c.loglik = kNaN;
  c.sigma = Vec::Constant(m, kNaN);
  const long covered = static_cast<long>((c.residuals.array().isFinite()).colwise().all().count());
  if (!r.reported) {
    c.coverage = fmt::format("no fit reported ({})", c.status);
    return c;
  }
  if (covered < K) {
    c.coverage = fmt::format("the fitted model's run covers {} of {} samples{}{}", covered, K,
                             f.step.outputs.reason.empty() ? "" : ": ", f.step.outputs.reason);
    return c;
  }
  c.covers_all = true;
  c.values = static_cast<long>(m) * K;
  c.loglik = 0.0;
  for (int j = 0; j < m; ++j) {
    const double var = c.residuals.row(j).squaredNorm() / static_cast<double>(K);
    c.sigma[j] = std::sqrt(var);
    c.loglik -= 0.5 * static_cast<double>(K) * (std::log(2.0 * std::numbers::pi * var) + 1.0);
  }
  return c;
}

HoldoutPrediction PredictHeldOut(const Model& model, const SampleData& data, const ComparisonSettings& settings) {
  if (std::string e; !settings.IsValid(&e)) throw std::invalid_argument(e);
  HoldoutPrediction h;
  std::vector<long> keep, held;
  for (const auto& [a, b] : Chains(data)) {
    const auto tail = static_cast<long>(std::floor(settings.holdout * static_cast<double>(b - a)));
    const long end = tail >= settings.min_holdout_samples ? b - tail : b;
    for (long k = a; k < b; ++k) (k < end ? keep : held).push_back(k);
  }
  h.samples = static_cast<long>(held.size());
  if (held.empty()) {
    h.status = "none";
    h.reason = fmt::format("no chain has {} samples or more to hold out", settings.min_holdout_samples);
    return h;
  }
  const FitRun f = RunPipeline(model, Subset(data, keep));
  const RefineResult& r = f.step.result;
  h.status = ToString(r.status);
  h.reason = r.reason;
  if (!r.reported) {
    h.reason = fmt::format("the fit on the rest reported no estimate ({}{}{})", h.status, r.reason.empty() ? "" : ": ",
                           r.reason);
    return h;
  }
  const std::vector<int> measured = MeasuredIndices(model);
  const int n = model.state_size(), m = static_cast<int>(measured.size());
  Mat y = Mat::Zero(n, data.y.cols());  // the hidden rows only start the recursive run, which is not read
  for (int j = 0; j < m; ++j) y.row(measured[std::size_t(j)]) = data.y.row(j);
  const FittedOutputs out = RunFittedModel(model, data.t, y, data.chain_start, data.u, IdentifyResult{}, r);
  h.rmse = Vec::Zero(m);
  double score = 0.0;
  for (int j = 0; j < m; ++j) {
    double sum = 0.0, mean = 0.0, spread = 0.0;
    for (const long k : held) mean += data.y(j, k) / static_cast<double>(held.size());
    for (const long k : held) {
      const double e = data.y(j, k) - out.x(measured[std::size_t(j)], k);
      if (!std::isfinite(e)) {
        h.reason = fmt::format("the forecast does not reach every held-out sample{}{}", out.reason.empty() ? "" : ": ",
                               out.reason);
        return h;
      }
      sum += e * e;
      spread += (data.y(j, k) - mean) * (data.y(j, k) - mean);
    }
    h.rmse[j] = std::sqrt(sum / static_cast<double>(held.size()));
    score += spread > 0.0 ? sum / spread : 0.0;  // (rmse_j / sd_j)²
  }
  h.score = std::sqrt(score / static_cast<double>(m));
  h.done = true;
  return h;
}

void RankCandidates(std::vector<Candidate>* candidates) {
  std::vector<std::size_t> ranked, forecast;
  for (std::size_t i = 0; i < candidates->size(); ++i) {
    Candidate& c = (*candidates)[i];
    c.ranked = c.fit.reported && c.fit.covers_all;
    c.aic_rank = c.bic_rank = c.holdout_rank = 0;
    if (c.holdout.done) forecast.push_back(i);
    if (!c.ranked) continue;
    const double k = c.fit.parameters;
    c.aic = 2.0 * k - 2.0 * c.fit.loglik;
    c.bic = k * std::log(static_cast<double>(c.fit.values)) - 2.0 * c.fit.loglik;
    ranked.push_back(i);
  }
  auto rank = [&](std::vector<std::size_t> order, double Candidate::*value, double Candidate::*delta,
                  double Candidate::*weight, int Candidate::*place) {
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t a, std::size_t b) { return (*candidates)[a].*value < (*candidates)[b].*value; });
    if (order.empty()) return;
    const double best = (*candidates)[order.front()].*value;
    double total = 0.0;
    for (std::size_t p = 0; p < order.size(); ++p) {
      Candidate& c = (*candidates)[order[p]];
      c.*delta = c.*value - best;
      total += std::exp(-0.5 * (c.*delta));
      c.*place = static_cast<int>(p) + 1;
    }
    for (const std::size_t i : order) (*candidates)[i].*weight = std::exp(-0.5 * ((*candidates)[i].*delta)) / total;
  };
  rank(ranked, &Candidate::aic, &Candidate::delta_aic, &Candidate::aic_weight, &Candidate::aic_rank);
  rank(ranked, &Candidate::bic, &Candidate::delta_bic, &Candidate::bic_weight, &Candidate::bic_rank);
  std::stable_sort(forecast.begin(), forecast.end(), [&](std::size_t a, std::size_t b) {
    return (*candidates)[a].holdout.score < (*candidates)[b].holdout.score;
  });
  for (std::size_t p = 0; p < forecast.size(); ++p) (*candidates)[forecast[p]].holdout_rank = static_cast<int>(p) + 1;
}

std::string DeltaMeaning(double delta) {
  if (delta <= 2.0) return "substantial support";
  if (delta <= 4.0) return "less support";
  if (delta <= 7.0) return "considerably less support";
  if (delta <= 10.0) return "little support";
  return "essentially no support";
}

}  // namespace hysid::cli
