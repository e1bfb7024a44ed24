// Typed values out of a parsed TOML document, for every kind of TOML file hysid reads (sweep files,
// model files): one wording per violation, and every message "FILE:LINE: KEY: problem" ("FILE: KEY:
// problem" for a key missing from the top level, which has no line of its own). Keys are dotted
// paths with indices: "grid.dt", "alpha[1].value", "flow.phi[1][0]".
//
//   wrong type     "expected a number, got a string"
//   unknown key    "unknown key (known here: a, b, c)"
//   missing key    "missing" or "missing: HINT"
//   out of range   "-1 must be > 0", "0 must be ≥ 1", "4294967296 must be ≤ 2147483647", "nan must be finite"
//   wrong length   "has 3 entries, expected 2 (one per state)"
//   empty          "empty: give at least one value"
//   unknown name   "unknown state 'w' (known: x, v)"
//   repeated       "'x' appears twice", "0.001 appears twice"
//   exclusive      "give x0 or x0_range, not both"
#pragma once

#include <cstdint>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "core/io/toml_guard.hpp"

namespace hysid {

class TomlReader {
 public:
  explicit TomlReader(std::string file) : file_(std::move(file)) {}
  const std::string& file() const { return file_; }

  // The line a node starts on (0 for none).
  static long Line(const toml::node* node) { return node ? static_cast<long>(node->source().begin.line) : 0; }
  // "FILE:LINE: KEY", or "FILE: KEY" without a line: the start of every message (and of the
  // CheckLimit context, core/io/limits.hpp).
  std::string Where(const toml::node* node, std::string_view key) const;
  // Throws std::invalid_argument "Where(node, key): what".
  [[noreturn]] void Fail(const toml::node* node, std::string_view key, std::string_view what) const;

  // "prefix.key" ("key" for the top level) and "key[i]".
  static std::string Join(std::string_view prefix, std::string_view key);
  static std::string Index(std::string_view key, std::size_t i);
  // "a table", "a list", "a string", "an integer", "a number", "a boolean", "a date/time".
  static std::string TypeName(const toml::node& node);

  // Every key of `table` (at `prefix`) must be one of `known`.
  void OnlyKeys(const toml::table& table, std::string_view prefix,
                const std::vector<std::string>& known) const;
  // table[key], else "missing" (with ": hint" when given). `prefix` empty: the top level.
  const toml::node& Require(const toml::table& table, std::string_view prefix, std::string_view key,
                            std::string_view hint = {}) const;
  // At most one of the two keys.
  void NotBoth(const toml::table& table, std::string_view prefix, std::string_view a,
               std::string_view b) const;

  // Typed values (inline tables are tables).
  std::string String(const toml::node& node, std::string_view key) const;
  double Number(const toml::node& node, std::string_view key) const;  // an integer (its nearest double) or a float, finite
  std::int64_t Integer(const toml::node& node, std::string_view key,
                       std::int64_t lo = std::numeric_limits<std::int64_t>::min(),
                       std::int64_t hi = std::numeric_limits<std::int64_t>::max()) const;
  bool Boolean(const toml::node& node, std::string_view key) const;
  const toml::table& Table(const toml::node& node, std::string_view key) const;
  const toml::array& Array(const toml::node& node, std::string_view key) const;
  std::vector<double> Numbers(const toml::node& node, std::string_view key) const;  // a list of numbers

  // Constraints on a value read: each fails with the wording above.
  void Above(const toml::node* node, std::string_view key, double value, double bound) const;    // >
  void AtLeast(const toml::node* node, std::string_view key, double value, double bound) const;  // ≥
  void Size(const toml::node* node, std::string_view key, std::size_t size, std::size_t expected,
            std::string_view per) const;
  void NotEmpty(const toml::node* node, std::string_view key, std::size_t size, std::string_view what) const;
  // The position of `name` in `known`, else "unknown WHAT 'name' (known: ...)".
  std::size_t Choice(const toml::node* node, std::string_view key, std::string_view what,
                     const std::string& name, const std::vector<std::string>& known) const;
  // "VALUE appears twice" (VALUE as the caller quotes it).
  [[noreturn]] void Twice(const toml::node* node, std::string_view key, std::string_view value) const;

 private:
  [[noreturn]] void WrongType(const toml::node& node, std::string_view key, std::string_view expected) const;
  std::string file_;
};

}  // namespace hysid
