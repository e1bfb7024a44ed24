// A guard in front of toml++ 3.3.0 (Debian's), for every TOML file hysid reads (sweep files, model
// files).
#pragma once

#include <string>
#include <string_view>

namespace hysid {

// Throws std::invalid_argument "NAME:LINE: a non-ASCII character ..." for a non-ASCII byte outside
// comments, one-line strings and multi-line literal strings: toml++ 3.3.0 classifies such characters
// with a table that ends in __builtin_unreachable for U+00A1–U+0499 (e.g. "û" where whitespace may
// stand, or after a line-ending backslash in a """ string).
void CheckTomlCharacters(std::string_view text, const std::string& name);

}  // namespace hysid
