#include "experiments/request/checks.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <functional>
#include <map>
#include <stdexcept>
#include <system_error>
#include <tuple>
#include <utility>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/io/csv.hpp"
#include "core/io/limits.hpp"
#include "core/model_file/input_defaults.hpp"

namespace hysid {

std::string Spelled(std::string_view name, Spelling spelling, std::string_view prefix) {
  if (spelling == Spelling::kFlag) return FlagName(name, prefix);
  return prefix.empty() ? std::string(name) : fmt::format("{}_{}", prefix, name);
}

void CheckFinite(const std::string& name, const std::vector<double>& values) {
  for (double v : values) {
    if (!std::isfinite(v)) throw std::invalid_argument(fmt::format("{} = {}: must be finite", name, v));
  }
}

SampleGrid CheckedGrid(double t_end, double dt, Spelling spelling) {
  const std::string t_name = Spelled("t_end", spelling), dt_name = Spelled("dt", spelling);
  const SampleGrid grid{.t_end = t_end, .dt = dt};
  for (const auto& [name, v] : {std::pair{dt_name, dt}, std::pair{t_name, t_end}}) {
    CheckFinite(name, {v});
    if (v <= 0) throw std::invalid_argument(fmt::format("{} = {}: must be > 0", name, v));
  }
  CheckLimit(kMaxSamples, static_cast<std::int64_t>(std::min(t_end / dt, 9e18)) + 1,
             fmt::format("{} {} / {} {}", t_name, t_end, dt_name, dt));
  if (std::string e; !grid.IsValid(&e))
    throw std::invalid_argument(fmt::format("{}/{}: {}", t_name, dt_name, e));
  return grid;
}

Vec CheckedSigma(const std::vector<double>& values, int states, bool allow_zero, Spelling spelling,
                 const std::vector<int>& measured) {
  const std::string name = Spelled("sigma", spelling);
  CheckFinite(name, values);
  const auto given = static_cast<int>(values.size()), m = static_cast<int>(measured.size());
  const bool some_measured = m > 0 && m < states;
  Vec sigma = Vec::Zero(states);
  if (given == 1) {
    sigma.setConstant(values[0]);
  } else if (given == states) {
    sigma = Eigen::Map<const Vec>(values.data(), states);
  } else if (some_measured && given == m) {
    for (int i = 0; i < m; ++i) sigma[measured[std::size_t(i)]] = values[std::size_t(i)];
  } else if (some_measured) {
    throw std::invalid_argument(
        fmt::format("{} has {} values; give one, one per state ({}) or one per measured state ({})", name,
                    given, states, m));
  } else {
    throw std::invalid_argument(
        fmt::format("{} has {} values; give one, or one per state ({})", name, given, states));
  }
  if (allow_zero ? (sigma.array() < 0.0).any() : (sigma.array() <= 0.0).any()) {
    throw std::invalid_argument(
        fmt::format("{} = {}: must be {} 0", name, fmt::join(values, ","), allow_zero ? ">=" : ">"));
  }
  return sigma;
}

void CheckSigmaRange(const Vec& sigma, Spelling spelling) {
  for (const double v : sigma) {
    if (v >= kMinSigma && v <= kMaxSigma) continue;
    throw std::invalid_argument(fmt::format(
        "{} = {:g}: out of range ({:g} <= sigma <= {:g}: the information scales as 1/sigma^2, which would "
        "overflow or underflow; rescale the data's units)",
        Spelled("sigma", spelling), v, kMinSigma, kMaxSigma));
  }
}

Vec CheckedNoiseSigma(const std::vector<double>& values, int measured, Spelling spelling) {
  const std::string name = Spelled("sigma", spelling);
  CheckFinite(name, values);
  if (values.size() != 1 && static_cast<int>(values.size()) != measured) {
    throw std::invalid_argument(fmt::format("{} has {} values; give one, or one per measured state ({})",
                                            name, values.size(), measured));
  }
  Vec sigma = CheckedSigma(values, measured, /*allow_zero=*/false, spelling);
  CheckSigmaRange(sigma, spelling);
  return sigma;
}

void CheckBoundGrid(const SampleGrid& grid, Spelling spelling) {
  if (grid.t_end >= grid.dt) return;
  throw std::invalid_argument(fmt::format(
      "{} = {:g}: out of range: the bound needs at least 2 samples ({} >= {} = {:g})",
      Spelled("t_end", spelling), grid.t_end, Spelled("t_end", spelling), Spelled("dt", spelling), grid.dt));
}

void CheckNoiseShapesUsed(const IdentifierSettings& settings, bool flow_given, bool jump_given,
                          Spelling spelling) {
  std::vector<std::string> users;
  for (const auto& d : AllPlugins<EstimatorKind>()) {
    if (d.traits.needs_noise_shape) users.emplace_back(d.name);
  }
  for (const auto& [given, kind, name, which] :
       {std::tuple{flow_given, settings.flow_estimator.kind, "flow_noise_shape", "alpha"},
        std::tuple{jump_given, settings.jump_estimator.kind, "jump_noise_shape", "beta"}}) {
    if (!given || DescriptorOf(kind).traits.needs_noise_shape) continue;
    throw std::invalid_argument(fmt::format("{}: the {} estimator {} uses no noise shape (only {} do)",
                                            Spelled(name, spelling), which, ToString(kind),
                                            fmt::join(users, ", ")));
  }
}

void CheckBoundsNeedRefinement(bool bounds_given, const std::string& refine, Spelling spelling) {
  if (!bounds_given || refine != "none") return;
  throw std::invalid_argument(fmt::format(
      "{}: bounds act on the refinement, and {} = none has none (the recursive estimate cannot honour a "
      "bound); use the refinement or leave the bounds out",
      Spelled("param_bound", spelling), Spelled("refine", spelling)));
}

void CheckSimOptions(const SimOptions& options, Spelling spelling) {
  for (const auto& [name, v] : {std::pair{"rtol", options.rtol}, std::pair{"atol", options.atol}}) {
    CheckFinite(Spelled(name, spelling), {v});
    if (!(v > 0)) throw std::invalid_argument(fmt::format("{} = {}: must be > 0", Spelled(name, spelling), v));
  }
  if (options.max_jumps < 1) {
    throw std::invalid_argument(
        fmt::format("{} = {}: must be >= 1", Spelled("max_jumps", spelling), options.max_jumps));
  }
  if (std::string e; !options.IsValid(&e)) throw std::invalid_argument(e);  // fields no argument sets
}

std::string NonNegativeIntegerProblem(std::string& text) {
  if (text.find('-') != std::string::npos) return "must be ≥ 0, got " + text;
  if (text.empty() || text.find_first_not_of("0123456789") != std::string::npos) {
    return "must be a decimal integer ≥ 0, got " + text;
  }
  std::uint64_t value = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec == std::errc::result_out_of_range) return "must be ≤ 18446744073709551615 (2^64 − 1), got " + text;
  text = std::to_string(value);
  return "";
}

