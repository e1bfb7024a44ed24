#include <cmath>
#include <stdexcept>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "experiments/cli/cli.hpp"

namespace hysid::cli {

void BadFlag(const std::string& what) { throw std::invalid_argument(what); }

Model MakeModel(const Environment& env, const std::string& name,
                const std::vector<std::string>& params) {
  Model model = [&] {
    try {
      return env.models.Make(name);
    } catch (const std::invalid_argument& e) {
      BadFlag(fmt::format("--model: {}", e.what()));
    }
  }();
  for (const std::string& p : params) {
    try {
      model.SetParameter(std::string_view(p));
    } catch (const std::invalid_argument& e) {
      BadFlag(fmt::format("--param {}: {}", p, e.what()));
    }
  }
  return model;
}

void RequireFinite(const std::string& flag, const std::vector<double>& values) {
  for (double v : values) {
    if (!std::isfinite(v)) BadFlag(fmt::format("{} = {}: must be finite", flag, v));
  }
}

void SetPluginKinds(const std::string& estimator, const std::string& detector, IdentifierSettings* settings) {
  try {
    settings->flow_estimator.kind = settings->jump_estimator.kind = ParseEstimatorKind(estimator);
  } catch (const std::invalid_argument& e) {
    BadFlag(fmt::format("--estimator: {}", e.what()));
  }
  try {
    settings->detector.kind = ParseDetectorKind(detector);
  } catch (const std::invalid_argument& e) {
    BadFlag(fmt::format("--detector: {}", e.what()));
  }
}

Vec SigmaFlag(const std::vector<double>& values, int states) {
  RequireFinite("--sigma", values);
  Vec sigma(states);
  if (values.size() == 1) {
    sigma.setConstant(values[0]);
  } else if (static_cast<int>(values.size()) == states) {
    sigma = Eigen::Map<const Vec>(values.data(), states);
  } else {
    BadFlag(fmt::format("--sigma has {} values; give one, or one per state ({})", values.size(), states));
  }
  if ((sigma.array() < 0.0).any()) BadFlag(fmt::format("--sigma = {}: must be >= 0", fmt::join(values, ",")));
  return sigma;
}

}  // namespace hysid::cli
