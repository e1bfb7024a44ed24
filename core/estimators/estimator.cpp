#include "core/estimators/estimator.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

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
  if (!(prior_scale.array() > 0.0).all() || !prior_scale.allFinite()) {
    if (error) *error = "prior_scale: every entry must be finite and > 0";
    return false;
  }
  return true;
}

Vec EstimatorSettings::PriorCovariance(Eigen::Index parameters) const {
  if (prior_scale.size() == 0) return Vec::Constant(parameters, p0);
  if (prior_scale.size() != parameters) {
    throw std::invalid_argument(fmt::format("prior_scale has {} entries; the estimator has {} parameters",
                                            prior_scale.size(), parameters));
  }
  return p0 * prior_scale.array().square().inverse();
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

void Estimator::SetNotOk(EstimatorStatus status, std::string reason) {
  status_ = status;
  reason_ = std::move(reason);
}

const char* ToString(EstimatorStatus status) {
  switch (status) {
    case EstimatorStatus::kOk: return "ok";
    case EstimatorStatus::kNotExcited: return "not-excited";
    case EstimatorStatus::kNonGeneric: return "non-generic";
    case EstimatorStatus::kIllConditioned: return "ill-conditioned";
    case EstimatorStatus::kInconsistent: return "inconsistent";
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
