// Recursive linear estimators for θ in y = Φθ (+ noise), one vector measurement per update.
//
// Pluggable by name ("rls", and the errors-in-variables estimators "gtls", "frisch"): the identifier
// keeps one estimator for α (flow regression) and one for β (jump regression), as in Algorithm 1.
// An estimator never produces NaN: degenerate data (no excitation, repeated rows, a zero column) is
// reported in status() and the estimate is left where it was.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/model/model.hpp"

namespace hysid {

enum class EstimatorStatus {
  kOk,
  kNotExcited,   // too few independent rows so far: the estimate is the prior / partial
  kNonGeneric,   // TLS non-generic case: the extreme eigenvector has no θ component
  kIllConditioned,  // an update was skipped because a factorisation failed
};
const char* ToString(EstimatorStatus status);

// Settings shared by every estimator, and each estimator's own. One struct so that sweeps and the
// command line can set any of them by name.
struct EstimatorSettings {
  std::string name = "rls";
  double forgetting = 1.0;  // λ ∈ (0, 1]: exponential forgetting (1 = none)
  // Initial covariance P0 = p0·I (the RLS prior ridge is P0⁻¹ = I/p0). Large: the flow regressors
  // are O(δt), so ΣΦᵀΦ is small and a 1e4 prior would bias α̂ by ~1e-3 on the §5 system.
  double p0 = 1e8;
  // gtls: noise covariance shape C of a regression row z = [φ; y] ((p+1) × (p+1), up to scale;
  // empty given directly to MakeEstimator = identity, classical TLS). frisch: only its zero diagonal
  // entries are used (exact columns; empty = none). The identifier fills an empty shape from σ, δt
  // and the model (WithNoiseShapes in core/identify/identifier.hpp, core/model/noise_shape.hpp).
  Mat noise_shape;
  int refactor_every = 500;  // gtls: recompute S⁻¹ from scratch every this many rows
  // frisch: window length in rows (0 = growing window with `forgetting`, box refreshed every update).
  int window = 200;
  // frisch: "cumulative" (bounding box of the simplex of all rows so far, refreshed every window) or
  // "intersect" (BBRF: running intersection of each window's own box). See core/estimators/frisch.hpp.
  std::string frisch_box = "cumulative";
  // frisch: point estimate: "rls" (RLS clamped into the BBRF-intersected box) or "centre" (of the
  // reported box).
  std::string frisch_point = "rls";
  // frisch: confidence of the sampling allowance added to every box (± a Student-t quantile times
  // the standard error of the least-squares vertex; for the BBRF intersection split over the
  // windows by a union bound). 0 = none: the plain Frisch / BBRF box, a population statement.
  double frisch_confidence = 0.95;
  // Field-naming message, e.g. "forgetting = 1.5: must be in (0, 1]".
  bool IsValid(std::string* error) const;
};

class Estimator {
 public:
  virtual ~Estimator() = default;

  // θ ∈ ℝ^p with Φ ∈ ℝ^{rows×p}, y ∈ ℝ^{rows}. Checks sizes (throws std::invalid_argument), then
  // calls DoUpdate. Non-finite rows are skipped and counted (status unchanged).
  void Update(const ConstMatRef& phi, const ConstVecRef& y);

  const Vec& estimate() const { return theta_; }
  // Parameter covariance (up to the noise variance), when the estimator has one.
  virtual std::optional<Mat> covariance() const { return std::nullopt; }
  // The same without a copy (nullptr when there is none); valid until the next Update or Reset.
  virtual const Mat* covariance_matrix() const { return nullptr; }
  EstimatorStatus status() const { return status_; }
  long updates() const { return updates_; }
  long skipped() const { return skipped_; }  // non-finite regressions ignored
  int parameter_count() const { return static_cast<int>(theta_.size()); }
  virtual std::string name() const = 0;
  // Back to the prior θ0.
  virtual void Reset() = 0;

 protected:
  explicit Estimator(Vec theta0) : theta_(std::move(theta0)) {}
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
  virtual void DoUpdate(const ConstMatRef& phi, const ConstVecRef& y) = 0;

  Vec theta_;
  EstimatorStatus status_ = EstimatorStatus::kNotExcited;
  long updates_ = 0;
  long skipped_ = 0;
};

// Known names: "rls", "gtls", "frisch". Throws std::invalid_argument naming the known
// estimators for an unknown name or invalid settings.
std::unique_ptr<Estimator> MakeEstimator(const EstimatorSettings& settings, const Vec& theta0);
std::vector<std::string> EstimatorNames();

}  // namespace hysid