std::string NeitherModelNorFile(const std::string& name, const std::vector<std::string>& registered) {
  return fmt::format("'{}' is neither a registered model ({}) nor a model file", name, fmt::join(registered, ", "));
}

std::string RefineChoiceProblem(const std::string& value) {
  return value == "ml" || value == "none" ? "" : value + " not in {ml,none}";
}

void CheckMaxGap(double value, std::string_view shown, Spelling spelling) {
  if (value > 0.0 && std::isfinite(value)) return;
  throw std::invalid_argument(
      fmt::format("{} = {}: must be a number > 0 (seconds)", Spelled("max_gap", spelling), shown));
}

void CheckDataAccuracy(double data_rtol, double data_atol, Spelling spelling) {
  for (const auto& [name, value] : {std::pair{"data_rtol", data_rtol}, std::pair{"data_atol", data_atol}}) {
    if (!(value >= 0.0) || !std::isfinite(value)) {
      throw std::invalid_argument(
          fmt::format("{} = {}: must be finite and >= 0", Spelled(name, spelling), value));
    }
  }
}

void SetPluginKinds(const std::string& estimator, const std::string& detector, Spelling spelling,
                    IdentifierSettings* settings) {
  try {
    settings->UseEstimator(ParseKind<EstimatorKind>(estimator));
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(fmt::format("{}: {}", Spelled("estimator", spelling), e.what()));
  }
  try {
    settings->detector.kind = ParseKind<DetectorKind>(detector);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(fmt::format("{}: {}", Spelled("detector", spelling), e.what()));
  }
}

