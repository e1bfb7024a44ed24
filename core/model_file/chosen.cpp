#include "core/model_file/chosen.hpp"

#include <algorithm>
#include <cstdint>
#include <optional>
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

// A candidate's term as written (a string, an integer or a float).
std::string TermText(const toml::node& term) {
  if (const std::optional<std::int64_t> i = term.value_exact<std::int64_t>()) return fmt::format("{}", *i);
  return term.value<std::string>().value_or(fmt::format("{}", term.value_exact<double>().value_or(0.0)));
}

// Appends a candidate's term to a row of phi or psi as written (an integer beyond ±2^53 has no exact double).
void PushTerm(toml::array& row, const toml::node& term) {
  if (const std::optional<std::int64_t> i = term.value_exact<std::int64_t>()) row.push_back(*i);
  else if (term.is_string()) row.push_back(*term.value<std::string>());
  else row.push_back(term.value_exact<double>().value_or(0.0));
}

// The flow tables of the file ([flow], or each [[flow]]) and the prefix of their candidates' names
// ("" for [flow], "MODE_" for a [[flow]]).
std::vector<std::pair<toml::table*, std::string>> FlowTables(toml::table& root) {
  std::vector<std::pair<toml::table*, std::string>> out;
  if (toml::table* flow = root["flow"].as_table()) out.emplace_back(flow, "");
  if (toml::array* flows = root["flow"].as_array()) {
    for (toml::node& node : *flows) {
      toml::table* t = node.as_table();
      if (t == nullptr) continue;
      out.emplace_back(t, (*t)["mode"].value<std::string>().value_or("") + "_");
    }
  }
  return out;
}

// Appends one column to every table's `matrix` (the flows' phi, the [jump]'s psi): `term` in state `row`
// of `owner`, 0 elsewhere.
void AppendColumn(const std::vector<std::pair<toml::table*, std::string>>& flows, const toml::table* owner,
                  const toml::array& states, std::string_view row, const toml::node& term, const char* matrix = "phi") {
  for (const auto& [table, prefix] : flows) {
    toml::array* phi = (*table)[matrix].as_array();
    for (std::size_t s = 0; phi != nullptr && s < states.size() && s < phi->size(); ++s) {
      toml::array* phi_row = phi->get(s)->as_array();
      if (phi_row == nullptr) continue;
      if (table == owner && states.get(s)->value<std::string>() == std::string(row)) {
        PushTerm(*phi_row, term);
      } else {
        phi_row->push_back(0);
      }
    }
  }
}

// The jump tables with candidates: the [jump] (prefix "jump_", its β the file's `beta`) or each
// [[jump]] map (prefix "MAP_", its β the map's own `beta`), with the β list their kept candidates join.
struct JumpTable {
  toml::table* table;
  std::string prefix;
  toml::array* beta;
};
std::vector<JumpTable> JumpTables(toml::table& root) {
  std::vector<JumpTable> out;
  const auto add = [&](toml::table* t, std::string prefix, toml::array* beta) {
    if (t != nullptr && t->contains("candidates") && beta != nullptr) out.push_back({t, std::move(prefix), beta});
  };
  add(root["jump"].as_table(), "jump_", root["beta"].as_array());
  if (toml::array* maps = root["jump"].as_array()) {
    for (toml::node& node : *maps) {
      toml::table* t = node.as_table();
      if (t != nullptr) add(t, (*t)["name"].value<std::string>().value_or("") + "_", (*t)["beta"].as_array());
    }
  }
  return out;
}

// A jump table's candidates kept (`kept`, names PREFIX_ROW_K) as β entries (value 0) with their ψ
// columns (the term in its row, 0 elsewhere); their names go to `found`. The candidates are erased.
void KeepJumpCandidates(const JumpTable& jump, const toml::array& states, const std::vector<std::string>& kept,
                        std::vector<std::string>* found) {
  const toml::table* candidates = (*jump.table)["candidates"].as_table();
  const std::vector<std::pair<toml::table*, std::string>> table = {{jump.table, ""}};
  for (auto&& [row, list] : *candidates) {
    const toml::array* terms = list.as_array();
    for (std::size_t i = 0; terms != nullptr && i < terms->size(); ++i) {
      const std::string candidate = fmt::format("{}{}_{}", jump.prefix, row.str(), i + 1);
      if (std::find(kept.begin(), kept.end(), candidate) == kept.end()) continue;
      found->push_back(candidate);
      const toml::node& term = *terms->get(i);
      toml::table entry{{"name", candidate}, {"value", 0.0}};
      entry.insert("description", fmt::format("chosen candidate jump term {}", TermText(term)));
      entry.is_inline(true);
      jump.beta->push_back(std::move(entry));
      AppendColumn(table, jump.table, states, row.str(), term, "psi");
    }
  }
  jump.table->erase("candidates");
}

}  // namespace

std::string ChosenModelText(std::string_view text, const std::string& name, const std::vector<std::string>& kept,
                            const std::map<std::string, double>& values, const std::vector<std::string>& header) {
  toml::table root = ParseToml(text, name);
  const std::vector<std::pair<toml::table*, std::string>> flows = FlowTables(root);
  toml::array* states = root["states"].as_array();
  toml::array* alpha = root["alpha"].as_array();
  const std::vector<JumpTable> jumps = JumpTables(root);
  const bool any =
      std::any_of(flows.begin(), flows.end(), [](const auto& f) { return f.first->contains("candidates"); }) ||
      !jumps.empty();
  if (!any || states == nullptr || alpha == nullptr)
    throw std::invalid_argument(fmt::format("{}: no [flow], [[flow]], [jump] or [[jump]] table has candidates", name));
  std::vector<std::string> found;
  for (const JumpTable& jump : jumps) KeepJumpCandidates(jump, *states, kept, &found);
  for (const auto& [table, prefix] : flows) {
    const toml::table* candidates = (*table)["candidates"].as_table();
    if (candidates == nullptr) continue;
    for (auto&& [row, list] : *candidates) {
      const toml::array* terms = list.as_array();
      for (std::size_t i = 0; terms != nullptr && i < terms->size(); ++i) {
        const std::string candidate = fmt::format("{}{}_{}", prefix, row.str(), i + 1);
        if (std::find(kept.begin(), kept.end(), candidate) == kept.end()) continue;
        found.push_back(candidate);
        const toml::node& term = *terms->get(i);
        toml::table entry{{"name", candidate}, {"value", 0.0}};
        entry.insert("description", fmt::format("chosen candidate term {}", TermText(term)));
        entry.is_inline(true);
        alpha->push_back(std::move(entry));
        AppendColumn(flows, table, *states, row.str(), term);
        // The file's declaration was made without the term (the library's model is not declared constant).
        table->erase("jacobian_constant");
      }
    }
  }
  for (const std::string& k : kept) {
    if (std::find(found.begin(), found.end(), k) == found.end())
      throw std::invalid_argument(
          fmt::format("{}: '{}' is no candidate term of [flow], [[flow]], [jump] or [[jump]]", name, k));
  }
  for (const auto& [table, prefix] : flows) table->erase("candidates");
  SetValues(root, values);
  std::ostringstream out;
  for (const std::string& line : header) out << "# " << line << "\n";
  out << toml::toml_formatter(root) << "\n";
  return out.str();
}

}  // namespace hysid
