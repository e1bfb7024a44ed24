#include "core/io/toml_guard.hpp"

#include <stdexcept>

#include <fmt/format.h>

#include "core/io/limits.hpp"

namespace hysid {

void CheckTomlCharacters(std::string_view text, const std::string& name) {
  enum class In { kCode, kComment, kBasic, kLiteral, kMultiBasic, kMultiLiteral } in = In::kCode;
  long line = 1;
  const auto starts = [&](std::size_t i, std::string_view s) { return text.substr(i, s.size()) == s; };
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\n') {
      ++line;
      if (in != In::kMultiBasic && in != In::kMultiLiteral) in = In::kCode;
      continue;
    }
    if (static_cast<unsigned char>(c) >= 0x80 && (in == In::kCode || in == In::kMultiBasic)) {
      throw std::invalid_argument(fmt::format(
          "{}:{}: a non-ASCII character {}; TOML files may hold them only in comments and one-line strings",
          name, line, in == In::kCode ? "outside a string or comment" : "in a \"\"\" string"));
    }
    switch (in) {
      case In::kCode:
        if (c == '#') in = In::kComment;
        if (c == '"') in = starts(i, "\"\"\"") ? (i += 2, In::kMultiBasic) : In::kBasic;
        if (c == '\'') in = starts(i, "\'\'\'") ? (i += 2, In::kMultiLiteral) : In::kLiteral;
        break;
      case In::kBasic:
      case In::kMultiBasic:
        if (c == '\\' && i + 1 < text.size() && text[i + 1] != '\n') {
          ++i;  // an escaped character (a non-ASCII one is caught on the next byte for """ strings)
          if (static_cast<unsigned char>(text[i]) >= 0x80) --i;
        } else if (in == In::kBasic && c == '"') {
          in = In::kCode;
        } else if (in == In::kMultiBasic && starts(i, "\"\"\"")) {
          in = In::kCode;
          i += 2;
        }
        break;
      case In::kLiteral:
        if (c == '\'') in = In::kCode;
        break;
      case In::kMultiLiteral:
        if (starts(i, "\'\'\'")) {
          in = In::kCode;
          i += 2;
        }
        break;
      case In::kComment: break;
    }
  }
}

toml::table ParseToml(std::string_view text, const std::string& name) {
  if (text.starts_with(kUtf8Bom)) text.remove_prefix(kUtf8Bom.size());  // as the CSV reader
  CheckTomlCharacters(text, name);
  try {
    return toml::parse(text, name);
  } catch (const toml::parse_error& e) {
    throw std::invalid_argument(
        fmt::format("{}:{}: TOML syntax: {}", name, e.source().begin.line, e.description()));
  }
}

}  // namespace hysid
