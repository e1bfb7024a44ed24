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
// Held out: the last `holdout` fraction of every chain's samples. The candidate is fitted again, the
// same way, on the rest, and its reported estimate run from each chain's fitted initial state through
// the held-out tail (a forecast: no held-out sample enters the fit or the initial state).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "core/io/sample_data.hpp"
#include "core/model/model.hpp"

namespace hysid {

struct ComparisonSettings {
  double holdout = 0.25;  // fraction of each chain's samples held out (0: none), in [0, 0.9]
  // Fewer held-out samples in a chain than this: that chain holds none out.
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
  std::string status;    // the fit on the rest (RefineStatus text), or why there is no forecast
  std::string reason;
  long samples = 0;      // held-out samples
  Vec rmse;              // per measured output
  double score = 0.0;    // RMS over outputs of rmse_j / sd_j (sd_j of output j over the held-out samples)
};

// The data of `paths` read for `model` (its measured states' columns), as `hysid identify` reads them
// with its defaults. Throws std::invalid_argument naming the file.
SampleData ReadComparisonData(const Model& model, const std::vector<std::string>& paths);

// The identification of `model` on `data` with identify's defaults and the criteria of its fit.
// Numerical outcomes are statuses; bad sizes throw std::invalid_argument.
ComparisonFit FitForComparison(const Model& model, const SampleData& data);

// The fit on all but the held-out tails and its forecast of them (settings.holdout > 0).
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
// or the setting for bad input.
std::vector<Candidate> CompareModels(const std::vector<std::string>& files, const std::vector<std::string>& data,
                                     const ComparisonSettings& settings,
                                     const std::function<void(const SampleData&)>& read = {},
                                     const std::function<void(const Candidate&)>& fitted = {});

// The comparison as `hysid compare --json` writes it (docs/outputs.md).
nlohmann::json ComparisonJson(const std::vector<std::string>& data, double holdout,
                              const std::vector<Candidate>& candidates);

// The candidate ranked first by `place` (&Candidate::aic_rank, bic_rank, holdout_rank), or null.
const Candidate* Best(const std::vector<Candidate>& candidates, int Candidate::*place);

// What a difference in AIC or BIC says (Burnham & Anderson's scale): "≤ 2: substantial support", …
std::string DeltaMeaning(double delta);

}  // namespace hysid
