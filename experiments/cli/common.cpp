#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <stdexcept>
#include <string_view>
#include <utility>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/io/limits.hpp"
#include "experiments/request/checks.hpp"
#include "experiments/cli/cli.hpp"
#include "sim/model_check/model_check.hpp"

namespace hysid::cli {

void BadFlag(const std::string& what) { throw std::invalid_argument(what); }

namespace {

// "; for a model file use --model-file NAME" when --model names no registered model but a file or a
// name ending in .toml; "" otherwise.
std::string ModelFileHint(const Environment& env, const std::string& name) {
  std::error_code ec;
  if (env.models.Contains(name) || !(name.ends_with(".toml") || std::filesystem::is_regular_file(name, ec)))
    return "";
  return fmt::format("; for a model file use --model-file {}", Abbreviated(name, 80));
}

}  // namespace

Model MakeModel(const Environment& env, const std::string& name, const std::vector<std::string>& params) {
  return MakeModel(env, name, "", params);
}

Model MakeModel(const Environment& env, const std::string& name, const std::string& file,
                const std::vector<std::string>& params, ModelValues values, std::string* note) {
  Model model = [&] {
    try {
      return file.empty() ? env.models.Make(name) : LoadModelFile(file, values, note);
    } catch (const std::invalid_argument& e) {
      BadFlag(fmt::format("{}: {}{}", file.empty() ? "--model" : "--model-file", e.what(),
                          file.empty() ? ModelFileHint(env, name) : ""));
    }
  }();
  std::map<std::string, std::string> given;  // name -> the assignment that set it
  for (const std::string& p : params) {
    const std::string name = p.substr(0, p.find('='));
    if (const auto [at, fresh] = given.emplace(name, p); !fresh) {
      BadFlag(fmt::format("--param {}: parameter '{}' is already set by --param {}; give each parameter once",
                          Abbreviated(p), Abbreviated(name, 40), Abbreviated(at->second)));
    }
    try {
      model.SetParameter(std::string_view(p));
    } catch (const std::invalid_argument& e) {
      BadFlag(fmt::format("--param {}: {}", p, e.what()));
    }
  }
  return model;
}

Model MakeModel(const Environment& env, const ModelFlags& flags, ModelValues values, std::string* note) {
  return MakeModel(env, flags.name, flags.file, flags.params, values, note);
}

void AddModelFlags(CLI::App& cmd, ModelFlags& flags, const std::string& param_help) {
  CLI::Option* model = cmd.add_option("--model", flags.name, "model name (see `hysid models`)");
  model->capture_default_str();
  cmd.add_option("--model-file", flags.file, "a model file (TOML, see models/*.toml) instead of --model")
      ->excludes(model);
  cmd.add_option("--param", flags.params, param_help);
}

void AddBoundFlag(CLI::App& cmd, std::vector<std::string>& bounds) {
  cmd.add_option("--param-bound", bounds,
                 "NAME=LO,HI: bounds of an unknown parameter of alpha, beta or the guard parameters "
                 "(repeatable; replaces the model file's bounds; -inf and inf allowed; the value must lie "
                 "inside)");
}

void ApplyBoundFlags(const std::vector<std::string>& bounds, Model* model) {
  ApplyBounds(bounds, Spelling::kFlag, model);
}

namespace {

// The comma-separated items of one value of `flag`; an empty item is refused (CLI11's own split
// would drop it and read "0.1,,0.2" as two values).
std::vector<std::string> ListItems(const std::string& flag, const std::string& text) {
  std::vector<std::string> items;
  std::size_t begin = 0;
  while (true) {
    const std::size_t comma = text.find(',', begin);
    items.push_back(text.substr(begin, comma == std::string::npos ? std::string::npos : comma - begin));
    if (items.back().find_first_not_of(" \t") == std::string::npos) {
      BadFlag(fmt::format("{} = {}: item {} is empty", flag, Abbreviated(text), items.size()));
    }
    if (comma == std::string::npos) return items;
    begin = comma + 1;
  }
}

// A list flag whose items `convert(text, i, item)` turns into values.
template <class T, class Convert>
CLI::Option* AddList(CLI::App& cmd, const std::string& flag, std::vector<T>& values, const std::string& help,
                     Convert convert) {
  return cmd.add_option_function<std::vector<std::string>>(
      flag,
      [&values, flag, convert](const std::vector<std::string>& given) {
        values.clear();
        for (const std::string& text : given) {
          std::vector<std::string> items = ListItems(flag, text);
          for (std::size_t i = 0; i < items.size(); ++i) {
            values.push_back(convert(text, i, std::move(items[i])));
          }
        }
      },
      help);
}

}  // namespace

std::string Trimmed(const std::string& text) {
  const std::size_t begin = text.find_first_not_of(" \t");
  return begin == std::string::npos ? std::string()
                                    : text.substr(begin, text.find_last_not_of(" \t") - begin + 1);
}

CLI::Option* AddTextList(CLI::App& cmd, const std::string& flag, std::vector<std::string>& values,
                         const std::string& help) {
  return AddList(cmd, flag, values, help,
                 [](const std::string&, std::size_t, const std::string& item) { return Trimmed(item); });
}

CLI::Option* AddNumberList(CLI::App& cmd, const std::string& flag, std::vector<double>& values,
                           const std::string& help) {
  return AddList(
      cmd, flag, values, help, [flag](const std::string& text, std::size_t i, const std::string& item) {
        char* end = nullptr;
        const double v = std::strtod(item.c_str(), &end);
        if (end == item.c_str() || std::string_view(end).find_first_not_of(" \t") != std::string::npos) {
          BadFlag(fmt::format("{} = {}: item {} '{}' is not a number", flag, Abbreviated(text), i + 1,
                              Abbreviated(item, 40)));
        }
        return v;
      });
}

void AddTrajectoryFlags(CLI::App& cmd, TrajectoryFlags& flags) {
  AddNumberList(cmd, "--x0", flags.x0, "initial state, comma-separated (default: the model's)");
  cmd.add_option("--t-end", flags.t_end, "horizon in seconds (default: the model's)");
  cmd.add_option("--dt", flags.dt, "sample time delta-t in seconds (default: the model's)");
}

CLI::Option* AddX0KnownOption(CLI::App& cmd, X0Known& flag, const std::string& help) {
  CLI::Option* option = cmd.add_option("--x0-known", flag.text, help)->expected(0, 1);
  flag.option = option;
  return option;
}

namespace {

// The setting `name`, which must be of `type`; its flag's name and help.
const IdentifySetting& SettingOfType(std::string_view name, SettingType type) {
  const IdentifySetting& setting = FindIdentifySetting(name);
  if (setting.type != type) {
    std::fprintf(stderr, "hysid: internal error: the setting '%s' is registered with another type\n",
                 setting.name.c_str());
    std::abort();
  }
  return setting;
}

// The default the command line shows, when the table gives one.
CLI::Option* ShownDefault(const IdentifySetting& setting, CLI::Option* option) {
  if (!setting.flag.default_text.empty()) option->default_str(setting.flag.default_text);
  return option;
}

}  // namespace

CLI::Option* AddSetting(CLI::App& cmd, std::string_view name, bool& target) {
  const IdentifySetting& s = SettingOfType(name, SettingType::kSwitch);
  return ShownDefault(
      s, cmd.add_flag(Spelled(s.name, Spelling::kFlag), target, SettingHelp(s, Spelling::kFlag)));
}

CLI::Option* AddSetting(CLI::App& cmd, std::string_view name, double& target) {
  const IdentifySetting& s = SettingOfType(name, SettingType::kNumber);
  return ShownDefault(
      s, cmd.add_option(Spelled(s.name, Spelling::kFlag), target, SettingHelp(s, Spelling::kFlag)));
}

CLI::Option* AddSetting(CLI::App& cmd, std::string_view name, std::vector<double>& target) {
  const IdentifySetting& s = SettingOfType(name, SettingType::kNumbers);
  return ShownDefault(
      s, AddNumberList(cmd, Spelled(s.name, Spelling::kFlag), target, SettingHelp(s, Spelling::kFlag)));
}

CLI::Option* AddSetting(CLI::App& cmd, std::string_view name, std::string& target) {
  const IdentifySetting& s = SettingOfType(name, SettingType::kText);
  return ShownDefault(
      s, cmd.add_option(Spelled(s.name, Spelling::kFlag), target, SettingHelp(s, Spelling::kFlag)));
}

CLI::Option* AddSetting(CLI::App& cmd, std::string_view name, std::vector<std::string>& target) {
  const IdentifySetting& s = SettingOfType(name, SettingType::kTexts);
  return ShownDefault(
      s, cmd.add_option(Spelled(s.name, Spelling::kFlag), target, SettingHelp(s, Spelling::kFlag)));
}

CLI::Option* AddSetting(CLI::App& cmd, std::string_view name, X0Known& target) {
  const IdentifySetting& s = SettingOfType(name, SettingType::kStateNames);
  return ShownDefault(s, AddX0KnownOption(cmd, target, SettingHelp(s, Spelling::kFlag)));
}

std::vector<int> X0KnownFlag(const X0Known& flag, const Model& model) {
  return KnownX0(flag.given() ? std::optional<std::string>(flag.text) : std::nullopt, model, Spelling::kFlag);
}

std::string CrlbMeanErrors(const Unknowns& unknowns, const Crlb& bound, int digits) {
  std::vector<std::string> parts;
  if (!unknowns.alpha.empty()) parts.push_back(fmt::format("mean e_alpha {:.{}g}", bound.mean_e_alpha, digits));
  if (!unknowns.beta.empty()) parts.push_back(fmt::format("mean e_beta {:.{}g}", bound.mean_e_beta, digits));
  if (!unknowns.gamma.empty()) parts.push_back(fmt::format("mean e_gamma {:.{}g}", bound.mean_e_gamma, digits));
  return fmt::format("{}", fmt::join(parts, ", "));
}

std::string X0KnownText(const std::vector<int>& known, const Model& model) {
  if (known.empty()) return "x0 unknown";
  if (static_cast<int>(known.size()) == model.state_size()) return "x0 known";
  std::vector<std::string> names;
  for (const int i : known) names.push_back(fmt::format("x0[{}]", model.spec().state_names[static_cast<std::size_t>(i)]));
  return fmt::format("{} known", fmt::join(names, ", "));
}

SampleGrid GridFlag(const TrajectoryFlags& flags, const Model& model) {
  const ModelSpec& spec = model.spec();
  return CheckedGrid(flags.t_end.value_or(spec.default_t_end), flags.dt.value_or(spec.default_dt),
                     Spelling::kFlag);
}

Vec InitialStateFlag(const TrajectoryFlags& flags, const Model& model, const Context& at) {
  return CheckedX0(flags.x0, model, at, Spelling::kFlag);
}

InputSignal InputsFlag(const std::string& path, const ModelSpec& spec, const SampleGrid& grid) {
  return CheckedInputs(path, spec, grid, Spelling::kFlag);
}

void RequireFinite(const std::string& flag, const std::vector<double>& values) { CheckFinite(flag, values); }

void SetPluginKinds(const std::string& estimator, const std::string& detector, IdentifierSettings* settings) {
  hysid::SetPluginKinds(estimator, detector, Spelling::kFlag, settings);
}

CLI::Option* AddSigmaOption(CLI::App& cmd, std::vector<double>& sigma, const std::string& help) {
  return AddNumberList(cmd, "--sigma", sigma, help);
}

void AddToleranceOptions(CLI::App& cmd, SimOptions& sim, const std::string& covers) {
  const std::string suffix = covers.empty() ? "" : " (" + covers + ")";
  cmd.add_option("--rtol", sim.rtol, "CVODE relative tolerance" + suffix)->capture_default_str();
  cmd.add_option("--atol", sim.atol, "CVODE absolute tolerance" + suffix)->capture_default_str();
}

Progress::Mode ProgressFlag(const std::string& text) {
  if (text == "auto") return Progress::Mode::kAuto;
  if (text == "bar") return Progress::Mode::kBar;
  if (text == "lines") return Progress::Mode::kLines;
  if (text == "none") return Progress::Mode::kNone;
  BadFlag(fmt::format("--progress = '{}': expected auto, bar, lines or none", Abbreviated(text, 40)));
}

}  // namespace hysid::cli
