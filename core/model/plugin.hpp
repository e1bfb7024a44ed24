// Plugin families (estimators, detectors) described as data. A plugin is a PluginDescriptor: its
// name, help, the options it reads, what its family adds, and its factory. A family is the
// PluginList that `Plugins(kind)` returns for its Kind type, one descriptor per enumerator of Kind
// in enumerator order (the enumerators are 0, 1, ...); the look-ups below serve every family
// (docs/architecture.md, "Estimator and detector descriptors").
#pragma once

#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace hysid {

// One plugin of the family with enumerators `Kind` (its kind is its place in the family's list).
// `traits` holds what the family adds (an estimator's needs, a detector's trace columns); `make`
// builds the plugin from checked settings.
template <class Kind, class Traits, class Make>
struct PluginDescriptor {
  std::string_view name;                  // as given on the command line and in sweep files
  std::string_view help;                  // one line
  std::vector<std::string_view> options;  // the family's options (EstimatorOptions()...) it reads
  Traits traits{};
  Make make = nullptr;

  bool Reads(std::string_view option) const {
    for (std::string_view o : options) {
      if (o == option) return true;
    }
    return false;
  }
};

// A family: its name in errors ("estimator") and every plugin, in the order of its Kind.
template <class Descriptor>
struct PluginList {
  std::string_view family;
  std::vector<Descriptor> all;
};

// A Kind whose family is declared as `const PluginList<...>& Plugins(Kind)` (found by its type).
template <class Kind>
concept PluginKind = requires(Kind kind) {
  Plugins(kind).all;
};

// Every plugin of Kind's family, in the order of Kind.
template <PluginKind Kind>
const auto& AllPlugins() {
  return Plugins(Kind{}).all;
}

// The descriptor of `kind`; throws std::invalid_argument "FAMILY kind N: no such FAMILY".
template <PluginKind Kind>
const auto& DescriptorOf(Kind kind) {
  const auto& list = Plugins(kind);
  const auto index = static_cast<std::size_t>(kind);
  if (index < list.all.size()) return list.all[index];
  const std::string family(list.family);
  throw std::invalid_argument(family + " kind " + std::to_string(static_cast<int>(kind)) + ": no such " +
                              family);
}

template <PluginKind Kind>
std::string_view ToString(Kind kind) {
  return DescriptorOf(kind).name;
}

template <PluginKind Kind>
std::vector<std::string> PluginNames() {
  std::vector<std::string> names;
  for (const auto& d : AllPlugins<Kind>()) names.emplace_back(d.name);
  return names;
}

// The kind named `name`; throws std::invalid_argument "unknown FAMILY 'x' (known: a, b)".
template <PluginKind Kind>
Kind ParseKind(std::string_view name) {
  const auto& list = Plugins(Kind{});
  std::string known;
  for (std::size_t i = 0; i < list.all.size(); ++i) {
    if (list.all[i].name == name) return static_cast<Kind>(i);
    known += (known.empty() ? "" : ", ") + std::string(list.all[i].name);
  }
  throw std::invalid_argument("unknown " + std::string(list.family) + " '" + std::string(name) +
                              "' (known: " + known + ")");
}

// The plugin settings.kind names, built by its factory from `settings` and `args`; first checks
// settings.IsValid and throws std::invalid_argument "FAMILY 'name': error" when they are not.
template <class Settings, class... Args>
auto MakePlugin(const Settings& settings, const Args&... args) {
  const auto& d = DescriptorOf(settings.kind);
  std::string error;
  if (!settings.IsValid(&error)) {
    throw std::invalid_argument(std::string(Plugins(settings.kind).family) + " '" + std::string(d.name) +
                                "': " + error);
  }
  return d.make(settings, args...);
}

}  // namespace hysid
