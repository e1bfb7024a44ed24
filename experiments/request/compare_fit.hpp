// hysid compare: each candidate model fitted on the same data as `hysid identify` fits it with its
// defaults (rls estimator, residual detector, the ML refinement with its routes), its Gaussian
// log-likelihood from the fitted model's own run over every sample, and its prediction of held-out
// samples; then the candidates ranked by AIC, BIC and the held-out error.
//
// The log-likelihood: with r_jk = y_jk − ŷ_jk the residual of measured output j at sample k, ŷ the
// reported estimate run from each chain's fitted initial state on its own events (FittedOutputs::x),
// and σ̂_j² = (1/N_j) Σ_k r_jk² (the ML noise variance of output j),
//   log L = −½ Σ_j N_j (log(2π σ̂_j²) + 1).
// k = the unknown α, β and guard parameters + the free components of each fitted chain's ξ0 + one σ
// per measured output. AIC = 2k − 2 log L, BIC = k log N − 2 log L with N = Σ_j N_j.
//
// Held out, by tail (HoldoutBy::kTail): the last `holdout` fraction of every chain's samples. The
// candidate is fitted again, the same way, on the rest, and its reported estimate run from each chain's
// fitted initial state through the held-out tail (a forecast: no held-out sample enters the fit or the
// initial state).
// Held out, by chain (HoldoutBy::kChain; the data need 2 chains or more): each chain c in turn. The
// candidate is fitted again on the other chains and the first `chain_head` fraction of chain c (its
// head: it sets chain c's fitted initial state and mode, and joins the fit of the shared parameters as
// the other chains do), and its estimate run from chain c's fitted initial state through the rest of
// chain c, which alone is scored: no scored sample enters the fit or the initial state. The squared
// errors of every left-out chain are summed into one score.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "core/io/sample_data.hpp"
#include "core/model/model.hpp"