namespace {

template <class S>
std::string ReadBy(std::string_view option, const std::vector<S>& descriptors) {
  std::vector<std::string_view> names;
  for (const S& d : descriptors) {
    if (d.Reads(option)) names.push_back(d.name);
  }
  return fmt::format("{}", fmt::join(names, ", "));
}

// The options of table that the plugin `d` reads, spelled.
template <class S, class Descriptor>
std::string OptionsRead(const std::vector<Option<S>>& table, const Descriptor& d, std::string_view prefix,
                        Spelling spelling) {
  std::vector<std::string> names;
  for (const Option<S>& o : table) {
    if (d.Reads(o.name)) names.push_back(Spelled(o.name, spelling, prefix));
  }
  return names.empty() ? "none" : fmt::format("{}", fmt::join(names, ", "));
}

template <class S, class Descriptor>
void AddArguments(std::vector<PluginOptionArgument>* out, const std::vector<Option<S>>& table,
                  const std::vector<Descriptor>& descriptors, S IdentifierSettings::*member,
                  std::string_view prefix, std::string_view whose, std::string_view role) {
  const IdentifierSettings defaults;
  for (const Option<S>& o : table) {
    PluginOptionArgument a;
    a.name = o.name;
    a.prefix = prefix;
    a.help = fmt::format("{}: {}{}", ReadBy(o.name, descriptors), o.help, whose);
    a.default_text = o.Format(o.get(defaults.*member));
    a.type = o.type;
    a.choices.assign(o.choices.begin(), o.choices.end());
    for (const Descriptor& d : descriptors) {
      if (d.Reads(o.name)) a.read_by.emplace_back(d.name);
    }
    a.set = [&o, member](IdentifierSettings& s, std::string_view text) { o.set(s.*member, o.Parse(text)); };
    a.unread = [&table, &o, member, prefix, role](const IdentifierSettings& s, Spelling spelling) {
      const auto& d = DescriptorOf((s.*member).kind);
      if (d.Reads(o.name)) return std::string();
      return fmt::format("the {} '{}' does not read it (its options: {})", role, d.name,
                         OptionsRead(table, d, prefix, spelling));
    };
    out->push_back(std::move(a));
  }
}

}  // namespace

const std::vector<PluginOptionArgument>& PluginOptionArguments() {
  static const std::vector<PluginOptionArgument> arguments = [] {
    std::vector<PluginOptionArgument> a;
    AddArguments(&a, DetectorOptions(), AllPlugins<DetectorKind>(), &IdentifierSettings::detector, "", "",
                 "detector");
    AddArguments(&a, EstimatorOptions(), AllPlugins<EstimatorKind>(), &IdentifierSettings::flow_estimator, "",
                 " (alpha estimator)", "alpha estimator");
    AddArguments(&a, EstimatorOptions(), AllPlugins<EstimatorKind>(), &IdentifierSettings::jump_estimator,
                 "jump", " (beta estimator)", "beta estimator");
    return a;
  }();
  return arguments;
}

void ApplyPluginOptions(const std::map<std::string, std::string>& given, Spelling spelling,
                        IdentifierSettings* settings) {
  std::map<std::string, const PluginOptionArgument*> by_keyword;
  for (const PluginOptionArgument& a : PluginOptionArguments())
    by_keyword[Spelled(a.name, Spelling::kKeyword, a.prefix)] = &a;
  for (const auto& [keyword, text] : given) {
    const auto it = by_keyword.find(keyword);
    if (it == by_keyword.end()) throw std::invalid_argument(fmt::format("{}: no such option", keyword));
    const std::string name = Spelled(it->second->name, spelling, it->second->prefix);
    if (const std::string why = it->second->unread(*settings, spelling); !why.empty()) {
      throw std::invalid_argument(fmt::format("{}: {}", name, why));
    }
    try {
      it->second->set(*settings, text);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(fmt::format("{}: {}", name, e.what()));
    }
  }
}

