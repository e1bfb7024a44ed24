#include "core/detectors/detector.hpp"

#include <cmath>
#include <stdexcept>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/detectors/paper.hpp"
#include "core/detectors/residual.hpp"

namespace hysid {

bool DetectorSettings::IsValid(std::string* error) const {
  auto fail = [&](std::string message) {
    if (error) *error = std::move(message);
    return false;
  };
  if (!(r > 1.0) || !std::isfinite(r)) return fail(fmt::format("r = {}: must be > 1", r));
  if (!(tau0 > 0.0) || !std::isfinite(tau0)) {
    return fail(fmt::format("tau0 = {}: must be > 0", tau0));
  }
  if (bound != "auto" && bound != "paper" && bound != "homogeneous") {
    return fail(fmt::format("bound = '{}': must be one of auto, paper, homogeneous", bound));
  }
  if (!(false_alarm > 0.0 && false_alarm < 0.5)) {
    return fail(fmt::format("false_alarm = {}: must be in (0, 0.5)", false_alarm));
  }
  return true;
}

std::vector<std::string> DetectorNames() { return {"paper", "residual"}; }

std::unique_ptr<JumpDetector> MakeDetector(const DetectorSettings& settings, const Model& model) {
  std::string error;
  if (!settings.IsValid(&error)) {
    throw std::invalid_argument(fmt::format("detector '{}': {}", settings.name, error));
  }
  if (settings.name == "paper") return std::make_unique<PaperDetector>(settings, model);
  if (settings.name == "residual") return std::make_unique<ResidualDetector>(settings, model);
  throw std::invalid_argument(fmt::format("unknown detector '{}' (known: {})", settings.name,
                                          fmt::join(DetectorNames(), ", ")));
}

}  // namespace hysid
