#include "core/io/toml_reader.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <fmt/format.h>
#include <fmt/ranges.h>

namespace hysid {

std::string TomlReader::Where(const toml::node* node, std::string_view key) const {
  const long line = Line(node);
  if (line > 0) return fmt::format("{}:{}: {}", file_, line, key);
  return fmt::format("{}: {}", file_, key);
}

void TomlReader::Fail(const toml::node* node, std::string_view key, std::string_view what) const {
  throw std::invalid_argument(fmt::format("{}: {}", Where(node, key), what));
}

std::string TomlReader::Join(std::string_view prefix, std::string_view key) {
  return prefix.empty() ? std::string(key) : fmt::format("{}.{}", prefix, key);
}

std::string TomlReader::Index(std::string_view key, std::size_t i) { return fmt::format("{}[{}]", key, i); }

std::string TomlReader::TypeName(const toml::node& node) {
  switch (node.type()) {
    case toml::node_type::table: return "a table";
    case toml::node_type::array: return "a list";
    case toml::node_type::string: return "a string";
    case toml::node_type::integer: return "an integer";
    case toml::node_type::floating_point: return "a number";
    case toml::node_type::boolean: return "a boolean";
    default: return "a date/time";
  }
}

void TomlReader::WrongType(const toml::node& node, std::string_view key, std::string_view expected) const {
  Fail(&node, key, fmt::format("expected {}, got {}", expected, TypeName(node)));
}

void TomlReader::OnlyKeys(const toml::table& table, std::string_view prefix,
                          const std::vector<std::string>& known) const {
  for (auto&& [k, v] : table) {
    if (std::find(known.begin(), known.end(), k.str()) == known.end())
      Fail(&v, Join(prefix, k.str()), fmt::format("unknown key (known here: {})", fmt::join(known, ", ")));
  }
}

const toml::node& TomlReader::Require(const toml::table& table, std::string_view prefix, std::string_view key,
                                      std::string_view hint) const {
  const toml::node* n = table.get(key);
  if (!n) {
    // The top level starts on line 1 whatever it holds: no line is better than a wrong one.
    Fail(prefix.empty() ? nullptr : &table, Join(prefix, key),
         hint.empty() ? std::string("missing") : fmt::format("missing: {}", hint));
  }
  return *n;
}

void TomlReader::NotBoth(const toml::table& table, std::string_view prefix, std::string_view a,
                         std::string_view b) const {
  if (table.contains(a) && table.contains(b))
    Fail(table.get(b), Join(prefix, b), fmt::format("give {} or {}, not both", a, b));
}

std::string TomlReader::String(const toml::node& node, std::string_view key) const {
  if (!node.is_string()) WrongType(node, key, "a string");
  return *node.value<std::string>();
}

double TomlReader::Number(const toml::node& node, std::string_view key) const {
  if (!node.is_number()) WrongType(node, key, "a number");
  // An integer beyond ±2^53 has no exact double (toml++'s value<double>() gives none): its nearest one.
  const double v = node.is_integer() ? static_cast<double>(*node.value_exact<std::int64_t>()) : *node.value_exact<double>();
  if (!std::isfinite(v)) Fail(&node, key, fmt::format("{} must be finite", v));
  return v;
}

std::int64_t TomlReader::Integer(const toml::node& node, std::string_view key, std::int64_t lo,
                                 std::int64_t hi) const {
  if (!node.is_integer()) WrongType(node, key, "an integer");
  const std::int64_t v = *node.value_exact<std::int64_t>();
  if (v < lo) Fail(&node, key, fmt::format("{} must be ≥ {}", v, lo));
  if (v > hi) Fail(&node, key, fmt::format("{} must be ≤ {}", v, hi));
  return v;
}

bool TomlReader::Boolean(const toml::node& node, std::string_view key) const {
  if (!node.is_boolean()) WrongType(node, key, "true or false");
  return *node.value<bool>();
}

const toml::table& TomlReader::Table(const toml::node& node, std::string_view key) const {
  if (!node.is_table()) WrongType(node, key, "a table");
  return *node.as_table();
}

const toml::array& TomlReader::Array(const toml::node& node, std::string_view key) const {
  if (!node.is_array()) WrongType(node, key, "a list");
  return *node.as_array();
}

std::vector<double> TomlReader::Numbers(const toml::node& node, std::string_view key) const {
  if (!node.is_array()) WrongType(node, key, "a list of numbers");
  const toml::array& arr = *node.as_array();
  std::vector<double> out;
  for (std::size_t i = 0; i < arr.size(); ++i) out.push_back(Number(arr[i], Index(key, i)));
  return out;
}

void TomlReader::Above(const toml::node* node, std::string_view key, double value, double bound) const {
  if (!(value > bound)) Fail(node, key, fmt::format("{} must be > {}", value, bound));
}

void TomlReader::AtLeast(const toml::node* node, std::string_view key, double value, double bound) const {
  if (!(value >= bound)) Fail(node, key, fmt::format("{} must be ≥ {}", value, bound));
}

void TomlReader::Size(const toml::node* node, std::string_view key, std::size_t size, std::size_t expected,
                      std::string_view per) const {
  if (size != expected) Fail(node, key, fmt::format("has {} entries, expected {} ({})", size, expected, per));
}

void TomlReader::NotEmpty(const toml::node* node, std::string_view key, std::size_t size,
                          std::string_view what) const {
  if (size == 0) Fail(node, key, fmt::format("empty: give at least one {}", what));
}

std::size_t TomlReader::Choice(const toml::node* node, std::string_view key, std::string_view what,
                               const std::string& name, const std::vector<std::string>& known) const {
  const auto it = std::find(known.begin(), known.end(), name);
  if (it == known.end())
    Fail(node, key, fmt::format("unknown {} '{}' (known: {})", what, name, fmt::join(known, ", ")));
  return static_cast<std::size_t>(it - known.begin());
}

void TomlReader::Twice(const toml::node* node, std::string_view key, std::string_view value) const {
  Fail(node, key, fmt::format("{} appears twice", value));
}

}  // namespace hysid
