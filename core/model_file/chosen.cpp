#include "core/model_file/chosen.hpp"

#include <algorithm>
#include <sstream>
#include <stdexcept>

#include <fmt/format.h>

#include "core/io/toml_guard.hpp"

namespace hysid {
namespace {

// Every parameter table of the file (alpha, beta, guard_params, jump[m].beta) whose name is in
// `values` takes that value.
void SetValues(toml::table& root, const std::map<std::string, double>& values) {
  auto set = [&](toml::node* list) {
    if (list == nullptr || !list->is_array()) return;
    for (toml::node& entry : *list->as_array()) {
      toml::table* t = entry.as_table();
      if (t == nullptr) continue;
      const std::optional<std::string> name = (*t)["name"].value<std::string>();
      if (!name) continue;
      if (const auto at = values.find(*name); at != values.end()) t->insert_or_assign("value", at->second);
    }
  };
  for (const char* key : {"alpha", "beta", "guard_params"}) set(root.get(key));
  if (toml::array* maps = root["jump"].as_array()) {
    for (toml::node& map : *maps) {
      if (toml::table* t = map.as_table()) set(t->get("beta"));
    }
  }
}

}  // namespace

std::string ChosenModelText(std::string_view text, const std::string& name, const std::vector<std::string>& kept,
                            const std::map<std::string, double>& values, const std::vector<std::string>& header) {
  toml::table root = ParseToml(text, name);
  toml::table* flow = root["flow"].as_table();
  toml::table* candidates = flow != nullptr ? (*flow)["candidates"].as_table() : nullptr;
  toml::array* states = root["states"].as_array();
  toml::array* phi = flow != nullptr ? (*flow)["phi"].as_array() : nullptr;
  toml::array* alpha = root["alpha"].as_array();
  if (candidates == nullptr || states == nullptr || phi == nullptr || alpha == nullptr)
    throw std::invalid_argument(fmt::format("{}: [flow] has no candidates", name));
  std::vector<std::string> found;
  for (auto&& [row, list] : *candidates) {
    const toml::array* terms = list.as_array();
    for (std::size_t i = 0; terms != nullptr && i < terms->size(); ++i) {
      const std::string candidate = fmt::format("{}_{}", row.str(), i + 1);
      if (std::find(kept.begin(), kept.end(), candidate) == kept.end()) continue;
      found.push_back(candidate);
      const toml::node& term = *terms->get(i);
      toml::table entry{{"name", candidate}, {"value", 0.0}};
      entry.insert("description", fmt::format("chosen candidate term {}", term.value<std::string>().value_or(
                                                                              fmt::format("{}", term.value<double>().value_or(0.0)))));
      entry.is_inline(true);
      alpha->push_back(std::move(entry));
      for (std::size_t s = 0; s < states->size() && s < phi->size(); ++s) {
        toml::array* phi_row = phi->get(s)->as_array();
        if (phi_row == nullptr) continue;
        if (states->get(s)->value<std::string>() == std::string(row.str())) {
          if (term.is_string()) phi_row->push_back(*term.value<std::string>());
          else phi_row->push_back(term.value<double>().value_or(0.0));
        } else {
          phi_row->push_back(0);
        }
      }
    }
  }
  for (const std::string& k : kept) {
    if (std::find(found.begin(), found.end(), k) == found.end())
      throw std::invalid_argument(fmt::format("{}: '{}' is no candidate term of [flow]", name, k));
  }
  flow->erase("candidates");
  SetValues(root, values);
  std::ostringstream out;
  for (const std::string& line : header) out << "# " << line << "\n";
  out << toml::toml_formatter(root) << "\n";
  return out.str();
}

}  // namespace hysid
