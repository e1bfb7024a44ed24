// Models by name. A registry is an ordinary object: the command line builds one and fills it with
// RegisterBuiltinModels (core/builtin/builtin.hpp); a program that adds its own model calls Register itself.
#pragma once

#include <functional>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "core/model/model.hpp"

namespace hysid {

class ModelRegistry {
 public:
  using Factory = std::function<Model()>;
  // Throws std::invalid_argument when the name is taken.
  void Register(const std::string& name, Factory factory);
  template <HybridModel M>
  void Register(M prototype) {
    Model model(prototype);
    Register(model.name(), [model] { return model; });
  }
  // Throws std::invalid_argument naming the known models when `name` is unknown.
  Model Make(std::string_view name) const;
  bool Contains(std::string_view name) const;
  std::vector<std::string> names() const;

 private:
  std::map<std::string, Factory, std::less<>> factories_;
};

}  // namespace hysid
