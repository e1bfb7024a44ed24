#include "core/model/registry.hpp"

#include <stdexcept>

#include <fmt/format.h>
#include <fmt/ranges.h>

namespace hysid {

void ModelRegistry::Register(const std::string& name, Factory factory) {
  if (!factories_.emplace(name, std::move(factory)).second) {
    throw std::invalid_argument(fmt::format("model '{}' is registered twice", name));
  }
}

Model ModelRegistry::Make(std::string_view name) const {
  const auto it = factories_.find(name);
  if (it == factories_.end()) {
    throw std::invalid_argument(
        fmt::format("unknown model '{}' (known: {})", name, fmt::join(names(), ", ")));
  }
  return it->second();
}

bool ModelRegistry::Contains(std::string_view name) const { return factories_.contains(name); }

std::vector<std::string> ModelRegistry::names() const {
  std::vector<std::string> out;
  for (const auto& [name, factory] : factories_) out.push_back(name);
  return out;
}

}  // namespace hysid
