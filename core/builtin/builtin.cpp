#include "core/builtin/builtin.hpp"

#include <stdexcept>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "core/builtin/bouncing_ball.hpp"
#include "core/builtin/impact_msd.hpp"
#include "core/builtin/impact_pendulum.hpp"
#include "core/builtin/model_texts.hpp"
#include "core/builtin/spec.hpp"
#include "core/model_file/model_file.hpp"

namespace hysid {

const ModelSpec& BuiltinSpec(std::string_view name) {
  static const std::vector<ModelSpec> specs = [] {
    std::vector<ModelSpec> out;
    for (const internal::ModelText& m : internal::BuiltinModelTexts()) {
      const std::string file = fmt::format("models/{}.toml", m.name);
      out.push_back(ParseModelFile(m.text, file, /*shipped=*/true).model.spec());
    }
    return out;
  }();
  for (const ModelSpec& spec : specs) {
    if (spec.name == name) return spec;
  }
  throw std::invalid_argument(fmt::format("no built-in model '{}'", name));
}

void RegisterBuiltinModels(ModelRegistry& registry) {
  registry.Register(ImpactMsd{});
  registry.Register(BouncingBall{});
  registry.Register(ImpactPendulum{});
}

}  // namespace hysid
