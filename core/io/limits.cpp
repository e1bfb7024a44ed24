#include "core/io/limits.hpp"

#include <sys/stat.h>

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
    throw std::invalid_argument(
        fmt::format("{}: {} × {} overflows 64 bits; the limit is {} {} (raise it with {}=N)", where, a, b,
                    LimitValue(limit), limit.what, limit.variable));
  }
  CheckLimit(limit, p, where);
  return p;
}

void CheckRegularFile(const std::string& path, const char* what) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0 || S_ISREG(st.st_mode) || S_ISDIR(st.st_mode)) return;
  const char* kind = S_ISFIFO(st.st_mode)   ? "a FIFO"
                     : S_ISSOCK(st.st_mode) ? "a socket"
                     : S_ISCHR(st.st_mode)  ? "a character device"
                     : S_ISBLK(st.st_mode)  ? "a block device"
                                            : "not a file";
  throw std::invalid_argument(fmt::format("{}: is {}, not a regular file; give the {} as a file",
                                          Abbreviated(path, 200), kind, what));
}

namespace {

// Length of the valid UTF-8 sequence at text[i] (2–4 bytes), or 0.
std::size_t Utf8Length(std::string_view text, std::size_t i) {
  const auto b = static_cast<unsigned char>(text[i]);
  const std::size_t n = b >= 0xF0 && b <= 0xF4 ? 4 : b >= 0xE0 ? 3 : b >= 0xC2 && b < 0xE0 ? 2 : 0;
  if (n == 0 || i + n > text.size()) return 0;
  for (std::size_t k = 1; k < n; ++k) {
    if ((static_cast<unsigned char>(text[i + k]) & 0xC0) != 0x80) return 0;
  }
  return n;
}

}  // namespace

std::string Printable(std::string_view text) {
  std::string out;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const auto b = static_cast<unsigned char>(text[i]);
    if (b >= 0x20 && b < 0x7F) {
      out += text[i];
    } else if (const std::size_t n = b >= 0x80 ? Utf8Length(text, i) : 0; n > 0) {
      out.append(text.substr(i, n));
      i += n - 1;
    } else {
      out += fmt::format("\\x{:02x}", b);
    }
  }
  return out;
}

std::string Abbreviated(std::string_view text, std::size_t max) {
  if (text.size() <= max) return Printable(text);
  return fmt::format("{}… ({} bytes)", Printable(text.substr(0, max)), text.size());
}

std::string ShortenedMessage(std::string_view text, std::size_t max) {
  if (text.size() <= max) return Printable(text);
  const std::size_t head = max * 2 / 3, tail = max - head;
  return fmt::format("{} … ({} bytes cut) … {}", Printable(text.substr(0, head)), text.size() - head - tail,
                     Printable(text.substr(text.size() - tail)));
}

}  // namespace hysid
