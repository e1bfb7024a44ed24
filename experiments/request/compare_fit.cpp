#include "experiments/request/compare_fit.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <numeric>
#include <stdexcept>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include "core/identify/identifier.hpp"
#include "experiments/request/request.hpp"
#include "sim/events/fitted_outputs.hpp"
#include "sim/model_check/model_check.hpp"

namespace hysid {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// One run of identify's pipeline with its defaults: the data as the refinement saw them (outliers left
// out, the hidden states reconstructed: n × K), their measured rows, the recursive result and the
// refinement.
struct FitRun {
  SampleData data;
  Mat measured_y;
  IdentifyResult recursive;
  RefineStep step;
};

FitRun RunPipeline(const Model& model, SampleData data) {
  FitRun f;
  IdentifyRequest request(model);  // identify's defaults: rls, residual, refine ml, nothing known
  request.data = std::move(data);
  IdentifyOutcome outcome = RunIdentification(std::move(request));
  f.recursive = std::move(outcome.recursive);
  f.step = std::move(outcome.refinement);
  f.data = std::move(outcome.data);
  const std::vector<int> measured = MeasuredIndices(model);
  f.measured_y = f.data.y.rows() == static_cast<Eigen::Index>(measured.size()) ? f.data.y
                                                                                : Mat(f.data.y(measured, Eigen::all));
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

nlohmann::json VectorJson(const Vec& v) {
  std::vector<nlohmann::json> out;
  for (Eigen::Index i = 0; i < v.size(); ++i) out.push_back(std::isfinite(v[i]) ? nlohmann::json(v[i]) : nlohmann::json());
  return out;
}

nlohmann::json Finite(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }

nlohmann::json ChainStates(const std::vector<Vec>& states) {
  nlohmann::json out = nlohmann::json::array();
  for (const Vec& v : states) out.push_back(v.size() ? VectorJson(v) : nlohmann::json());
  return out;
}

nlohmann::json CandidateJson(const Candidate& c) {
  nlohmann::json estimates = nlohmann::json::object(), se = nlohmann::json::object();
  for (std::size_t i = 0; i < c.fit.names.size(); ++i) {
    const auto ii = static_cast<Eigen::Index>(i);
    if (ii < c.fit.estimates.size()) estimates[c.fit.names[i]] = Finite(c.fit.estimates[ii]);
    if (ii < c.fit.standard_errors.size()) se[c.fit.names[i]] = Finite(c.fit.standard_errors[ii]);
  }
  const bool r = c.ranked;
  return {{"file", c.file}, {"name", c.name}, {"status", c.fit.status}, {"reason", c.fit.reason},
          {"route", c.fit.route}, {"reported", c.fit.reported}, {"ranked", r}, {"coverage", c.fit.coverage},
          {"samples", c.fit.samples}, {"samples_fitted", c.fit.samples_fitted}, {"chains", c.fit.chains},
          {"chains_fitted", c.fit.chains_fitted}, {"k", c.fit.parameters}, {"values", c.fit.values},
          {"loglik", Finite(c.fit.loglik)}, {"sigma", VectorJson(c.fit.sigma)},
          {"aic", r ? Finite(c.aic) : nlohmann::json()}, {"delta_aic", r ? Finite(c.delta_aic) : nlohmann::json()},
          {"aic_weight", r ? Finite(c.aic_weight) : nlohmann::json()}, {"aic_rank", c.aic_rank},
          {"bic", r ? Finite(c.bic) : nlohmann::json()}, {"delta_bic", r ? Finite(c.delta_bic) : nlohmann::json()},
          {"bic_weight", r ? Finite(c.bic_weight) : nlohmann::json()}, {"bic_rank", c.bic_rank},
          {"estimates", estimates}, {"standard_errors", se}, {"chain_x0", ChainStates(c.fit.chain_x0)},
          {"chain_mode", c.fit.chain_mode},
          {"holdout",
           {{"done", c.holdout.done}, {"status", c.holdout.status}, {"reason", c.holdout.reason},
            {"by", c.holdout.by}, {"fits", c.holdout.fits}, {"chains_held", c.holdout.chains_held},
            {"samples", c.holdout.samples}, {"rmse", VectorJson(c.holdout.rmse)},
            {"score", c.holdout.done ? Finite(c.holdout.score) : nlohmann::json()}, {"rank", c.holdout_rank}}}};
}

}  // namespace

const Candidate* Best(const std::vector<Candidate>& candidates, int Candidate::*place) {
  for (const Candidate& c : candidates)
    if (c.*place == 1) return &c;
  return nullptr;
}


std::vector<Model> LoadCandidates(const std::vector<std::string>& files) {
  if (files.size() < 2) {
    throw std::invalid_argument(fmt::format("compare: {} model file(s) given: give at least 2 candidate model files", files.size()));
  }
  std::vector<Model> models;
  for (const std::string& file : files) {
    try {
      models.push_back(LoadModelFile(file));
    } catch (const std::invalid_argument& e) {
      const std::string what = e.what();  // the reader's messages begin with the file's name
      throw std::invalid_argument(what.rfind(file, 0) == 0 ? what : fmt::format("model file {}: {}", file, what));
    }
    if (!models.back().spec().candidates.empty() || !models.back().spec().jump_candidates.empty()) {
      throw std::invalid_argument(fmt::format("model file {}: has candidate terms; compare fits models as written (write the "
                          "model `hysid identify` chooses with --chosen-model, and compare that)",
                          file));
    }
  }
  return models;
}

std::vector<SampleData> CandidateData(const std::vector<std::string>& files, const std::function<SampleData(const Model&)>& data_for,
                                      const std::vector<Model>& models) {
  std::vector<SampleData> data;
  for (std::size_t i = 0; i < models.size(); ++i) {
    try {
      data.push_back(data_for(models[i]));
    } catch (const std::invalid_argument& e) {
      const std::string what = e.what();
      if (i == 0 || what.find(files[i]) != std::string::npos) throw;
      throw std::invalid_argument(fmt::format("model file {}: {}", files[i], what));
    }
    const SampleData& d = data.back();
    if (d.state_columns != data.front().state_columns || d.t.size() != data.front().t.size()) {
      throw std::invalid_argument(fmt::format("model file {}: reads the columns ({}) of the data, {} samples, but {} reads ({}), {} "
                          "samples: the candidates must measure the same outputs",
                          files[i], fmt::join(d.state_columns, ","), d.t.size(), files.front(),
                          fmt::join(data.front().state_columns, ","), data.front().t.size()));
    }
  }
  return data;
}

bool ComparisonSettings::IsValid(std::string* error) const {
  if (!(holdout >= 0.0 && holdout <= 0.9)) {
    if (error != nullptr) *error = fmt::format("ComparisonSettings::holdout = {}: must be in [0, 0.9]", holdout);
    return false;
  }
  if (!(chain_head > 0.0 && chain_head <= 0.5)) {
    if (error != nullptr) *error = fmt::format("ComparisonSettings::chain_head = {}: must be in (0, 0.5]", chain_head);
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

namespace {

// One fit on the rest: the samples it is fitted on, the samples its forecast is scored on, and (by
// chain) the chain left out, 0-based.
struct HoldoutFold {
  std::vector<long> keep, scored;
  int chain = -1;
};

// By tail: one fold, the last `holdout` fraction of every chain scored (none when none is long enough).
std::vector<HoldoutFold> TailFolds(const SampleData& data, const ComparisonSettings& settings) {
  HoldoutFold f;
  for (const auto& [a, b] : Chains(data)) {
    const auto tail = static_cast<long>(std::floor(settings.holdout * static_cast<double>(b - a)));
    const long end = tail >= settings.min_holdout_samples ? b - tail : b;
    for (long k = a; k < b; ++k) (k < end ? f.keep : f.scored).push_back(k);
  }
  if (f.scored.empty()) return {};
  return {f};
}

// By chain: one fold per chain long enough (a head and a scored rest of min_holdout_samples each):
// fitted on the other chains and the chain's head, scored on the rest of the chain.
std::vector<HoldoutFold> ChainFolds(const SampleData& data, const ComparisonSettings& settings) {
  const std::vector<std::pair<long, long>> chains = Chains(data);
  const auto K = static_cast<long>(data.t.size());
  std::vector<HoldoutFold> folds;
  for (std::size_t c = 0; c < chains.size(); ++c) {
    const auto [a, b] = chains[c];
    const long head = std::max(static_cast<long>(std::ceil(settings.chain_head * static_cast<double>(b - a))),
                               settings.min_holdout_samples);
    if (b - a - head < settings.min_holdout_samples) continue;
    HoldoutFold f;
    f.chain = static_cast<int>(c);
    for (long k = 0; k < K; ++k) (k >= a + head && k < b ? f.scored : f.keep).push_back(k);
    folds.push_back(std::move(f));
  }
  return folds;
}

std::string FoldName(const SampleData& data, const HoldoutFold& fold) {
  if (fold.chain < 0) return "";
  const long first = Chains(data)[std::size_t(fold.chain)].first;
  const int run = std::size_t(first) < data.run.size() ? data.run[std::size_t(first)] : 0;
  const std::string name = std::size_t(run) < data.run_names.size() ? data.run_names[std::size_t(run)] : "";
  return fmt::format("chain {}{}{}: ", fold.chain + 1, name.empty() ? "" : " of ", name);
}

// The fit on `fold.keep` and its forecast of `fold.scored`, written into `predicted` (measured × K);
// false, with h->reason, when the fit reports no estimate or its run misses a scored sample.
bool Forecast(const Model& model, const SampleData& data, const HoldoutFold& fold, Mat* predicted,
              HoldoutPrediction* h) {
  const FitRun f = RunPipeline(model, Subset(data, fold.keep));
  const RefineResult& r = f.step.result;
  ++h->fits;
  h->status = ToString(r.status);
  h->reason = r.reason;
  if (!r.reported) {
    h->reason = fmt::format("{}the fit on the rest reported no estimate ({}{}{})", FoldName(data, fold), h->status,
                            r.reason.empty() ? "" : ": ", r.reason);
    return false;
  }
  const std::vector<int> measured = MeasuredIndices(model);
  Mat y = Mat::Zero(model.state_size(), data.y.cols());  // the hidden rows only start the recursive run, not read
  for (std::size_t j = 0; j < measured.size(); ++j) y.row(measured[j]) = data.y.row(Eigen::Index(j));
  // The kept samples hold every chain (by chain, chain c by its head), in order: r's chains are data's.
  const FittedOutputs out = RunFittedModel(model, data.t, y, data.chain_start, data.u, IdentifyResult{}, r);
  for (const long k : fold.scored) {
    for (std::size_t j = 0; j < measured.size(); ++j) {
      const double x = out.x(measured[j], k);
      if (!std::isfinite(x)) {
        h->reason = fmt::format("{}the forecast does not reach every held-out sample{}{}", FoldName(data, fold),
                                out.reason.empty() ? "" : ": ", out.reason);
        return false;
      }
      (*predicted)(Eigen::Index(j), k) = x;
    }
  }
  return true;
}

// rmse_j over the scored samples and the score, RMS over outputs of rmse_j / sd_j.
void Score(const SampleData& data, const Mat& predicted, const std::vector<long>& scored, HoldoutPrediction* h) {
  const auto m = data.y.rows();
  const auto count = static_cast<double>(scored.size());
  h->rmse = Vec::Zero(m);
  double score = 0.0;
  for (Eigen::Index j = 0; j < m; ++j) {
    double sum = 0.0, mean = 0.0, spread = 0.0;
    for (const long k : scored) mean += data.y(j, k) / count;
    for (const long k : scored) {
      const double e = data.y(j, k) - predicted(j, k);
      sum += e * e;
      spread += (data.y(j, k) - mean) * (data.y(j, k) - mean);
    }
    h->rmse[j] = std::sqrt(sum / count);
    score += spread > 0.0 ? sum / spread : 0.0;  // (rmse_j / sd_j)²
  }
  h->score = std::sqrt(score / static_cast<double>(m));
  h->done = true;
}

}  // namespace

std::string ToString(HoldoutBy by) { return by == HoldoutBy::kChain ? "chain" : "tail"; }

HoldoutBy HoldoutByFromString(const std::string& text, const std::string& what) {
  if (text == "tail") return HoldoutBy::kTail;
  if (text == "chain") return HoldoutBy::kChain;
  throw std::invalid_argument(fmt::format("{} = '{}': must be tail or chain", what, text));
}

std::string OneChainReason(const SampleData& data) {
  return fmt::format("the data ({}) are {} chain; leaving each chain out in turn needs 2 or more (several data "
                     "files, a run column, or runs cut at gaps longer than {:g} s); hold out each chain's tail instead",
                     data.path, data.chains(), data.max_gap);
}

HoldoutPrediction PredictHeldOut(const Model& model, const SampleData& data, const ComparisonSettings& settings) {
  if (std::string e; !settings.IsValid(&e)) throw std::invalid_argument(e);
  const bool by_chain = settings.holdout_by == HoldoutBy::kChain;
  if (by_chain && data.chains() < 2) throw std::invalid_argument("hold-out by chain: " + OneChainReason(data));
  HoldoutPrediction h;
  h.by = ToString(settings.holdout_by);
  const std::vector<HoldoutFold> folds = by_chain ? ChainFolds(data, settings) : TailFolds(data, settings);
  if (folds.empty()) {
    h.status = "none";
    h.reason = by_chain ? fmt::format("no chain has {} samples or more after a head of {:g} of it",
                                      settings.min_holdout_samples, settings.chain_head)
                        : fmt::format("no chain has {} samples or more to hold out", settings.min_holdout_samples);
    return h;
  }
  for (const HoldoutFold& fold : folds) h.samples += static_cast<long>(fold.scored.size());
  Mat predicted = Mat::Constant(data.y.rows(), data.y.cols(), kNaN);
  std::vector<long> scored;
  for (const HoldoutFold& fold : folds) {
    if (fold.chain >= 0) h.chains_held.push_back(fold.chain + 1);
    if (!Forecast(model, data, fold, &predicted, &h)) return h;
    scored.insert(scored.end(), fold.scored.begin(), fold.scored.end());
  }
  Score(data, predicted, scored, &h);
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

nlohmann::json ComparisonJson(const std::vector<std::string>& data, const ComparisonSettings& settings,
                              const std::vector<Candidate>& candidates) {
  const std::vector<std::string> outputs = candidates.empty() ? std::vector<std::string>{} : candidates.front().fit.outputs;
  nlohmann::json models = nlohmann::json::array();
  for (const Candidate& c : candidates) models.push_back(CandidateJson(c));
  auto best = [&](int Candidate::*place) {
    const Candidate* c = Best(candidates, place);
    return c ? nlohmann::json(c->file) : nlohmann::json();
  };
  const bool by_chain = settings.holdout_by == HoldoutBy::kChain;
  return {{"command", "compare"}, {"data", data}, {"outputs", outputs}, {"holdout_by", ToString(settings.holdout_by)},
          {"holdout_fraction", settings.holdout}, {"chain_head", by_chain ? nlohmann::json(settings.chain_head) : nlohmann::json()},
          {"models", models}, {"best", {{"aic", best(&Candidate::aic_rank)}, {"bic", best(&Candidate::bic_rank)},
                                        {"holdout", best(&Candidate::holdout_rank)}}}};
}

std::vector<Candidate> CompareModels(const std::vector<std::string>& files, const std::vector<std::string>& data,
                                     const ComparisonSettings& settings,
                                     const std::function<void(const SampleData&)>& read,
                                     const std::function<void(const Candidate&)>& fitted) {
  if (std::string error; !settings.IsValid(&error)) throw std::invalid_argument(error);
  if (data.empty()) throw std::invalid_argument("compare: no data file given");
  const std::vector<Model> models = LoadCandidates(files);
  const std::vector<SampleData> samples =
      CandidateData(files, [&](const Model& model) { return ReadComparisonData(model, data); }, models);
  return CompareLoaded(files, models, samples, settings, read, fitted);
}

std::vector<Candidate> CompareLoaded(const std::vector<std::string>& files, const std::vector<Model>& models,
                                     const std::vector<SampleData>& samples, const ComparisonSettings& settings,
                                     const std::function<void(const SampleData&)>& read,
                                     const std::function<void(const Candidate&)>& fitted) {
  if (std::string error; !settings.IsValid(&error)) throw std::invalid_argument(error);
  if (models.size() != files.size() || samples.size() != models.size() || models.empty()) {
    throw std::invalid_argument(fmt::format("CompareLoaded: {} files, {} models, {} data sets: give one model and one "
                                            "data set per file", files.size(), models.size(), samples.size()));
  }
  if (read) read(samples.front());
  if (settings.holdout > 0.0 && settings.holdout_by == HoldoutBy::kChain && samples.front().chains() < 2)
    throw std::invalid_argument("hold-out by chain: " + OneChainReason(samples.front()));
  std::vector<Candidate> candidates;
  for (std::size_t i = 0; i < models.size(); ++i) {
    Candidate c;
    c.file = files[i];
    c.name = models[i].name();
    c.fit = FitForComparison(models[i], samples[i]);
    if (settings.holdout > 0.0) {
      c.holdout = PredictHeldOut(models[i], samples[i], settings);
    } else {
      c.holdout.status = "none";
      c.holdout.by = ToString(settings.holdout_by);
      c.holdout.reason = "no hold-out asked for";
    }
    if (fitted) fitted(c);
    candidates.push_back(std::move(c));
  }
  RankCandidates(&candidates);
  return candidates;
}

}  // namespace hysid
