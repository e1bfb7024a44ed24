// The identifier's state and the steps of its pass, shared by the sources that run it (not installed):
//   identifier.cpp      the public Identifier: construction, the per-sample path through the
//                       estimator and detector interfaces, Feed, the jump update;
//   row_block.cpp       the direct path: blocks of samples with the estimator and the detector called
//                       directly, and its flow runs;
//   lockstep_units.cpp  what the lockstep driver asks of an identifier (core/identify/lockstep_units.hpp);
//   identify.cpp        Identify: the passes over a data set and the result.
#pragma once

#include <memory>
#include <optional>
#include <vector>

#include "core/detectors/paper.hpp"
#include "core/detectors/residual.hpp"
#include "core/estimators/integral.hpp"
#include "core/estimators/rls.hpp"
#include "core/identify/identifier.hpp"
#include "core/identify/localize.hpp"
#include "core/model/automaton.hpp"
#include "core/model/regression.hpp"
#include "core/sets/sample_set.hpp"

namespace hysid::detail {

inline constexpr Eigen::Index kFeedBlock = 256;  // samples per block of regressions in Feed

// The identifier's state that copies as it is (IdentifierState adds the estimators, the detector, the
// sets and the direct calls bound to them).
struct IdentifierValues {
  IdentifierValues(const Model& m, double step, const IdentifierSettings& s)
      : model(m),
        dt(step),
        settings(s),
        builder(m),
        alpha_known(m.alpha()),
        beta_known(m.beta()),
        prev(m.state_size()),
        phi(builder.flow_layout().rows.size(), builder.flow_layout().unknown.size()),
        y(builder.flow_layout().rows.size()),
        psi(builder.jump_layout().rows.size(), builder.jump_layout().unknown.size()),
        yj(builder.jump_layout().rows.size()),
        localizer(m),
        inputs(m.input_size() > 0),
        contextual(inputs || IsAutomaton(m.spec())),
        prev_u(m.input_size()),
        cur_u(m.input_size()) {}

  Model model;
  double dt;
  IdentifierSettings settings;
  RegressionBuilder builder;
  Vec alpha_known, beta_known, alpha_full;
  Vec prev;
  bool has_prev = false;
  Mat phi;
  Vec y;
  Mat psi;
  Vec yj;
  // Feed: the flow regressions of a block of samples (|u| × kFeedBlock rows, kFeedBlock values).
  std::vector<double> block_phi, block_y;
  JumpLocalizer localizer;
  JumpLocation location;
  // Second pass: classification uses these instead of the running estimates.
  bool frozen = false;
  Vec frozen_alpha;
  std::optional<Mat> frozen_covariance;
  long frozen_updates = 0;
  long version = 0;
  long samples = 0;
  long jumps = 0;
  long localized = 0;
  // A model with inputs: the time and u of the previous and the current sample. A hybrid automaton
  // (contextual without inputs too): their modes, and the map of the jump into the current sample.
  bool inputs = false;
  bool contextual = false;
  Vec prev_u, cur_u;
  double prev_t = 0.0, cur_t = 0.0;
  int prev_mode = 0, cur_mode = 0, cur_map = 0;
  // StopAtJumps (core/identify/lockstep_units.hpp): the direct path stops before it applies a jump, its
  // decision here.
  bool stop_at_jumps = false;
  Decision stopped;
  Context PrevAt() const {
    return {.t = prev_t, .u = inputs ? prev_u.data() : nullptr, .mode = prev_mode, .map = cur_map};
  }
  Context CurAt() const {
    return {.t = cur_t, .u = inputs ? cur_u.data() : nullptr, .mode = cur_mode, .map = cur_map};
  }
};

struct IdentifierState;
// A row block (row_block.cpp): `count` consecutive samples x_k = xs + k·n after s.prev, their flow rows
// (phi + k·|u|, y[k]) built, fed on the direct path, the decisions written (unless null). Returns where
// it stopped (StopAtJumps), else count.
using RowBlockFn = Eigen::Index (*)(IdentifierState&, const double* xs, Eigen::Index count, const double* phi,
                                    const double* y, Decision* decisions);

struct IdentifierState : IdentifierValues {
  // Throws std::invalid_argument for a wrong-sized prior or σ, and a flow-only jump estimator.
  IdentifierState(const Model& m, double step, const IdentifierSettings& s);
  // `other`'s state with `own` settings, which differ from other's in the detector's settings alone
  // (AdoptState); no sets (they do not copy).
  IdentifierState(const IdentifierState& other, const IdentifierSettings& own);

