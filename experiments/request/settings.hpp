// The identification's own settings (those besides the detector's and the estimators' options of
// PluginOptionArguments, checks.hpp), each described once: its name, from which both spellings derive
// (Spelled: "max_gap" is --max-gap and max_gap), the kind of value, the help and the default as each
// front-end shows it. The command line registers its flags of `hysid identify` from this table; the
// Python module builds its keyword list, the docstring and the refusal of an unknown keyword from it.
// What only one front-end has (the files and outputs of the command line, the arrays and the truth of
// Python) is described by that front-end (docs/architecture.md, "One identification under two
// front-ends").
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "experiments/request/checks.hpp"

namespace hysid {

// The kind of value a setting takes (each front-end reads it in its own way: --x0 1,0 or x0=[1, 0]).
enum class SettingType {
  kSwitch,     // on or off: a flag without a value; True or False
  kNumber,     // one real number
  kNumbers,    // real numbers: a comma-separated list; a sequence or an array
  kText,       // a name (a plugin, the refinement's choice)
  kTexts,      // texts, repeatable: --param-bound NAME=LO,HI; {name: (lo, hi)}
  kStateNames  // x0_known: every component, or state names
};

// What a front-end shows of a setting: its default ("" : none shown) and the help's front-end parts.
struct SettingFront {
  std::string default_text;
  std::string help_before;  // "NAME=LO,HI: ", the value's form
  std::string help_after;   // "; default 5 x the median step"
};

struct IdentifySetting {
  std::string name;  // "max_gap"
  SettingType type = SettingType::kNumber;
  // The help both front-ends show; "${x0_known}" names another setting as the front-end spells it.
  std::string help;
  SettingFront flag, keyword;  // the command line's, Python's
  const SettingFront& front(Spelling spelling) const { return spelling == Spelling::kFlag ? flag : keyword; }
};

// Every setting both front-ends accept, in the order of Python's docstring.
const std::vector<IdentifySetting>& IdentifySettings();
// The setting by name; an internal error (Demand) when there is none.
const IdentifySetting& FindIdentifySetting(std::string_view name);
// The whole help as `spelling`'s front-end shows it: help_before + help + help_after, the settings named
// by ${name} spelled.
std::string SettingHelp(const IdentifySetting& setting, Spelling spelling);

}  // namespace hysid
