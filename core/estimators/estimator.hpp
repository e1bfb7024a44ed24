// Recursive linear estimators for θ in y = Φθ (+ noise), one vector measurement per update.
//
// Pluggable (EstimatorKind: rls, the errors-in-variables estimators gtls, frisch, and integral, for
// α only; each described once by an EstimatorDescriptor): the identifier keeps one estimator for α
// (flow regression) and one for β (jump regression), as in Algorithm 1.
// An estimator never produces NaN: degenerate data (no excitation, repeated rows, a zero column) is
// reported in status() and the estimate is left where it was.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/model/model.hpp"
#include "core/model/option.hpp"
#include "core/model/plugin.hpp"

namespace hysid {

enum class EstimatorStatus {
  kOk,
  kNotExcited,      // too few independent rows so far: the estimate is the prior / partial
  kNonGeneric,      // TLS non-generic case: the extreme eigenvector has no θ component
  kIllConditioned,  // the data do not determine the estimate (reason() says why): a factorisation
                    // failed, or (gtls) the regressors' weakest direction is within the noise
  kInconsistent,    // set by Identify, not by an estimator: the estimate contradicts its data (its flow
                    // residuals far above the noise, or jumps in data where the detector found none;
                    // core/identify/self_check.hpp)
};
const char* ToString(EstimatorStatus status);

enum class EstimatorKind { kRls, kGtls, kFrisch, kIntegral };
// frisch: the box rule (core/estimators/frisch.hpp) and the point estimate.
enum class FrischBox { kIntersect, kCumulative };
enum class FrischPoint { kCentre, kClampedRls };

// The options of every estimator in one struct, each described once in EstimatorOptions() below;
// an estimator reads the ones its descriptor lists.
struct EstimatorSettings {
  EstimatorKind kind = EstimatorKind::kRls;
  double forgetting = 1.0;  // λ ∈ (0, 1]: exponential forgetting (1 = none)
  // Initial covariance P0 = p0·diag(1/g²) with g = prior_scale (the prior ridge P0⁻¹ = diag(g²)/p0
  // weighs as 1/p0 regression rows of typical size): rls, frisch's rls, integral's ridge.
  double p0 = 1e8;
  // g: the typical size of each unknown's regression column (its RMS over the data), so that the
  // prior is the same relative to the data in any units. Empty: ones (P0 = p0·I). Identify() fills
  // it from the data (RegressorScales in core/identify/identifier.hpp).
  Vec prior_scale;
  int refactor_every = 500;  // gtls: recompute S⁻¹ from scratch every this many rows
  // frisch: window length in rows (0 = growing window with `forgetting`, box refreshed every update).
  int window = 200;
  // frisch: kCumulative (bounding box of the simplex of all rows so far, refreshed every window) or
  // kIntersect (BBRF: running intersection of each window's own box). See core/estimators/frisch.hpp.
  FrischBox frisch_box = FrischBox::kCumulative;
  // frisch: point estimate: kClampedRls (RLS clamped into the BBRF-intersected box) or kCentre (of
  // the reported box).
  FrischPoint frisch_point = FrischPoint::kClampedRls;
  // frisch: confidence of the sampling allowance added to every box (± a Student-t quantile times
  // the standard error of the least-squares vertex; for the BBRF intersection split over the
  // windows by a union bound). 0 = none: the plain Frisch / BBRF box, a population statement.
  double frisch_confidence = 0.95;
  // gtls: noise covariance shape C of a regression row z = [φ; y] ((p+1) × (p+1), up to scale;
  // empty given directly to MakeEstimator = identity, classical TLS). frisch: only its zero diagonal
  // entries are used (exact columns; empty = none). The identifier fills an empty shape from σ, δt
  // and the model (WithNoiseShapes in core/identify/identifier.hpp, core/model/noise_shape.hpp).
  Mat noise_shape;
  // P0's diagonal p0/g_i² for `parameters` unknowns (prior_scale empty: p0 each). Throws
  // std::invalid_argument when prior_scale has another size.
  Vec PriorCovariance(Eigen::Index parameters) const;
  // Every option in EstimatorOptions(), noise_shape and prior_scale; names the field, e.g.
  // "forgetting = 1.5: must be in (0, 1]".
  bool IsValid(std::string* error) const;
  // True when the estimator's descriptor needs a noise shape and none is given.
  bool NeedsNoiseShape() const;
};

// Each option of EstimatorSettings, described once (name = field = TOML key, flag --name).
inline const std::vector<Option<EstimatorSettings>>& EstimatorOptions() {
  using S = EstimatorSettings;
  static const std::vector<Option<S>> table{
      Describe<&S::forgetting>({.name = "forgetting",
                                .range = {0, 1, true, false},
                                .help = "exponential forgetting factor lambda (1 = none)"}),
      Describe<&S::p0>({.name = "p0",
                        .range = {0, kUnbounded, true, true},
                        .help = "initial covariance P0 = p0 I (prior ridge I/p0)"}),
      Describe<&S::refactor_every>({.name = "refactor_every",
                                    .range = {1, kUnbounded},
                                    .help = "exact refactorisation every this many rows"}),
      Describe<&S::window>(
          {.name = "window", .range = {0, kUnbounded}, .help = "window in rows (0 = growing)"}),
      Describe<&S::frisch_box>({.name = "frisch_box",
                                .choices = {"intersect", "cumulative"},
                                .help = "cumulative (box of the simplex of all rows) or intersect (BBRF)"}),
      Describe<&S::frisch_point>({.name = "frisch_point",
                                  .choices = {"centre", "rls"},
                                  .help = "rls (RLS clamped into the boxes) or centre (of the box)"}),
      Describe<&S::frisch_confidence>(
          {.name = "frisch_confidence",
           .range = {0, 1, false, true},
           .help = "confidence of the sampling allowance added to the boxes (0 = none)"}),
  };
  return table;
}

class Estimator {
 public:
  virtual ~Estimator() = default;

