#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

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

}  // namespace hysid::cli