void ApplyBounds(const std::vector<std::string>& bounds, Spelling spelling, Model* model) {
  const std::string flag = Spelled("param_bound", spelling);
  std::map<std::string, std::string> given;  // name -> the value that set it
  for (const std::string& b : bounds) {
    const std::size_t eq = b.find('='), comma = b.find(',', eq == std::string::npos ? 0 : eq);
    if (eq == std::string::npos || eq == 0 || comma == std::string::npos) {
      throw std::invalid_argument(fmt::format("{} {}: must be NAME=LO,HI", flag, Abbreviated(b)));
    }
    const std::string name = b.substr(0, eq);
    if (const auto [at, fresh] = given.emplace(name, b); !fresh) {
      throw std::invalid_argument(fmt::format("{} {}: parameter '{}' is already bounded by {} {}", flag,
                                              Abbreviated(b), Abbreviated(name, 40), flag, Abbreviated(at->second)));
    }
    auto number = [&](const std::string& text, const char* which) {
      char* end = nullptr;
      const double v = std::strtod(text.c_str(), &end);
      if (text.empty() || end != text.c_str() + text.size() || std::isnan(v)) {
        throw std::invalid_argument(
            fmt::format("{} {}: {} '{}' is not a number", flag, Abbreviated(b), which, Abbreviated(text, 40)));
      }
      return v;
    };
    const double lo = number(b.substr(eq + 1, comma - eq - 1), "LO");
    const double hi = number(b.substr(comma + 1), "HI");
    try {
      model->SetBounds(name, lo, hi);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(fmt::format("{} {}: {}", flag, Abbreviated(b), e.what()));
    }
  }
}

std::vector<int> KnownX0(const std::optional<std::string>& text, const Model& model, Spelling spelling) {
  const std::vector<std::string>& names = model.spec().state_names;
  std::vector<int> known;
  if (!text) return known;
  if (text->empty() || *text == "all") {
    for (int i = 0; i < model.state_size(); ++i) known.push_back(i);
    return known;
  }
  const std::string flag = Spelled("x0_known", spelling);
  std::size_t begin = 0;
  while (begin <= text->size()) {
    const std::size_t end = std::min(text->find(',', begin), text->size());
    const std::string name = text->substr(begin, end - begin);
    const auto at = std::find(names.begin(), names.end(), name);
    if (at == names.end()) {
      throw std::invalid_argument(fmt::format("{} = {}: '{}' is not a state of '{}' (states: {}; or 'all')", flag,
                                              Abbreviated(*text, 60), Abbreviated(name, 40), model.name(),
                                              fmt::join(names, ", ")));
    }
    const int i = static_cast<int>(at - names.begin());
    if (std::find(known.begin(), known.end(), i) != known.end()) {
      throw std::invalid_argument(fmt::format("{} = {}: '{}' named twice", flag, Abbreviated(*text, 60), name));
    }
    known.push_back(i);
    begin = end + 1;
  }
  std::sort(known.begin(), known.end());
  return known;
}

Vec CheckedX0(const std::vector<double>& values, const Model& model, const Context& at, Spelling spelling) {
  const ModelSpec& spec = model.spec();
  const std::string flag = Spelled("x0", spelling);
  const int n = model.state_size();
  Vec x0 = DefaultState(model);
  if (!values.empty()) {
    CheckFinite(flag, values);
    if (static_cast<int>(values.size()) != n) {
      throw std::invalid_argument(fmt::format("{} has {} values; model '{}' has {} states ({})", flag, values.size(),
                                              spec.name, n, fmt::join(spec.state_names, ", ")));
    }
    x0 = Eigen::Map<const Vec>(values.data(), n);
  }
  if (!model.InFlowSet(x0, at) && !model.InJumpSet(x0, at)) {
    throw std::invalid_argument(fmt::format("{} = {}: outside the flow set C and the jump set D of '{}'", flag,
                                            fmt::join(x0, ","), spec.name));
  }
  return x0;
}

int ModeIndex(const std::string& name, const Model& model, Spelling spelling) {
  const ModelSpec& spec = model.spec();
  if (name.empty()) return spec.default_mode;
  const std::string flag = Spelled("mode", spelling);
  if (spec.modes.empty()) {
    throw std::invalid_argument(
        fmt::format("{} {}: model '{}' has no modes (only a hybrid automaton with modes has an initial mode)", flag,
                    name, model.name()));
  }
  const auto it = std::find(spec.modes.begin(), spec.modes.end(), name);
  if (it == spec.modes.end()) {
    throw std::invalid_argument(fmt::format("{} {}: model '{}' has no mode '{}' (modes: {})", flag, name,
                                            model.name(), name, fmt::join(spec.modes, ", ")));
  }
  return static_cast<int>(it - spec.modes.begin());
}

