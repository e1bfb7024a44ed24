#include "core/model_file/input_defaults.hpp"

#include <cmath>
#include <stdexcept>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <muParser.h>

namespace hysid {

std::string InputsWithoutDefault(const ModelSpec& spec) {
  std::vector<std::string> missing;
  for (std::size_t i = 0; i < spec.inputs.size(); ++i) {
    if (i >= spec.input_defaults.size() || spec.input_defaults[i].empty()) missing.push_back(spec.inputs[i]);
  }
  return fmt::format("{}", fmt::join(missing, ", "));
}

Mat EvaluateInputDefaults(const ModelSpec& spec, const std::vector<double>& times) {
  const auto m = static_cast<Eigen::Index>(spec.inputs.size());
  Mat u(m, static_cast<Eigen::Index>(times.size()));
  for (Eigen::Index i = 0; i < m; ++i) {
    const std::string& name = spec.inputs[static_cast<std::size_t>(i)];
    const std::string key = fmt::format("input_defaults.{}", name);
    const auto at = static_cast<std::size_t>(i);
    if (at >= spec.input_defaults.size() || spec.input_defaults[at].empty()) {
      throw std::invalid_argument(
          fmt::format("{}: the model gives no default for the input '{}'", key, name));
    }
    double t = 0.0;
    mu::Parser p;
    try {
      p.DefineVar("t", &t);
      p.SetExpr(spec.input_defaults[at]);
      for (std::size_t k = 0; k < times.size(); ++k) {
        t = times[k];
        u(i, static_cast<Eigen::Index>(k)) = p.Eval();
        if (!std::isfinite(u(i, static_cast<Eigen::Index>(k)))) {
          throw std::invalid_argument(fmt::format("{} = \"{}\" is {} at t = {}: an input must be finite", key,
                                                  spec.input_defaults[at], u(i, static_cast<Eigen::Index>(k)),
                                                  t));
        }
      }
    } catch (const mu::Parser::exception_type& e) {
      throw std::invalid_argument(fmt::format("{} = \"{}\": {}", key, spec.input_defaults[at], e.GetMsg()));
    }
  }
  return u;
}

}  // namespace hysid