namespace hysid {

// What is held out: each chain's tail, or each chain in turn.
enum class HoldoutBy { kTail, kChain };
std::string ToString(HoldoutBy by);  // "tail", "chain"
// "tail" or "chain"; throws std::invalid_argument naming `what` (the flag or keyword) otherwise.
HoldoutBy HoldoutByFromString(const std::string& text, const std::string& what);

struct ComparisonSettings {
  // By tail: the fraction of each chain's samples held out, in [0, 0.9]. 0: no hold-out (by either).
  double holdout = 0.25;
  HoldoutBy holdout_by = HoldoutBy::kTail;
  // By chain: the fraction of the left-out chain's first samples that set its initial state, in (0, 0.5].
  double chain_head = 0.1;
  // Fewer held-out (by chain: scored or head) samples in a chain than this: that chain holds none out.
  long min_holdout_samples = 5;
  // Field-naming message, e.g. "ComparisonSettings::holdout = 2: must be in [0, 0.9]".
  bool IsValid(std::string* error) const;
};

// One fit of one candidate: what the ranking reads.
struct ComparisonFit {
  std::string status;   // the refinement's (RefineStatus text)
  std::string reason;   // why it is not ok ("" when ok)
  std::string route;    // the refinement's route
  bool reported = false;      // the refined estimate stands (ok, or converged with its residual tests refusing it)
  bool covers_all = false;    // the fitted run covers every sample (its criteria are then computed)
  std::string coverage;       // why not ("" when it does)
  long samples = 0;           // data samples
  long samples_fitted = 0;    // samples inside the refinement's fitted spans
  int chains = 0, chains_fitted = 0;
  int parameters = 0;         // k
  long values = 0;            // N = Σ_j N_j
  double loglik = 0.0;        // NaN when not computed
  std::vector<std::string> outputs;  // measured state names, the rows of `residuals`
  Vec sigma;                         // σ̂_j of the residuals
  Mat residuals;                     // measured × K: y − ŷ (NaN where ŷ is not available)
  std::vector<std::string> names;    // the refinement's θ names (unknown α, β, γ and the first chain's ξ0)
  Vec estimates, standard_errors;
  // Per chain: its fitted initial state (empty: not fitted) and, for a model with modes, the name of
  // the mode it starts in ("" when none).
  std::vector<Vec> chain_x0;
  std::vector<std::string> chain_mode;
};

// The held-out forecast of one candidate.
struct HoldoutPrediction {
  bool done = false;     // a forecast of every held-out sample was made
  std::string status;    // the fit on the rest (RefineStatus text; by chain the last fit's), or why there is none
  std::string reason;
  std::string by;        // "tail" or "chain"
  int fits = 0;          // fits on the rest made (by tail 1, by chain one per chain left out)
  std::vector<int> chains_held;  // by chain: the chains left out, numbered from 1
  long samples = 0;      // held-out samples scored
  Vec rmse;              // per measured output
  double score = 0.0;    // RMS over outputs of rmse_j / sd_j (sd_j of output j over the held-out samples)
};

// The data of `paths` read for `model` (its measured states' columns), as `hysid identify` reads them
// with its defaults. Throws std::invalid_argument naming the file.
SampleData ReadComparisonData(const Model& model, const std::vector<std::string>& paths);

// The identification of `model` on `data` with identify's defaults and the criteria of its fit.
// Numerical outcomes are statuses; bad sizes throw std::invalid_argument.
ComparisonFit FitForComparison(const Model& model, const SampleData& data);

// Why data of one chain cannot be held out by chain: "the data (FILE) are 1 chain; ...".
std::string OneChainReason(const SampleData& data);

// The fit(s) on all but the held-out samples and the forecast of them (settings.holdout > 0), by tail or
// by chain as settings.holdout_by says. By chain, data of one chain throw std::invalid_argument.
HoldoutPrediction PredictHeldOut(const Model& model, const SampleData& data, const ComparisonSettings& settings);

// One candidate with its fit, forecast and ranking.
struct Candidate {
  std::string file, name;
  ComparisonFit fit;
  HoldoutPrediction holdout;
  bool ranked = false;     // reported and covering every sample
  double aic = 0.0, bic = 0.0, delta_aic = 0.0, delta_bic = 0.0, aic_weight = 0.0, bic_weight = 0.0;
  int aic_rank = 0, bic_rank = 0, holdout_rank = 0;  // 1 = best; 0: not ranked
};

// The criteria, their differences to the best and the Akaike (and BIC) weights
// w_i = exp(−Δ_i/2) / Σ_l exp(−Δ_l/2) over the ranked candidates; the held-out ranks over those
// with a forecast.
void RankCandidates(std::vector<Candidate>* candidates);

// The whole comparison (hysid compare, Python's hysid.compare): the files loaded (at least 2, none with
// candidate terms), the data read for each (the same columns and samples for all), each fitted and,
// with settings.holdout > 0, its held-out forecast made, then ranked. `read` (may be empty) is called
// with the data once read, `fitted` after each candidate. Throws std::invalid_argument naming the file
// or the setting for bad input (by chain: data of one chain).
std::vector<Candidate> CompareModels(const std::vector<std::string>& files, const std::vector<std::string>& data,
                                     const ComparisonSettings& settings,
                                     const std::function<void(const SampleData&)>& read = {},
                                     const std::function<void(const Candidate&)>& fitted = {});

// The steps of CompareModels, for data not read from files (Python's hysid.compare(y=...) makes its
// arrays into each candidate's data on its own thread): the files loaded (at least 2, none with
// candidate terms; an error names the file); each candidate's data made by `data_for` (the same
// columns and samples for all; an error it throws for a candidate after the first is prefixed with the
// candidate's file); the comparison of the loaded models on their data.
std::vector<Model> LoadCandidates(const std::vector<std::string>& files);
std::vector<SampleData> CandidateData(const std::vector<std::string>& files,
                                      const std::function<SampleData(const Model&)>& data_for,
                                      const std::vector<Model>& models);
std::vector<Candidate> CompareLoaded(const std::vector<std::string>& files, const std::vector<Model>& models,
                                     const std::vector<SampleData>& data, const ComparisonSettings& settings,
                                     const std::function<void(const SampleData&)>& read = {},
                                     const std::function<void(const Candidate&)>& fitted = {});

// The comparison as `hysid compare --json` writes it (docs/outputs.md); `data` names the data (the files).
nlohmann::json ComparisonJson(const std::vector<std::string>& data, const ComparisonSettings& settings,
                              const std::vector<Candidate>& candidates);

// The candidate ranked first by `place` (&Candidate::aic_rank, bic_rank, holdout_rank), or null.
const Candidate* Best(const std::vector<Candidate>& candidates, int Candidate::*place);

// What a difference in AIC or BIC says (Burnham & Anderson's scale): "≤ 2: substantial support", …
std::string DeltaMeaning(double delta);

}  // namespace hysid