InputSignal CheckedInputs(const std::string& path, const ModelSpec& spec, const SampleGrid& grid,
                          Spelling spelling) {
  const std::string flag = Spelled("inputs", spelling);
  InputSignal s;
  if (spec.inputs.empty()) {
    if (!path.empty())
      throw std::invalid_argument(fmt::format("{} {}: model '{}' has no inputs", flag, path, spec.name));
    return s;
  }
  const double t_last = static_cast<double>(grid.size() - 1) * grid.dt;
  if (const std::string missing = InputsWithoutDefault(spec); path.empty() && !missing.empty()) {
    throw std::invalid_argument(fmt::format("{}: model '{}' gives no default for its inputs {}; give {} FILE", flag,
                                            spec.name, missing, flag));
  }
  try {
    if (path.empty()) {
      for (long k = 0; k < grid.size(); ++k) s.times.push_back(static_cast<double>(k) * grid.dt);
      s.values = EvaluateInputDefaults(spec, s.times);
      return s;
    }
    s = ReadInputSignal(path, spec.inputs);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(fmt::format("{}{}: {}", flag, path.empty() ? "" : " " + path, e.what()));
  }
  if (const std::string e = InputRangeError(s, spec.inputs, 0.0, t_last); !e.empty()) {
    throw std::invalid_argument(fmt::format("{} {}: {}", flag, path, e));
  }
  return s;
}

std::vector<std::uint8_t> SamplesAtTimes(const std::vector<double>& times, const SampleGrid& grid,
                                         const std::string& name,
                                         const std::function<std::string(std::size_t)>& where) {
  std::vector<std::uint8_t> present(static_cast<std::size_t>(grid.size()), 0);
  std::vector<std::size_t> given_at(present.size(), 0);
  for (std::size_t i = 0; i < times.size(); ++i) {
    const double t = times[i], k = std::round(t / grid.dt);
    if (!std::isfinite(t) || k < 0.0 || k >= static_cast<double>(grid.size()) ||
        std::abs(t - k * grid.dt) > 1e-6 * grid.dt) {
      throw std::invalid_argument(
          fmt::format("{}: t = {}: not a sample time of the grid (k·dt, dt = {:g}, from 0 to {:g})", where(i),
                      t, grid.dt, static_cast<double>(grid.size() - 1) * grid.dt));
    }
    const auto at = static_cast<std::size_t>(k);
    if (present[at] != 0) {
      throw std::invalid_argument(
          fmt::format("{}: t = {}: the same sample as {}", where(i), t, where(given_at[at])));
    }
    present[at] = 1;
    given_at[at] = i;
  }
  if (std::count(present.begin(), present.end(), 1) < 2) {
    throw std::invalid_argument(fmt::format("{}: fewer than two sample times", name));
  }
  return present;
}

std::vector<std::uint8_t> CheckedSampleTimes(const std::string& path, const SampleGrid& grid,
                                             Spelling spelling) {
  const std::string name = fmt::format("{} {}", Spelled("times", spelling), path);
  CsvTable table;
  try {
    table = ReadCsv(path);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(fmt::format("{} {}", Spelled("times", spelling), e.what()));
  }
  const int column = table.Find("t");
  if (column < 0) throw std::invalid_argument(fmt::format("{}: no column t", name));
  // A row with a missing cell is not a sample (identify leaves it out too).
  std::vector<double> times;
  std::vector<long> lines;
  for (long r = 0; r < table.rows(); ++r) {
    const auto row = static_cast<std::size_t>(r);
    if (std::any_of(table.columns.begin(), table.columns.end(),
                    [&](const std::vector<double>& c) { return std::isnan(c[row]); })) {
      continue;
    }
    times.push_back(table.columns[std::size_t(column)][row]);
    lines.push_back(table.line_of_row[row]);
  }
  return SamplesAtTimes(times, grid, name,
                        [&](std::size_t i) { return fmt::format("{}:{}", name, lines[i]); });
}

}  // namespace hysid