  // θ ∈ ℝ^p with Φ ∈ ℝ^{rows×p}, y ∈ ℝ^{rows}. Checks sizes (throws std::invalid_argument), then
  // calls DoUpdate. Non-finite rows are skipped and counted (status unchanged).
  void Update(const ConstMatRef& phi, const ConstVecRef& y);

  const Vec& estimate() const { return theta_; }
  // Parameter covariance (up to the noise variance), nullptr when the estimator has none; valid until
  // the next Update or Reset.
  virtual const Mat* covariance_matrix() const { return nullptr; }
  // The solution box of the unknowns, p × 2 (lower, upper), when the estimator reports one (its
  // descriptor's reports_box) and has it yet; else empty.
  virtual Mat solution_box() const { return Mat(); }
  EstimatorStatus status() const { return status_; }
  // Why the status is not ok, in words (empty when ok or not yet excited).
  const std::string& reason() const { return reason_; }
  long updates() const { return updates_; }
  long skipped() const { return skipped_; }  // non-finite regressions ignored
  int parameter_count() const { return static_cast<int>(theta_.size()); }
  virtual std::string name() const = 0;
  // A copy of this estimator, state and settings.
  virtual std::unique_ptr<Estimator> Clone() const = 0;
  // Back to the prior θ0.
  virtual void Reset() = 0;
  // The next row does not continue the trajectory of the previous ones (a jump, a gap in the data,
  // another run). Only estimators that integrate consecutive rows (`integral`) use it.
  virtual void Break() {}

 protected:
  explicit Estimator(const Vec& theta0) : theta0_(theta0), theta_(theta0) {}
  // The rule for every update: a non-finite regression is skipped and counted, a finite one counted
  // as an update. Returns whether to update.
  bool Admit(bool finite) {
    if (!finite) {
      ++skipped_;
      return false;
    }
    ++updates_;
    return true;
  }
  // `rows` finite regressions admitted by a caller that applied them itself (Admit on each).
  void AddUpdates(long rows) { updates_ += rows; }
  virtual void DoUpdate(const ConstMatRef& phi, const ConstVecRef& y) = 0;
  // A status other than ok, with its reason (not inline: called from the per-row paths on failure).
  void SetNotOk(EstimatorStatus status, std::string reason);
  // Reset's common part: θ back to the prior θ0, status kNotExcited, no updates, none skipped.
  void ResetToPrior() {
    theta_ = theta0_;
    status_ = EstimatorStatus::kNotExcited;
    reason_.clear();
    updates_ = 0;
    skipped_ = 0;
  }

  const Vec theta0_;  // the prior
  Vec theta_;
  EstimatorStatus status_ = EstimatorStatus::kNotExcited;
  std::string reason_;
  long updates_ = 0;
  long skipped_ = 0;
};

// What an estimator's descriptor adds to the common part (core/model/plugin.hpp).
struct EstimatorTraits {
  bool needs_noise_shape = false;  // the identifier derives one when none is given
  bool reports_box = false;        // solution_box()
  // Its rows must be the consecutive flow differences of one trajectory (Break() between pieces):
  // an α estimator only; where one kind is chosen for both, β gets rls (IdentifierSettings::
  // UseEstimator).
  bool flow_only = false;
};
using EstimatorFactory = std::unique_ptr<Estimator> (*)(const EstimatorSettings&, const Vec& theta0);
// One estimator, described once: the factory, the command line and sweep files read this.
using EstimatorDescriptor = PluginDescriptor<EstimatorKind, EstimatorTraits, EstimatorFactory>;
// Every estimator, in the order of EstimatorKind; ParseKind<EstimatorKind>("x") throws
// "unknown estimator 'x' (known: rls, gtls, frisch, integral)".
const PluginList<EstimatorDescriptor>& Plugins(EstimatorKind);

// Throws std::invalid_argument naming the estimator and the field for invalid settings.
std::unique_ptr<Estimator> MakeEstimator(const EstimatorSettings& settings, const Vec& theta0);

}  // namespace hysid
