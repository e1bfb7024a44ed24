#include "experiments/request/settings.hpp"

#include <cstdio>
#include <cstdlib>
#include <utility>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/identify/identifier.hpp"

namespace hysid {
namespace {

// "estimator of alpha and beta: rls (recursive least squares); gtls (...)".
template <class Kind>
std::string PluginChoice(std::string_view what) {
  std::vector<std::string> parts;
  for (const auto& d : AllPlugins<Kind>()) parts.push_back(fmt::format("{} ({})", d.name, d.help));
  return fmt::format("{}: {}", what, fmt::join(parts, "; "));
}

// What a front-end shows: the default, the help's parts before and after the shared help.
SettingFront Shows(std::string default_text, std::string help_before = "", std::string help_after = "") {
  return {std::move(default_text), std::move(help_before), std::move(help_after)};
}

std::vector<IdentifySetting> MakeSettings() {
  using T = SettingType;
  return {
      {"estimator", T::kText, PluginChoice<EstimatorKind>("estimator of alpha and beta"), Shows("rls"),
       Shows("'rls'")},
      {"detector", T::kText, PluginChoice<DetectorKind>("jump detector"), Shows("residual"),
       Shows("'residual'")},
      {"sigma", T::kNumbers, "known measurement noise σ > 0 (one, or one per measured state)",
       Shows("", "", "; gtls/frisch estimate it from the data when not given"),
       Shows("None", "", "; None: estimated where needed")},
      {"max_gap", T::kNumber,
       "seconds: a step longer than this restarts the chain (no regression or detector statistic across it)",
       Shows("", "", "; default 5 x the median step"), Shows("None", "", "; None: 5 x the median step")},
      {"localize", T::kSwitch,
       "regress each jump at its located instant inside (t-dt, t] (flows forward and backward with the "
       "estimated flow until the jump's known rows agree)",
       Shows(""), Shows("False")},
      {"second_pass", T::kSwitch,
       "re-classify every sample with the final estimates, re-estimate, report the changes", Shows(""),
       Shows("False")},
      {"keep_outliers", T::kSwitch,
       "keep every sample (else a sample that stands alone off both neighbours in a measured state, its "
       "second difference beyond 10 robust sd in the pattern (1, -2, 1), or a pair displaced together, "
       "is left out and listed; and "
       "when the fit is not ok, or ok on a span it cut short, a sample or pair alone beyond 10 robust sd "
       "off it is left out and listed when the fit without them is ok)",
       Shows(""), Shows("False")},
      {"data_rtol", T::kNumber,
       "residual detector: relative accuracy of the data apart from the noise (simulated data: the "
       "integrator's rtol, e.g. 1e-12 for `hysid simulate`)",
       Shows("0"), Shows("0.0")},
      {"data_atol", T::kNumber,
       "residual detector: absolute accuracy of the data apart from the noise (simulated data: the "
       "integrator's atol)",
       Shows("0"), Shows("0.0")},
      {"flow_noise_shape", T::kNumbers,
       "gtls/frisch: noise covariance shape C of the flow rows [phi, y] instead of the one derived from "
       "sigma and dt",
       Shows("", "", "; its (p+1)^2 values, row-major"),
       Shows("None", "", "; (p+1) x (p+1), or its (p+1)^2 values row-major")},
      {"jump_noise_shape", T::kNumbers, "gtls/frisch: the same for the jump rows", Shows(""), Shows("None")},
      {"refine", T::kText,
       "ml: maximum-likelihood output-error refinement of the recursive estimate (with standard errors and a "
       "fit status), none: the recursive estimate alone",
       Shows("ml", "", "; with ml, hysid exits 1 when the fit is not ok"),
       Shows("'ml'", "", "; with 'ml' the dict has `refined`")},
      {"x0_known", T::kStateNames,
       "the components of x0 that are known (not estimated: held at ${x0} in the refinement; one chain only)",
       Shows("", "", ": alone or 'all' every component, or state names, comma-separated (e.g. --x0-known v)"),
       Shows("None", "", ": True or 'all' for every one, or state names (a list, or comma-separated)")},
      {"x0", T::kNumbers,
       "with ${x0_known}: the initial state, one value per state (the known components are held at theirs; "
       "default: the model's)",
       Shows(""), Shows("None")},
      {"param_bound", T::kTexts,
       "bounds of an unknown parameter of alpha, beta or the guard parameters in the refinement (replaces "
       "the model file's bounds; -inf and inf allowed; the value must lie inside)",
       Shows("", "NAME=LO,HI (repeatable): "), Shows("None", "{name: (lo, hi)}: ")},
  };
}

// `text` with every ${name} as `spelling` spells the setting `name`.
std::string SpellNames(std::string text, Spelling spelling) {
  for (std::size_t at = text.find("${"); at != std::string::npos; at = text.find("${", at)) {
    const std::size_t end = text.find('}', at);
    const std::string spelled = Spelled(text.substr(at + 2, end - at - 2), spelling);
    text.replace(at, end - at + 1, spelled);
    at += spelled.size();
  }
  return text;
}

}  // namespace

const std::vector<IdentifySetting>& IdentifySettings() {
  static const std::vector<IdentifySetting> settings = MakeSettings();
  return settings;
}

const IdentifySetting& FindIdentifySetting(std::string_view name) {
  for (const IdentifySetting& s : IdentifySettings()) {
    if (s.name == name) return s;
  }
  std::fprintf(stderr, "hysid: internal error: no identify setting '%.*s'\n", static_cast<int>(name.size()),
               name.data());
  std::abort();
}

std::string SettingHelp(const IdentifySetting& setting, Spelling spelling) {
  const SettingFront& front = setting.front(spelling);
  return SpellNames(front.help_before + setting.help + front.help_after, spelling);
}

}  // namespace hysid
