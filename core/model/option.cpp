#include "core/model/option.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <fmt/format.h>
#include <fmt/ranges.h>

namespace hysid {

bool Interval::Contains(double v) const {
  if (!std::isfinite(v)) return false;
  const bool above = lo_open ? v > lo : v >= lo;
  const bool below = hi_open ? v < hi : v <= hi;
  return above && below;
}

std::string Interval::ToString() const {
  const bool has_lo = std::isfinite(lo), has_hi = std::isfinite(hi);
  if (has_lo && !has_hi) return fmt::format("must be {} {}", lo_open ? ">" : ">=", lo);
  if (!has_lo && has_hi) return fmt::format("must be {} {}", hi_open ? "<" : "<=", hi);
  if (!has_lo && !has_hi) return "must be finite";
  return fmt::format("must be in {}{}, {}{}", lo_open ? "(" : "[", lo, hi, hi_open ? ")" : "]");
}

std::string FlagName(std::string_view name, std::string_view prefix) {
  std::string flag = "--";
  if (!prefix.empty()) flag += fmt::format("{}-", prefix);
  for (char c : name) flag += c == '_' ? '-' : c;
  return flag;
}

namespace detail {

std::string CheckValue(OptionType type, const Interval& range, const std::vector<std::string_view>& choices,
                       double v) {
  if (type == OptionType::kChoice) {
    if (v >= 0 && v < static_cast<double>(choices.size()) && v == std::floor(v)) return {};
    return fmt::format("must be one of {}", fmt::join(choices, ", "));
  }
  if (type == OptionType::kInteger && v != std::floor(v)) return "must be an integer";
  if (!range.Contains(v)) return range.ToString();
  // Integer options are int fields: a value beyond int's range would not survive the conversion.
  if (type == OptionType::kInteger && std::abs(v) > static_cast<double>(std::numeric_limits<int>::max())) {
    return fmt::format("must be at most {} in magnitude", std::numeric_limits<int>::max());
  }
  return {};
}

std::string FormatValue(OptionType type, const std::vector<std::string_view>& choices, double v) {
  if (type == OptionType::kChoice) {
    const auto i = static_cast<long>(v);
    if (v == std::floor(v) && i >= 0 && i < static_cast<long>(choices.size())) {
      return std::string(choices[static_cast<std::size_t>(i)]);
    }
    return fmt::format("#{}", v);
  }
  return fmt::format("{}", v);
}

double ParseValue(std::string_view name, OptionType type, const std::vector<std::string_view>& choices,
                  std::string_view text) {
  if (type == OptionType::kChoice) {
    for (std::size_t i = 0; i < choices.size(); ++i) {
      if (choices[i] == text) return static_cast<double>(i);
    }
    ThrowInvalid(name, fmt::format("'{}'", text), fmt::format("must be one of {}", fmt::join(choices, ", ")));
  }
  const std::string s(text);
  std::size_t used = 0;
  double v = 0.0;
  try {
    v = type == OptionType::kInteger ? static_cast<double>(std::stol(s, &used)) : std::stod(s, &used);
  } catch (const std::out_of_range&) {  // a number, beyond what a double (long) holds
    ThrowInvalid(
        name, fmt::format("'{}'", text),
        type == OptionType::kInteger
            ? fmt::format("out of range (an integer within ±{})", std::numeric_limits<long>::max())
            : "out of range (a finite double: magnitude below 1.8e308, not below 2.2e-308 unless 0)");
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != s.size()) {
    ThrowInvalid(name, fmt::format("'{}'", text),
                 type == OptionType::kInteger ? "expected an integer" : "expected a number");
  }
  return v;
}

void ThrowInvalid(std::string_view name, const std::string& value, const std::string& what) {
  throw std::invalid_argument(fmt::format("{} = {}: {}", name, value, what));
}

}  // namespace detail
}  // namespace hysid
