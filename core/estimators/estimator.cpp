#include "core/estimators/estimator.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/estimators/frisch.hpp"
#include "core/estimators/gtls.hpp"
#include "core/estimators/integral.hpp"
#include "core/estimators/rls.hpp"

namespace hysid {

bool EstimatorSettings::IsValid(std::string* error) const {
  if (!CheckOptions(EstimatorOptions(), *this, error)) return false;
  if (!noise_shape.allFinite()) {
    if (error) *error = "noise_shape: must be finite";
    return false;
  }
  return true;
}

bool EstimatorSettings::NeedsNoiseShape() const {
  return DescriptorOf(kind).traits.needs_noise_shape && noise_shape.size() == 0;
}

void Estimator::Update(const ConstMatRef& phi, const ConstVecRef& y) {
  if (phi.cols() != theta_.size() || phi.rows() != y.size()) {
    throw std::invalid_argument(
        fmt::format("{}: regression of size Phi {}x{}, y {} does not match {} parameters", name(), phi.rows(),
                    phi.cols(), y.size(), theta_.size()));
  }
  if (!Admit(phi.allFinite() && y.allFinite())) return;
  DoUpdate(phi, y);
}

const char* ToString(EstimatorStatus status) {
  switch (status) {
    case EstimatorStatus::kOk: return "ok";
    case EstimatorStatus::kNotExcited: return "not-excited";
    case EstimatorStatus::kNonGeneric: return "non-generic";
    case EstimatorStatus::kIllConditioned: return "ill-conditioned";
  }
  return "?";
}

const PluginList<EstimatorDescriptor>& Plugins(EstimatorKind) {
  static const PluginList<EstimatorDescriptor> list{
      "estimator", {RlsDescriptor(), GtlsDescriptor(), FrischDescriptor(), IntegralDescriptor()}};
  return list;
}

std::unique_ptr<Estimator> MakeEstimator(const EstimatorSettings& settings, const Vec& theta0) {
  return MakePlugin(settings, theta0);
}

}  // namespace hysid
