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

bool DetectorDescriptor::Reads(std::string_view option) const {
  return std::find(options.begin(), options.end(), option) != options.end();
}

const std::vector<const DetectorDescriptor*>& DetectorDescriptors() {
  static const std::vector<const DetectorDescriptor*> all{&PaperDetectorDescriptor(), &ResidualDetectorDescriptor()};
  return all;
}

const DetectorDescriptor& DescriptorOf(DetectorKind kind) {
  for (const DetectorDescriptor* d : DetectorDescriptors()) {
    if (d->kind == kind) return *d;
  }
  throw std::invalid_argument(fmt::format("DetectorKind {}: no such detector", static_cast<int>(kind)));
}

std::vector<std::string> DetectorNames() {
  std::vector<std::string> names;
  for (const DetectorDescriptor* d : DetectorDescriptors()) names.emplace_back(d->name);
  return names;
}

DetectorKind ParseDetectorKind(std::string_view name) {
  for (const DetectorDescriptor* d : DetectorDescriptors()) {
    if (d->name == name) return d->kind;
  }
  throw std::invalid_argument(
      fmt::format("unknown detector '{}' (known: {})", name, fmt::join(DetectorNames(), ", ")));
}

std::string_view ToString(DetectorKind kind) { return DescriptorOf(kind).name; }

std::unique_ptr<JumpDetector> MakeDetector(const DetectorSettings& settings, const Model& model) {
  const DetectorDescriptor& d = DescriptorOf(settings.kind);
  std::string error;
  if (!settings.IsValid(&error)) throw std::invalid_argument(fmt::format("detector '{}': {}", d.name, error));
  return d.make(settings, model);
}

}  // namespace hysid
