#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <utility>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/io/limits.hpp"
#include "experiments/cli/cli.hpp"
#include "sim/model_check/model_check.hpp"

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

Model MakeModel(const Environment& env, const ModelFlags& flags) {
  return MakeModel(env, flags.name, flags.file, flags.params);
}

void AddModelFlags(CLI::App& cmd, ModelFlags& flags, const std::string& param_help) {
  CLI::Option* model = cmd.add_option("--model", flags.name, "model name (see `hysid models`)");
  model->capture_default_str();
  cmd.add_option("--model-file", flags.file, "a model file (TOML, see models/*.toml) instead of --model")
      ->excludes(model);
  cmd.add_option("--param", flags.params, param_help);
}

void AddTrajectoryFlags(CLI::App& cmd, TrajectoryFlags& flags) {
  cmd.add_option("--x0", flags.x0, "initial state, comma-separated (default: the model's)")->delimiter(',');
  cmd.add_option("--t-end", flags.t_end, "horizon in seconds (default: the model's)");
  cmd.add_option("--dt", flags.dt, "sample time delta-t in seconds (default: the model's)");
}

SampleGrid GridFlag(const TrajectoryFlags& flags, const Model& model) {
  const ModelSpec& spec = model.spec();
  const SampleGrid grid{.t_end = flags.t_end.value_or(spec.default_t_end),
                        .dt = flags.dt.value_or(spec.default_dt)};
  for (const auto& [flag, v] : {std::pair{"--dt", grid.dt}, std::pair{"--t-end", grid.t_end}}) {
    if (!std::isfinite(v)) BadFlag(fmt::format("{} = {}: must be finite", flag, v));
    if (v <= 0) BadFlag(fmt::format("{} = {}: must be > 0", flag, v));
  }
  if (std::string e; !grid.IsValid(&e)) BadFlag(fmt::format("--t-end/--dt: {}", e));
  CheckLimit(kMaxSamples, static_cast<std::int64_t>(std::min(grid.t_end / grid.dt, 9e18)) + 1,
             fmt::format("--t-end {} / --dt {}", grid.t_end, grid.dt));
  return grid;
}

Vec InitialStateFlag(const TrajectoryFlags& flags, const Model& model) {
  const ModelSpec& spec = model.spec();
  const int n = model.state_size();
  Vec x0 = DefaultState(model);
  if (!flags.x0.empty()) {
    RequireFinite("--x0", flags.x0);
    if (static_cast<int>(flags.x0.size()) != n) {
      BadFlag(fmt::format("--x0 has {} values; model '{}' has {} states ({})", flags.x0.size(), spec.name, n,
                          fmt::join(spec.state_names, ", ")));
    }
    x0 = Eigen::Map<const Vec>(flags.x0.data(), n);
  }
  if (!model.InFlowSet(x0) && !model.InJumpSet(x0)) {
    BadFlag(fmt::format("--x0 = {}: outside the flow set C and the jump set D of '{}'", fmt::join(x0, ","),
                        spec.name));
  }
  return x0;
}

void RequireFinite(const std::string& flag, const std::vector<double>& values) {
  for (double v : values) {
    if (!std::isfinite(v)) BadFlag(fmt::format("{} = {}: must be finite", flag, v));
  }
}

void SetPluginKinds(const std::string& estimator, const std::string& detector, IdentifierSettings* settings) {
  try {
    settings->UseEstimator(ParseKind<EstimatorKind>(estimator));
  } catch (const std::invalid_argument& e) {
    BadFlag(fmt::format("--estimator: {}", e.what()));
  }
  try {
    settings->detector.kind = ParseKind<DetectorKind>(detector);
  } catch (const std::invalid_argument& e) {
    BadFlag(fmt::format("--detector: {}", e.what()));
  }
}

CLI::Option* AddSigmaOption(CLI::App& cmd, std::vector<double>& sigma, const std::string& help) {
  return cmd.add_option("--sigma", sigma, help)->delimiter(',');
}

void AddToleranceOptions(CLI::App& cmd, SimOptions& sim, const std::string& covers) {
  const std::string suffix = covers.empty() ? "" : " (" + covers + ")";
  cmd.add_option("--rtol", sim.rtol, "CVODE relative tolerance" + suffix)->capture_default_str();
  cmd.add_option("--atol", sim.atol, "CVODE absolute tolerance" + suffix)->capture_default_str();
}

Vec SigmaFlag(const std::vector<double>& values, int states, bool allow_zero) {
  RequireFinite("--sigma", values);
  Vec sigma(states);
  if (values.size() == 1) {
    sigma.setConstant(values[0]);
  } else if (static_cast<int>(values.size()) == states) {
    sigma = Eigen::Map<const Vec>(values.data(), states);
  } else {
    BadFlag(fmt::format("--sigma has {} values; give one, or one per state ({})", values.size(), states));
  }
  if (allow_zero ? (sigma.array() < 0.0).any() : (sigma.array() <= 0.0).any()) {
    BadFlag(fmt::format("--sigma = {}: must be {} 0", fmt::join(values, ","), allow_zero ? ">=" : ">"));
  }
  return sigma;
}

}  // namespace hysid::cli
