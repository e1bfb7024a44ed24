#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

#include "core/model_file/model_file.hpp"
#include "experiments/cli/cli.hpp"

namespace hysid::cli {

void BadFlag(const std::string& what) { throw std::invalid_argument(what); }

Model MakeModel(const Environment& env, const std::string& name,
                const std::vector<std::string>& params) {
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
  CLI::Option* opt = cmd.add_option("--model-file", file, "a model file (TOML, see models/*.toml) instead of --model");
  if (CLI::Option* model = cmd.get_option_no_throw("--model")) opt->excludes(model);
}

void RequireFinite(const std::string& flag, const std::vector<double>& values) {
  for (double v : values) {
    if (!std::isfinite(v)) BadFlag(fmt::format("{} = {}: must be finite", flag, v));
  }
}

}  // namespace hysid::cli
