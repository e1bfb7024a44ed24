// Options of a plugin (estimator, detector) described once, as data: name, type, validator, help,
// whether a sweep may vary it, and how to read and write the field of the settings struct. The command
// line, sweep files, sweep columns and validation are generated from these tables
// (docs/architecture.md, "Estimator and detector descriptors").
#pragma once

#include <limits>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

namespace hysid {

enum class OptionType { kReal, kInteger, kChoice };

inline constexpr double kUnbounded = std::numeric_limits<double>::infinity();

// An interval of allowed values; open or closed at each end, unbounded when infinite.
struct Interval {
  double lo, hi;
  bool lo_open = false, hi_open = false;
  bool Contains(double v) const;
  std::string ToString() const;  // "must be > 1", "must be in (0, 1]", "must be >= 0"
};

// One field of a settings struct S. The value travels as a double (a choice as its enumerator's index).
template <class S>
struct Option {
  std::string_view name{};  // the field's name: TOML key; the flag is "--" + name with '-' for '_'
  OptionType type = OptionType::kReal;      // Describe sets it from the field's type
  Interval range{};                         // kReal, kInteger
  std::vector<std::string_view> choices{};  // kChoice: the enumerators' names, in enumerator order
  std::string_view help{};
  bool sweepable = false;  // a sweep grid may give a list of values
  double (*get)(const S&) = nullptr;
  void (*set)(S&, double) = nullptr;

  // "" when v is allowed, else the constraint: "must be in (0, 1]", "must be one of a, b".
  std::string Check(double v) const;
  // The value as text: %g-style number or the choice's name.
  std::string Format(double v) const;
  // Parses text (a number, or a choice's name); throws std::invalid_argument "NAME = 'TEXT': ...".
  double Parse(std::string_view text) const;
  // Checks v; throws std::invalid_argument "NAME = V: constraint".
  void Require(double v) const;
};

// Getter and setter of the member M (a double, int or enum field) for Option::get / Option::set.
template <auto M>
struct Field;
template <class S, class T, T S::*M>
struct Field<M> {
  using Settings = S;
  // An enum is a choice among its enumerators, an integral type an integer, anything else real.
  static constexpr OptionType kType = std::is_enum_v<T>       ? OptionType::kChoice
                                      : std::is_integral_v<T> ? OptionType::kInteger
                                                              : OptionType::kReal;
  static double Get(const S& s) {
    if constexpr (std::is_enum_v<T>) {
      return static_cast<double>(static_cast<int>(s.*M));
    } else {
      return static_cast<double>(s.*M);
    }
  }
  static void Set(S& s, double v) {
    if constexpr (std::is_enum_v<T>) {
      s.*M = static_cast<T>(static_cast<int>(v));
    } else {
      s.*M = static_cast<T>(v);
    }
  }
};

// The option `o` with its type, get and set taken from the member M:
//   Describe<&DetectorSettings::r>({.name = "r", .range = {1, kUnbounded, true, true}, ...}).
template <auto M>
Option<typename Field<M>::Settings> Describe(Option<typename Field<M>::Settings> o) {
  o.type = Field<M>::kType;
  o.get = &Field<M>::Get;
  o.set = &Field<M>::Set;
  return o;
}

// Validates every option of `table` on `settings`; on failure writes "NAME = V: constraint".
template <class S>
bool CheckOptions(const std::vector<Option<S>>& table, const S& settings, std::string* error) {
  for (const Option<S>& o : table) {
    const double v = o.get(settings);
    if (std::string c = o.Check(v); !c.empty()) {
      if (error) *error = std::string(o.name) + " = " + o.Format(v) + ": " + c;
      return false;
    }
  }
  return true;
}

// The option named `name`, or nullptr.
template <class S>
const Option<S>* FindOption(const std::vector<Option<S>>& table, std::string_view name) {
  for (const Option<S>& o : table) {
    if (o.name == name) return &o;
  }
  return nullptr;
}

// "--frisch-box" for "frisch_box" (with an optional prefix: "--jump-frisch-box").
std::string FlagName(std::string_view name, std::string_view prefix = {});

namespace detail {
std::string CheckValue(OptionType type, const Interval& range, const std::vector<std::string_view>& choices,
                       double v);
std::string FormatValue(OptionType type, const std::vector<std::string_view>& choices, double v);
double ParseValue(std::string_view name, OptionType type, const std::vector<std::string_view>& choices,
                  std::string_view text);
[[noreturn]] void ThrowInvalid(std::string_view name, const std::string& value, const std::string& what);
}  // namespace detail

template <class S>
std::string Option<S>::Check(double v) const {
  return detail::CheckValue(type, range, choices, v);
}
template <class S>
std::string Option<S>::Format(double v) const {
  return detail::FormatValue(type, choices, v);
}
template <class S>
double Option<S>::Parse(std::string_view text) const {
  const double v = detail::ParseValue(name, type, choices, text);
  Require(v);
  return v;
}
template <class S>
void Option<S>::Require(double v) const {
  if (std::string c = Check(v); !c.empty()) detail::ThrowInvalid(name, Format(v), c);
}

}  // namespace hysid
