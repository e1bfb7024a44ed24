#include "core/estimator.hpp"

#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

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
  return true;
}

void Estimator::Update(ConstMatRef phi, ConstVecRef y) {
  if (phi.cols() != theta_.size() || phi.rows() != y.size()) {
    throw std::invalid_argument(fmt::format(
        "{}: regression of size Phi {}x{}, y {} does not match {} parameters", name(), phi.rows(),
        phi.cols(), y.size(), theta_.size()));
  }
  if (!phi.allFinite() || !y.allFinite()) {
    ++skipped_;
    return;
  }
  ++updates_;
  DoUpdate(phi, y);
}

std::vector<std::string> EstimatorNames() { return {"rls"}; }

std::unique_ptr<Estimator> MakeEstimator(const EstimatorSettings& settings, const Vec& theta0) {
  std::string error;
  if (!settings.IsValid(&error)) {
    throw std::invalid_argument(fmt::format("estimator '{}': {}", settings.name, error));
  }
  if (settings.name == "rls") {
    return std::make_unique<Rls>(theta0, settings.p0, settings.forgetting);
  }
  throw std::invalid_argument(fmt::format("unknown estimator '{}' (known: {})", settings.name,
                                          fmt::join(EstimatorNames(), ", ")));
}

}  // namespace hysid
