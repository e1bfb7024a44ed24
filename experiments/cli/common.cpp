#include <cmath>
#include <stdexcept>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/model_file/model_file.hpp"
#include "experiments/cli/cli.hpp"

namespace hysid::cli {

void BadFlag(const std::string& what) { throw std::invalid_argument(what); }

Model MakeModel(const Environment& env, const std::string& name, const std::vector<std::string>& params) {
  return MakeModel(env, name, "", params);
}

Model MakeModel(const Environment& env, const std::string& name, const std::string& file,
                const std::vector<std::string>& params) {
  Model model = [&] {
    try {
      return file.empty() ? env.models.Make(name) : LoadModelFile(file);
    } catch (const std::invalid_argument& e) {
      BadFlag(fmt::format("{}: {}", file.empty() ? "--model" : "--model-file", e.what()));
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

void AddModelFileOption(CLI::App& cmd, std::string& file) {
  CLI::Option* opt =
      cmd.add_option("--model-file", file, "a model file (TOML, see models/*.toml) instead of --model");
  if (CLI::Option* model = cmd.get_option_no_throw("--model")) opt->excludes(model);
}

void RequireFinite(const std::string& flag, const std::vector<double>& values) {
  for (double v : values) {
    if (!std::isfinite(v)) BadFlag(fmt::format("{} = {}: must be finite", flag, v));
  }
}

void SetPluginKinds(const std::string& estimator, const std::string& detector, IdentifierSettings* settings) {
  try {
    settings->UseEstimator(ParseEstimatorKind(estimator));
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
