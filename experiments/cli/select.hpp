// hysid identify on a model file with candidate terms (of flow rows, of the [jump]'s rows and of
// [[jump]] maps' rows): the selection of the terms the data support (core/select), its bootstrap, the
// chosen model (core/model_file/chosen.hpp) that the rest of identify refines, the chosen terms the
// refined fit does not support dropped, and --chosen-model.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json_fwd.hpp>

#include "core/identify/identifier.hpp"
#include "core/io/sample_data.hpp"
#include "core/model/model.hpp"
#include "core/select/select.hpp"
#include "experiments/request/request.hpp"
#include "sim/refine/refine.hpp"

namespace hysid::cli {

struct SelectArgs {
  std::string chosen_model;  // --chosen-model PATH
  int bootstrap = 100;       // --select-bootstrap N (0: none)
  std::uint64_t seed = 1;    // --select-seed
};
void AddSelectOptions(CLI::App& cmd, SelectArgs& args);
// --chosen-model given for a model without candidates, or --select-* out of range: BadFlag.
void CheckSelectArgs(const SelectArgs& args, const Model& model);

// The selection of one mode's candidates (a [flow]'s: mode 0) on that mode's flow samples.
struct SelectBlock {
  int mode = 0;
  std::string mode_name;                // "" for [flow]
  std::vector<int> positions;           // its columns: positions in SelectStep::columns
  Selection selection;                  // over `positions`
  BootstrapResult bootstrap;            // over `positions`
  int segments = 0;                     // flow segments of the mode summed
};

// The selection of the [jump]'s candidates, or of one [[jump]] map's, on the detected jumps (of that
// map: core/select SumJumps, one group of rows per jump), by leave-one-jump-out cross-validation; its
// bootstrap redraws the jumps.
struct JumpSelect {
  std::string map;                      // the [[jump]] map's name; "" for [jump]
  std::vector<int> columns;             // unknown β indices (SumJumps' columns; a map's: its slice's)
  std::vector<bool> selectable;         // per column: a candidate
  // Per column: the β name and, for a candidate, "ROW+ term TERM", its row's state and its term.
  std::vector<std::string> names, terms, rows, raw_terms;
  Selection selection;                  // per column, after the stability rule
  BootstrapResult bootstrap;
  std::vector<int> unstable;            // columns cross-validation chose and KeepStable dropped
  int jumps = 0;                        // detected jumps summed
};

// A chosen candidate the refined fit of the chosen model does not support: its z² = (estimate / its
// standard error)² below the χ²₁ quantile at 1 − kFitDropSize.
struct FitDrop {
  std::string name;
  double z2 = 0.0, threshold = 0.0;
};
inline constexpr double kFitDropSize = 0.01;

struct SelectStep {
  std::optional<Model> chosen;          // the chosen model, values from the selection's fit
  std::vector<SelectBlock> blocks;      // one per mode with candidates, in mode order
  bool per_mode = false;                // the candidates are in [[flow]] tables
  std::string text, file;               // the model file with candidates (its text, its path)
  std::vector<int> columns;             // unknown α indices of the full model (FlowSums::columns)
  std::vector<bool> selectable;         // per column: a candidate
  // Per column: the α name and, for a candidate, "ROW' term TERM", its row's state and its term.
  std::vector<std::string> names, terms, rows, raw_terms;
  std::vector<std::string> term_modes;  // per column: a [[flow]] candidate's mode, else ""

  // The blocks' selections and bootstraps per column of `columns` (a column of no block: chosen when no
  // candidate, estimate 0, frequency 0); with several blocks bic, rows and supports are the blocks'
  // sums, the runner-up BIC is infinite and the bootstrap's draws and exact supports the least over them.
  Selection selection;
  BootstrapResult bootstrap;
  std::vector<JumpSelect> jumps;        // [jump] candidates: one; [[jump]] candidates: one per map with them
  std::vector<std::string> kept;        // names of the chosen candidates (flow and jump)
  std::vector<int> unstable;            // columns cross-validation chose and KeepStable dropped
  int segments = 0;                     // flow segments summed (over the blocks)
  int round = 1;                        // 1: on the pass with every candidate; then on the chosen model's
  double seconds = 0.0;                 // the selection and its bootstrap
  std::vector<FitDrop> dropped_by_fit;  // DropUnsupportedTerms, in order
};

// The selection on the detections of a recursive pass (`detected`: of the model with candidates, or
// of a chosen model) over `model`'s candidates; the bootstrap when `bootstrap`. Throws RunFailed when
// no support can be chosen.
SelectStep SelectCandidates(const Model& model, const std::string& file, const SampleData& data,
                            const IdentifyResult& detected, const SelectArgs& args, bool bootstrap);
void PrintSelection(const SelectStep& step);
nlohmann::json SelectionJson(const SelectStep& step);
// --refine ml: the chosen model refined (RunRefinement on the outcome of its recursive pass); while the
// fit is reported and a chosen candidate's z² is below the threshold (FitDrop), the least such is
// dropped and the chosen model without it (the refined values as its start) passed and refined again,
// the drop kept when that fit is reported and ok (or the fit before it was not). Leaves the outcome
// refined and `step` with the support kept (kept, chosen flags, the chosen model, dropped_by_fit).
void DropUnsupportedTerms(const IdentifyRequest& request, IdentifyOutcome* outcome, SelectStep* step);
void PrintFitDrops(const SelectStep& step);
// After the chosen model's refinement (`refined`, null: none ran) or recursive pass: the chosen terms
// with their estimates and bootstrap frequencies; --chosen-model written with the estimates.
void FinishSelection(const SelectStep& step, const Model& chosen, const IdentifyResult& recursive,
                     const RefineResult* refined, const SelectArgs& args);

}  // namespace hysid::cli
