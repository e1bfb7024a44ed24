// The one way hysid parses TOML (sweep files, model files): toml++ 3.3.0 (Debian's) behind a guard.
#pragma once

#include <string>
#include <string_view>

// toml++ 3.3.0 turns its internal assertions into __builtin_assume under NDEBUG (clang) and into
// assert() otherwise; both are reachable from malformed input (upstream issues 294/295). With NDEBUG
// undefined and TOML_ASSERT a no-op, neither happens in any build type: the parser's own checks
// report the error. Non-ASCII input that reaches its __builtin_unreachable is refused before parsing
// (CheckTomlCharacters). hysid code includes toml++ through this header only.
#pragma push_macro("NDEBUG")
#undef NDEBUG
#define TOML_ASSERT(expr) static_cast<void>(0)
#include <toml++/toml.h>
#pragma pop_macro("NDEBUG")

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
