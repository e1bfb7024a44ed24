#include "core/detectors/detector.hpp"

#include <algorithm>
#include <stdexcept>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/detectors/paper.hpp"
#include "core/detectors/residual.hpp"

namespace hysid {

bool DetectorSettings::IsValid(std::string* error) const {
  return CheckOptions(DetectorOptions(), *this, error);
}

const PluginList<DetectorDescriptor>& Plugins(DetectorKind) {
  static const PluginList<DetectorDescriptor> list{"detector",
                                                   {PaperDetectorDescriptor(), ResidualDetectorDescriptor()}};
  return list;
}

std::unique_ptr<JumpDetector> MakeDetector(const DetectorSettings& settings, const Model& model) {
  return MakePlugin(settings, model);
}

}  // namespace hysid
