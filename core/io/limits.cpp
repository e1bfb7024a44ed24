#include "core/io/limits.hpp"

#include <charconv>
#include <cstdlib>
#include <stdexcept>
#include <string_view>

#include <fmt/format.h>

namespace hysid {

std::int64_t LimitValue(const Limit& limit) {
  const char* env = std::getenv(limit.variable);
  if (!env || !*env) return limit.default_value;
  std::int64_t v = 0;
  const std::string_view s(env);
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || end != s.data() + s.size() || v < 1) {
    throw std::invalid_argument(fmt::format("{} = '{}': must be a positive integer (the limit of {})",
                                            limit.variable, Abbreviated(s), limit.what));
  }
  return v;
}

void CheckLimit(const Limit& limit, std::int64_t value, const std::string& where) {
  const std::int64_t max = LimitValue(limit);
  if (value > max) {
    throw std::invalid_argument(fmt::format("{}: {} exceeds the limit of {} {} (raise it with {}=N)", where,
                                            value, max, limit.what, limit.variable));
  }
}

std::int64_t CheckedProduct(const Limit& limit, std::int64_t a, std::int64_t b, const std::string& where) {
  std::int64_t p = 0;
  if (__builtin_mul_overflow(a, b, &p)) {
    throw std::invalid_argument(fmt::format("{}: {} × {} overflows 64 bits; the limit is {} {} (raise it with {}=N)",
                                            where, a, b, LimitValue(limit), limit.what, limit.variable));
  }
  CheckLimit(limit, p, where);
  return p;
}

std::string Abbreviated(std::string_view text, std::size_t max) {
  if (text.size() <= max) return std::string(text);
  return fmt::format("{}… ({} bytes)", text.substr(0, max), text.size());
}

}  // namespace hysid