  // The common configurations get direct, inlined calls instead of the virtual interfaces: RLS
  // for α on one identified row, and with it the paper detector on a model with a constant flow
  // Jacobian. Same arithmetic in the same order (tests/core/identify/identifier_test.cpp checks
  // bit-equality).
  void Bind();

  std::unique_ptr<Estimator> flow, jump;
  std::unique_ptr<JumpDetector> detector;
  SampleSet flow_set, jump_set;
  // The α estimator on one identified row (direct_calls), when it is RLS or integral.
  Rls* rls = nullptr;
  IntegralLs* integral = nullptr;
  // The β estimator on one identified row (direct_calls), when it is RLS.
  Rls* jump_rls = nullptr;
  void (*jump_row)(Rls&, const double*, double) = nullptr;  // its UpdateRow for |u| unknowns
  // With rls or integral: the detector, when it is the paper's (on a constant Jacobian) or the residual
  // detector, and the row block for the model's sizes.
  PaperDetector* paper = nullptr;
  ResidualDetector* residual = nullptr;
  RowBlockFn row_block = nullptr;
  bool flow_run = false;  // the row block for n = 2, |u| = 2, RLS and the paper detector may take flow runs
};

// The row block for s's direct calls and the model's sizes (s.rls or s.integral set; row_block.cpp).
RowBlockFn ChooseRowBlock(const IdentifierState& s);
// From sample k of a block (xs: its samples, 2 × count; phi, y: its flow rows; its decisions written):
// FeedRest feeds samples k … count − 1 by the row block; ApplyAndFeed first applies decision d to
// sample k. Both return where they stopped (StopAtJumps), else count (row_block.cpp).
Eigen::Index FeedRest(IdentifierState& s, const double* xs, Eigen::Index k, Eigen::Index count,
                      const double* phi, const double* y, Decision* decisions);
Eigen::Index ApplyAndFeed(IdentifierState& s, const double* xs, Eigen::Index k, Eigen::Index count,
                          const double* phi, const double* y, const Decision& d, Decision* decisions);

// γ = 0, after the α estimator's update to θ (its estimate): α̂ and its version (the caller adds
// ξ(t−δt) to Λ). P = |u| when known at compile time, else 0.
template <int P>
[[gnu::always_inline]] inline void AfterFlowUpdate(IdentifierState& s, const double* theta) {
  const int* unknown = s.builder.flow_layout().unknown.data();
  const int u = P > 0 ? P : static_cast<int>(s.builder.flow_layout().unknown.size());
  for (int i = 0; i < u; ++i) s.alpha_full[unknown[i]] = theta[i];
  ++s.version;
}
// γ = 1: the jump regression (at the located instant when asked and found), β̂, Γ (identifier.cpp).
void AfterJump(IdentifierState& s, ConstVecRef x, const Vec& alpha_class);
// What the detector sees of sample x after s.prev, with the flow regression (phi: rows × |u|
// column-major, y: rows) already built.
SampleContext SampleContextOf(IdentifierState& s, const double* x, const double* phi, const double* y,
                              const Vec& alpha_class);

// What a model with inputs cannot be identified with: the noise shapes of gtls and frisch and the
// jump localiser integrate or differentiate the flow without the inputs between samples. Throws
// std::invalid_argument naming the setting.
void CheckInputSettings(const Model& m, const IdentifierSettings& s);
// Settings with the noise shapes filled at the model's default state (Identifier's constructor).
IdentifierSettings ResolvedAtDefault(const Model& m, double dt, const IdentifierSettings& s);

// An identifier's state, for the sources above (Identifier befriends it).
struct IdentifierAccess {
  static IdentifierState& Of(Identifier& id) { return *id.s_; }
  static const IdentifierState& Of(const Identifier& id) { return *id.s_; }
  static std::unique_ptr<IdentifierState>& Pointer(Identifier& id) { return id.s_; }
};

}  // namespace hysid::detail
