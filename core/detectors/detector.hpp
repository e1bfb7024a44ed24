// Jump detectors: decide, for each sample pair (ξ(t−δt), ξ(t)), whether a jump happened in
// (t−δt, t] (γ = 1) or the system flowed (γ = 0). Pluggable (DetectorKind, each described once by a
// DetectorDescriptor): paper (§3 of the paper: Euler derivative against the estimated smoothness
// bound τ̂) and residual (tuning-free: the one-step prediction residual of the flow model against its
// predicted distribution, core/detectors/residual.hpp).
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/model/model.hpp"
#include "core/model/option.hpp"
#include "core/model/plugin.hpp"

namespace hysid {

class SampleSet;  // core/sets/sample_set.hpp
struct DetectorSettings;

// Everything a detector may use for one sample. References stay valid for the call only.
using ConstVecMap = Eigen::Map<const Vec>;
using ConstMatMap = Eigen::Map<const Mat>;

// Everything a detector may use for one sample. The maps point into the caller's storage and stay
// valid for the call only.
struct SampleContext {
  const Model* model = nullptr;
  double dt = 0.0;               // δt
  ConstVecMap prev{nullptr, 0};  // ξ(t−δt) (measured)
  ConstVecMap cur{nullptr, 0};   // ξ(t)
  // The flow regression of this pair on the identified rows: y = Φ α_u (see core/model/regression.hpp).
  ConstMatMap flow_phi{nullptr, 0, 0};
  ConstVecMap flow_y{nullptr, 0};
  ConstVecMap alpha_hat{nullptr, 0};  // full α̂ (known entries at their known values)
  // Of the unknown entries, when the estimator has one (RLS: P, Cov(α̂) ≈ residual variance × P).
  const Mat* alpha_covariance = nullptr;
  long flow_updates = 0;                // flow samples the α estimator has seen
  long version = 0;                     // changes whenever α̂ changes (for caching)
  const SampleSet* flow_set = nullptr;  // Λ, whose hull is Ĉ (may be null or empty)
  const Vec* sigma = nullptr;           // measurement noise σ per component, when known
  // Accuracy of the data apart from σ: component j off by up to data_rtol·|ξ_j| + data_atol.
  double data_rtol = 0.0, data_atol = 0.0;
  // A model with inputs: the time and inputs u of ξ(t−δt) and of ξ(t) (u null without inputs).
  Context at_prev{}, at_cur{};
};

struct Decision {
  bool gamma = false;      // γ: true = jump
  double statistic = 0.0;  // the tested quantity (paper: D_δt ξ(t))
  double threshold = 0.0;  // its threshold (paper: τ̂(t))
};

class JumpDetector {
 public:
  virtual ~JumpDetector() = default;
  virtual Decision Classify(const SampleContext& context) = 0;
  // Told the final decision (after Classify) so that stateful detectors can learn from it.
  virtual void Observe(const SampleContext& /*context*/, const Decision& /*decision*/) {}
  virtual std::string name() const = 0;
  virtual void Reset() = 0;
  // A copy of what this detector has learned, with `settings` instead of its own (the same kind and
  // everything else equal; they may differ in the threshold alone: a sweep's units that share one
  // identifier until their decisions differ, core/identify/lockstep.hpp).
  virtual std::unique_ptr<JumpDetector> CloneWith(const DetectorSettings& settings) const = 0;
};

enum class DetectorKind { kPaper, kResidual };
// paper detector: how L̂ and the norms are taken (core/detectors/paper.hpp):
//   kPaper        the identified rows of the Jacobian, ‖ξ‖ (as the paper's §5: L̂ = ‖α̂‖);
//   kHomogeneous  [J_r f̂_r(0)] with ‖[ξ; 1]‖, for affine flows (f(0) ≠ 0, e.g. gravity);
//   kAuto         kPaper when φ(0) = 0 on the identified rows, kHomogeneous otherwise.
enum class BoundRule { kAuto, kPaper, kHomogeneous };

// The options of every detector in one struct, each described once in DetectorOptions() below; a
// detector reads the ones its descriptor lists.
struct DetectorSettings {
  DetectorKind kind = DetectorKind::kPaper;
  // paper: τ̂(t) = (r/2)·L̂·(‖ξ(t)‖ + ‖ξ(t−δt)‖), L̂ = sup_{ξ∈Ĉ}‖∂f̂/∂ξ‖; τ̂ = tau0 until the first
  // α update.
  double r = 220.0;
  double tau0 = 1e5;
  BoundRule bound = BoundRule::kAuto;
  // residual: false-alarm probability per sample under flow (its only input). 1e-8: a run of 1e5
  // samples then has a false jump with probability ≈ 1e-3 (1e-6 gave up to 0.2 false jumps per
  // 2e5-sample run of the robustness map); no jump of that map is missed at 1e-8.
  double false_alarm = 1e-8;
  // Every option in DetectorOptions(); names the field, e.g. "r = 1: must be > 1".
  bool IsValid(std::string* error) const;
};

// Each option of DetectorSettings, described once (name = field = TOML key, flag --name).
inline const std::vector<Option<DetectorSettings>>& DetectorOptions() {
  using S = DetectorSettings;
  static const std::vector<Option<S>> table{
      Describe<&S::r>({.name = "r",
                       .range = {1, kUnbounded, true, true},
                       .help = "multiplicative constant r > 1 of the smoothness bound",
                       .sweepable = true}),
      Describe<&S::tau0>(
          {.name = "tau0", .range = {0, kUnbounded, true, true}, .help = "initial smoothness bound"}),
      Describe<&S::bound>({.name = "bound",
                           .choices = {"auto", "paper", "homogeneous"},
                           .help = "auto, paper or homogeneous bound"}),
      Describe<&S::false_alarm>({.name = "false_alarm",
                                 .range = {0, 0.5, true, true},
                                 .help = "false-alarm probability per flow sample",
                                 .sweepable = true}),
  };
  return table;
}

// What a detector's descriptor adds to the common part (core/model/plugin.hpp): the trace column
// names of what it reports per sample (Decision::statistic, Decision::threshold).
struct DetectorTraits {
  std::string_view statistic, threshold;
};
using DetectorFactory = std::unique_ptr<JumpDetector> (*)(const DetectorSettings&, const Model&);
// One detector, described once: the factory, the command line and sweep files read this.
using DetectorDescriptor = PluginDescriptor<DetectorKind, DetectorTraits, DetectorFactory>;
// Every detector, in the order of DetectorKind; ParseKind<DetectorKind>("x") throws
// "unknown detector 'x' (known: paper, residual)".
const PluginList<DetectorDescriptor>& Plugins(DetectorKind);

// Throws std::invalid_argument naming the detector and the field for invalid settings.
std::unique_ptr<JumpDetector> MakeDetector(const DetectorSettings& settings, const Model& model);

}  // namespace hysid
