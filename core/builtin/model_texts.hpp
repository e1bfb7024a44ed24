// The text of each built-in model's file models/NAME.toml, compiled into the library by the build.
#pragma once

#include <span>
#include <string_view>

namespace hysid::internal {

struct ModelText {
  std::string_view name;  // NAME
  std::string_view text;  // the file's contents
};

std::span<const ModelText> BuiltinModelTexts();

}  // namespace hysid::internal
