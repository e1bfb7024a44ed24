// The one way hysid parses TOML (sweep files, model files): toml++ 3.3.0 (Debian's) behind a guard.
#pragma once

#include <string>
#include <string_view>

#include <toml++/toml.h>

namespace hysid {

// Throws std::invalid_argument "NAME:LINE: a non-ASCII character ..." for a non-ASCII byte outside
// comments, one-line strings and multi-line literal strings: toml++ 3.3.0 classifies such characters
// with a table that ends in __builtin_unreachable for U+00A1–U+0499 (e.g. "û" where whitespace may
// stand, or after a line-ending backslash in a """ string).
void CheckTomlCharacters(std::string_view text, const std::string& name);

// `text` checked by CheckTomlCharacters, then parsed; a syntax error throws std::invalid_argument
// "NAME:LINE: TOML syntax: ...".
toml::table ParseToml(std::string_view text, const std::string& name);

}  // namespace hysid
