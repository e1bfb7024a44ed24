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

bool DetectorDescriptor::Reads(std::string_view option) const { return ReadsOption(options, option); }

const std::vector<const DetectorDescriptor*>& DetectorDescriptors() {
  static const std::vector<const DetectorDescriptor*> all{&PaperDetectorDescriptor(),
                                                          &ResidualDetectorDescriptor()};
  return all;
}

const DetectorDescriptor& DescriptorOf(DetectorKind kind) {
  return FindDescriptor(DetectorDescriptors(), kind, "detector");
}

std::vector<std::string> DetectorNames() { return DescriptorNames(DetectorDescriptors()); }

DetectorKind ParseDetectorKind(std::string_view name) {
  return ParseKind(DetectorDescriptors(), name, "detector");
}

std::string_view ToString(DetectorKind kind) { return DescriptorOf(kind).name; }

std::unique_ptr<JumpDetector> MakeDetector(const DetectorSettings& settings, const Model& model) {
  const DetectorDescriptor& d = DescriptorOf(settings.kind);
  std::string error;
  if (!settings.IsValid(&error)) throw std::invalid_argument(fmt::format("detector '{}': {}", d.name, error));
  return d.make(settings, model);
}

}  // namespace hysid
