#include "core/estimators/estimator.hpp"

#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

#include "core/estimators/frisch.hpp"
#include "core/estimators/gtls.hpp"
#include "core/estimators/rls.hpp"

namespace hysid {

const char* ToString(EstimatorStatus status) {
  switch (status) {
    case EstimatorStatus::kOk: return "ok";
    case EstimatorStatus::kNotExcited: return "not-excited";
    case EstimatorStatus::kNonGeneric: return "non-generic";
    case EstimatorStatus::kIllConditioned: return "ill-conditioned";
  }
  return "?";
}

bool EstimatorSettings::IsValid(std::string* error) const {
  auto fail = [&](std::string message) {
    if (error) *error = std::move(message);
    return false;
  };
  if (!(forgetting > 0.0 && forgetting <= 1.0)) {
    return fail(fmt::format("forgetting = {}: must be in (0, 1]", forgetting));
  }
  if (!(p0 > 0.0) || !std::isfinite(p0)) return fail(fmt::format("p0 = {}: must be > 0", p0));
  if (refactor_every < 1) {
    return fail(fmt::format("refactor_every = {}: must be >= 1", refactor_every));
  }
  if (window < 0) return fail(fmt::format("window = {}: must be >= 0", window));
  if (!noise_shape.allFinite()) return fail("noise_shape: must be finite");
  if (!(frisch_confidence >= 0.0 && frisch_confidence < 1.0)) {
    return fail(fmt::format("frisch_confidence = {}: must be in [0, 1)", frisch_confidence));
  }
  if (frisch_box != "cumulative" && frisch_box != "intersect") {
    return fail(fmt::format("frisch_box = '{}': must be 'cumulative' or 'intersect'", frisch_box));
  }
  if (frisch_point != "centre" && frisch_point != "rls") {
    return fail(fmt::format("frisch_point = '{}': must be 'centre' or 'rls'", frisch_point));
  }
  return true;
}

void Estimator::Update(const ConstMatRef& phi, const ConstVecRef& y) {
  if (phi.cols() != theta_.size() || phi.rows() != y.size()) {
    throw std::invalid_argument(fmt::format(
        "{}: regression of size Phi {}x{}, y {} does not match {} parameters", name(), phi.rows(),
        phi.cols(), y.size(), theta_.size()));
  }
  if (!Admit(phi.allFinite() && y.allFinite())) return;
  DoUpdate(phi, y);
}

std::vector<std::string> EstimatorNames() { return {"rls", "gtls", "frisch"}; }

std::unique_ptr<Estimator> MakeEstimator(const EstimatorSettings& settings, const Vec& theta0) {
  std::string error;
  if (!settings.IsValid(&error)) {
    throw std::invalid_argument(fmt::format("estimator '{}': {}", settings.name, error));
  }
  if (settings.name == "rls") {
    return std::make_unique<Rls>(theta0, settings.p0, settings.forgetting);
  }
  if (settings.name == "gtls") {
    return std::make_unique<Gtls>(theta0, settings.noise_shape, settings.forgetting,
                                  settings.refactor_every);
  }
  if (settings.name == "frisch") {
    return std::make_unique<Frisch>(
        theta0, settings.window, settings.forgetting, settings.p0,
        settings.frisch_box == "intersect" ? FrischBox::kIntersect : FrischBox::kCumulative,
        settings.frisch_point == "rls" ? FrischPoint::kClampedRls : FrischPoint::kCentre,
        settings.noise_shape, settings.frisch_confidence);
  }
  throw std::invalid_argument(fmt::format("unknown estimator '{}' (known: {})", settings.name,
                                          fmt::join(EstimatorNames(), ", ")));
}

}  // namespace hysid
