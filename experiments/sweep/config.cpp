#include "experiments/sweep/config.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <limits>
#include <set>
#include <sstream>
#include <stdexcept>
#include <type_traits>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/detectors/detector.hpp"
#include "core/estimators/estimator.hpp"
#include "core/identify/reconstruct.hpp"
#include "core/io/files.hpp"
#include "core/io/limits.hpp"
#include "core/io/toml_guard.hpp"
#include "core/io/toml_reader.hpp"
#include "core/model/automaton.hpp"
#include "core/model_file/input_defaults.hpp"
#include "experiments/sweep/plan.hpp"
#include "experiments/sweep/run_context.hpp"
#include "sim/model_check/model_check.hpp"

namespace hysid {
namespace {

// A computed grid value (a range's from + u·(to − from), or its log-spaced form) rounded to 12
// significant digits, so that a log range from 0.01 to 1 holds 0.1 and not 0.10000000000000006: the
// grid then matches what a user types when filtering the tables.
double ShortDecimal(double v) { return std::strtod(fmt::format("{:.12g}", v).c_str(), nullptr); }

// A value of a grid axis given twice.
template <class T>
void NoDuplicates(const TomlReader& rd, const toml::node& node, const std::string& key,
                  const std::vector<T>& v) {
  std::set<T> seen;
  for (const T& x : v) {
    if (seen.insert(x).second) continue;
    if constexpr (std::is_same_v<T, std::string>) {
      rd.Twice(&node, key, fmt::format("'{}'", x));
    } else {
      rd.Twice(&node, key, fmt::format("{}", x));
    }
  }
}

// A range { from, to, count [, log] } of a grid axis.
std::vector<double> NumberRange(const TomlReader& rd, const toml::table& t, const std::string& key) {
  rd.OnlyKeys(t, key, {"from", "to", "count", "log"});
  constexpr std::string_view kHint = "a range needs from, to and count";
  const double from = rd.Number(rd.Require(t, key, "from", kHint), key + ".from");
  const double to = rd.Number(rd.Require(t, key, "to", kHint), key + ".to");
  const toml::node& count_node = rd.Require(t, key, "count", kHint);
  const std::int64_t count = rd.Integer(count_node, key + ".count", 1);
  const bool log = t.contains("log") && rd.Boolean(*t.get("log"), key + ".log");
  CheckLimit(kMaxAxisValues, count, rd.Where(&count_node, key + ".count"));
  if (log && (from <= 0 || to <= 0)) rd.Fail(&t, key, "a log range needs from > 0 and to > 0");
  std::vector<double> out;
  for (std::int64_t i = 0; i < count; ++i) {
    const double u = count == 1 ? 0.0 : static_cast<double>(i) / static_cast<double>(count - 1);
    out.push_back(ShortDecimal(log ? std::exp(std::log(from) + u * (std::log(to) - std::log(from)))
                                   : from + u * (to - from)));
  }
  return out;
}

// A grid axis of numbers: a number, a list, or { from, to, count [, log] }. Never empty.
std::vector<double> NumberAxis(const TomlReader& rd, const toml::node& node, const std::string& key) {
  std::vector<double> out;
  if (node.is_number()) {
    out.push_back(rd.Number(node, key));
  } else if (node.is_array()) {
    out = rd.Numbers(node, key);
  } else if (node.is_table()) {
    out = NumberRange(rd, *node.as_table(), key);
  } else {
    rd.Fail(&node, key,
            fmt::format("expected a number, a list or {{ from, to, count }}, got {}",
                        TomlReader::TypeName(node)));
  }
  rd.NotEmpty(&node, key, out.size(), "value");
  return out;
}

// A grid axis of names: a string or a list of strings. Never empty.
std::vector<std::string> StringAxis(const TomlReader& rd, const toml::node& node, const std::string& key) {
  std::vector<std::string> out;
  if (node.is_array()) {
    const auto& arr = *node.as_array();
    for (std::size_t i = 0; i < arr.size(); ++i) out.push_back(rd.String(arr[i], TomlReader::Index(key, i)));
  } else if (node.is_string()) {
    out.push_back(rd.String(node, key));
  } else {
    rd.Fail(&node, key,
            fmt::format("expected a string or a list of strings, got {}", TomlReader::TypeName(node)));
  }
  rd.NotEmpty(&node, key, out.size(), "value");
  return out;
}

// model.name (a registry name) or model.file (a model file, relative to the sweep file's folder).
void ParseModelSource(const TomlReader& rd, const toml::table& t, const std::string& key,
                      const ModelRegistry& registry, SweepModel* m) {
  rd.NotBoth(t, key, "name", "file");
  if (const toml::node* file = t.get("file")) {
    const std::filesystem::path path =
        std::filesystem::path(rd.file()).parent_path() / rd.String(*file, key + ".file");
    try {
      const std::string text = ReadWholeFile(path, "model file");
      m->from_file = std::make_shared<const Model>(ParseModelText(text, path.string()));
      m->file_digest = Fnv1aDigest(text);
    } catch (const std::invalid_argument& e) {
      rd.Fail(file, key + ".file", e.what());
    }
    m->file = path.lexically_normal().string();
    m->name = m->from_file->name();
    // Each trial simulates with the model's default inputs: one missing fails every trial.
    if (const std::string missing = InputsWithoutDefault(m->from_file->spec()); !missing.empty()) {
      rd.Fail(
          file, key + ".file",
          fmt::format("{}: input {} has no input_defaults expression, and a sweep simulates every trial with "
                      "the defaults (add input_defaults = {{ NAME = \"expression of t\" }})",
                      m->file, missing));
    }
    // Unmeasured states must be reconstructible for the identifier's start (core/identify/reconstruct.hpp).
    if (const ReconstructionPlan plan = PlanReconstruction(*m->from_file, MeasuredIndices(*m->from_file)); !plan.ok()) {
      rd.Fail(file, key + ".file", fmt::format("{}: measured: {}", m->file, plan.error));
    }
    return;
  }
  const toml::node& name =
      rd.Require(t, key, "name", "the model's registry name (see `hysid models`), or file = a model file");
  m->name = rd.String(name, key + ".name");
  rd.Choice(&name, key + ".name", "model", m->name, registry.names());
}

// model.params: each value set on `model` (an unknown name or a bad value names its key).
void ParseModelParams(const TomlReader& rd, const toml::table& t, const std::string& key, Model* model,
                      SweepModel* m) {
  const toml::node* p = t.get("params");
  if (!p) return;
  for (auto&& [k, v] : rd.Table(*p, key + ".params")) {
    const std::string pk = fmt::format("{}.params.{}", key, k.str());
    const double value = rd.Number(v, pk);
    try {
      model->SetParameter(k.str(), value);
    } catch (const std::invalid_argument& e) {
      rd.Fail(&v, pk, e.what());
    }
    m->params.emplace_back(std::string(k.str()), value);
  }
}

// model.x0 (n numbers) or model.x0_range (n [lo, hi] pairs), else the model's default x0.
void ParseInitialState(const TomlReader& rd, const toml::table& t, const std::string& key, const Model& model,
                       SweepModel* m) {
  const std::size_t n = static_cast<std::size_t>(model.state_size());
  const std::string per_state = fmt::format("one per state of model '{}'", m->name);
  rd.NotBoth(t, key, "x0", "x0_range");
  if (const toml::node* x0 = t.get("x0")) {
    m->x0 = rd.Numbers(*x0, key + ".x0");
    rd.Size(x0, key + ".x0", m->x0.size(), n, per_state);
  } else if (const toml::node* range = t.get("x0_range")) {
    const toml::array& arr = rd.Array(*range, key + ".x0_range");
    rd.Size(range, key + ".x0_range", arr.size(), n, per_state);
    for (std::size_t i = 0; i < arr.size(); ++i) {
      const std::string ik = TomlReader::Index(key + ".x0_range", i);
      const std::vector<double> lohi = rd.Numbers(arr[i], ik);
      rd.Size(&arr[i], ik, lohi.size(), 2, "[lo, hi]");
      rd.AtLeast(&arr[i], TomlReader::Index(ik, 1), lohi[1], lohi[0]);
      m->x0_range.push_back({lohi[0], lohi[1]});
    }
  } else {
    m->x0 = model.spec().default_x0;
  }
}

SweepModel ParseModel(const TomlReader& rd, const toml::table& t, const std::string& key,
                      const ModelRegistry& registry) {
  rd.OnlyKeys(t, key, {"name", "file", "params", "x0", "x0_range", "t_end"});
  SweepModel m;
  ParseModelSource(rd, t, key, registry, &m);
  Model model = m.from_file ? *m.from_file : registry.Make(m.name);
  ParseModelParams(rd, t, key, &model, &m);
  ParseInitialState(rd, t, key, model, &m);
  m.t_end = model.spec().default_t_end;
  if (const toml::node* te = t.get("t_end")) {
    m.t_end = rd.Number(*te, key + ".t_end");
    rd.Above(te, key + ".t_end", m.t_end, 0.0);
  }
  return m;
}

// Every [identifier] option key: the detector options, the α estimator's options and the β
// estimator's as jump_NAME. `set` parses a TOML value into the settings; `get` gives it for ToJson.
struct IdentifierKey {
  std::string key;
  OptionType type;
  std::function<void(IdentifierSettings&, double)> set;
  std::function<double(const IdentifierSettings&)> get;
  std::function<std::string(double)> format;
  std::function<double(std::string_view)> parse;
  std::function<std::string(double)> check;  // "" or the violated constraint, as Option::Check
};

template <class S, class Member>
void AddKeys(std::vector<IdentifierKey>* keys, const std::vector<Option<S>>& table, const std::string& prefix,
             Member member) {
  for (const Option<S>& o : table) {
    keys->push_back({prefix + std::string(o.name), o.type,
                     [&o, member](IdentifierSettings& s, double v) { o.set(s.*member, v); },
                     [&o, member](const IdentifierSettings& s) { return o.get(s.*member); },
                     [&o](double v) { return o.Format(v); }, [&o](std::string_view t) { return o.Parse(t); },
                     [&o](double v) { return o.Check(v); }});
  }
}

const std::vector<IdentifierKey>& IdentifierKeys() {
  static const std::vector<IdentifierKey> keys = [] {
    std::vector<IdentifierKey> k;
    AddKeys(&k, DetectorOptions(), "", &IdentifierSettings::detector);
    AddKeys(&k, EstimatorOptions(), "", &IdentifierSettings::flow_estimator);
    AddKeys(&k, EstimatorOptions(), "jump_", &IdentifierSettings::jump_estimator);
    return k;
  }();
  return keys;
}

std::vector<OptionAxis> SweepableAxes(const IdentifierSettings& s) {
  std::vector<OptionAxis> axes;
  for (const auto& o : EstimatorOptions()) {
    if (o.sweepable)
      axes.push_back({OptionAxis::Family::kEstimator, std::string(o.name), {o.get(s.flow_estimator)}});
  }
  for (const auto& o : DetectorOptions()) {
    if (o.sweepable)
      axes.push_back({OptionAxis::Family::kDetector, std::string(o.name), {o.get(s.detector)}});
  }
  return axes;
}

std::string Constraint(const OptionAxis& axis, double v) {
  if (axis.family == OptionAxis::Family::kEstimator)
    return FindOption(EstimatorOptions(), axis.name)->Check(v);
  return FindOption(DetectorOptions(), axis.name)->Check(v);
}

std::vector<SweepModel> ParseModels(const TomlReader& rd, const toml::table& root,
                                    const ModelRegistry& registry) {
  std::vector<SweepModel> out;
  const toml::node* models = &rd.Require(root, "", "model", "a [model] table with at least name");
  if (models->is_table()) {
    out.push_back(ParseModel(rd, *models->as_table(), "model", registry));
  } else if (models->is_array()) {
    const auto& arr = *models->as_array();
    rd.NotEmpty(models, "model", arr.size(), "model");
    for (std::size_t i = 0; i < arr.size(); ++i) {
      const std::string k = fmt::format("model[{}]", i);
      out.push_back(ParseModel(rd, rd.Table(arr[i], k), k, registry));
    }
  } else {
    rd.Fail(
        models, "model",
        fmt::format("expected a [model] table or [[model]] tables, got {}", TomlReader::TypeName(*models)));
  }
  return out;
}

template <class Kind>
std::vector<Kind> KindAxis(const TomlReader& rd, const toml::table& grid, const char* name,
                           const char* fallback, Kind (*parse)(std::string_view)) {
  const std::string key = fmt::format("grid.{}", name);
  const toml::node* node = grid.get(name);
  const std::vector<std::string> names =
      node ? StringAxis(rd, *node, key) : std::vector<std::string>{fallback};
  if (node) NoDuplicates(rd, *node, key, names);
  std::vector<Kind> kinds;
  for (const std::string& n : names) {
    try {
      kinds.push_back(parse(n));
    } catch (const std::invalid_argument& e) {
      rd.Fail(node, key, e.what());
    }
  }
  return kinds;
}

// The number of cells, before EnumerateCells allocates them: per (estimator, detector), the product of
// the sizes of the axes it reads.
void CheckCellCount(const SweepConfig& c) {
  const std::string where = fmt::format("{}: [grid] cells", c.source);
  std::int64_t per_base = 0;  // cells per (model, δt, σ, refine)
  for (EstimatorKind e : c.grid.estimator) {
    for (DetectorKind d : c.grid.detector) {
      std::int64_t n = 1;
      for (const OptionAxis& a : c.grid.options) {
        if (Reads(a, e, d))
          n = CheckedProduct(kMaxCells, n, static_cast<std::int64_t>(a.values.size()), where);
      }
      per_base += n;
    }
  }
  std::int64_t cells = per_base;
  for (std::size_t n : {c.models.size(), c.grid.dt.size(), c.grid.sigma.size(), c.grid.refine.size()}) {
    cells = CheckedProduct(kMaxCells, cells, static_cast<std::int64_t>(n), where);
  }
}

void CheckGridSteps(const TomlReader& rd, const toml::table& grid, const SweepConfig& c) {
  for (double s : c.grid.sigma) {
    rd.AtLeast(grid.get("sigma"), "grid.sigma", s, 0.0);
  }
  for (double dt : c.grid.dt) {
    rd.Above(grid.get("dt"), "grid.dt", dt, 0.0);
    for (const SweepModel& m : c.models) {
      CheckLimit(kMaxSamples, static_cast<std::int64_t>(std::min(m.t_end / dt, 9e18)) + 1,
                 rd.Where(grid.get("dt"),
                          fmt::format("grid.dt = {} with t_end = {} of model '{}'", dt, m.t_end, m.name)));
      if (2 * dt > m.t_end) {
        rd.Fail(
            grid.get("dt"), "grid.dt",
            fmt::format("{} leaves fewer than 3 samples in t_end = {} of model '{}'", dt, m.t_end, m.name));
      }
    }
  }
  NoDuplicates(rd, *grid.get("sigma"), "grid.sigma", c.grid.sigma);
  NoDuplicates(rd, *grid.get("dt"), "grid.dt", c.grid.dt);
}

// The names of the plugins of `kinds` and whether one of them reads `option`.
template <class Kind>
bool AnyReads(const std::vector<Kind>& kinds, const std::string& option, std::vector<std::string>* names) {
  bool read = false;
  for (Kind k : kinds) {
    read = read || DescriptorOf(k).Reads(option);
    names->emplace_back(DescriptorOf(k).name);
  }
  return read;
}

// Refuses an option axis that no detector (estimator) of the grid reads: its values would change nothing.
void CheckAxesRead(const TomlReader& rd, const toml::table& grid, const SweepConfig& c) {
  for (const OptionAxis& a : c.grid.options) {
    const toml::node* node = grid.get(a.name);
    if (!node) continue;
    const bool detector = a.family == OptionAxis::Family::kDetector;
    std::vector<std::string> names;
    const bool read =
        detector ? AnyReads(c.grid.detector, a.name, &names) : AnyReads(c.grid.estimator, a.name, &names);
    if (!read) {
      rd.Fail(node, "grid." + a.name,
              fmt::format("no {} of the grid ({}) reads it", detector ? "detector" : "estimator",
                          fmt::join(names, ", ")));
    }
  }
}

// [grid]: after [identifier], whose values are the defaults of the option axes.
void ParseGrid(const TomlReader& rd, const toml::table& root, SweepConfig* c) {
  const toml::table& grid =
      rd.Table(rd.Require(root, "", "grid", "a [grid] table (at least sigma and dt)"), "grid");
  c->grid.options = SweepableAxes(c->identifier);
  std::vector<std::string> allowed{"sigma", "dt", "estimator", "detector", "refine"};
  for (const OptionAxis& a : c->grid.options) allowed.push_back(a.name);
  rd.OnlyKeys(grid, "grid", allowed);
  if (const toml::node* rn = grid.get("refine")) {
    c->grid.refine_axis = true;
    c->grid.refine = StringAxis(rd, *rn, "grid.refine");
    for (const std::string& m : c->grid.refine) rd.Choice(rn, "grid.refine", "refinement", m, {"none", "ml"});
    NoDuplicates(rd, *rn, "grid.refine", c->grid.refine);
  }
  c->grid.sigma = NumberAxis(rd, rd.Require(grid, "grid", "sigma"), "grid.sigma");
  c->grid.dt = NumberAxis(rd, rd.Require(grid, "grid", "dt"), "grid.dt");
  CheckGridSteps(rd, grid, *c);
  for (OptionAxis& axis : c->grid.options) {
    const toml::node* node = grid.get(axis.name);
    if (!node) continue;
    const std::string key = "grid." + axis.name;
    axis.values = NumberAxis(rd, *node, key);
    for (double v : axis.values) {
      if (std::string what = Constraint(axis, v); !what.empty())
        rd.Fail(node, key, fmt::format("{} {}", v, what));
    }
    NoDuplicates(rd, *node, key, axis.values);
  }
  if (c->oracle) {  // the true labels replace the detector: nothing of it to vary
    for (const auto& [k, v] : grid) {
      const std::string name(k.str());  // a structured binding cannot be captured by clang 14
      const bool detector_key =
          k == "detector" ||
          std::any_of(c->grid.options.begin(), c->grid.options.end(), [&](const OptionAxis& a) {
            return a.name == name && a.family == OptionAxis::Family::kDetector;
          });
      if (detector_key) rd.Fail(&v, "grid." + std::string(k.str()), "not used with identifier.oracle = true");
    }
  }
  c->grid.estimator = KindAxis(rd, grid, "estimator", "rls", &ParseKind<EstimatorKind>);
  c->grid.detector = KindAxis(rd, grid, "detector", "paper", &ParseKind<DetectorKind>);
  if (!c->oracle) CheckAxesRead(rd, grid, *c);
}

void SetIdentifierKey(const TomlReader& rd, const toml::node& v, const std::string& key,
                      const IdentifierKey& k, IdentifierSettings* s) {
  double value = 0.0;
  if (k.type == OptionType::kChoice) {
    const std::string text = rd.String(v, key);
    try {
      value = k.parse(text);
    } catch (const std::invalid_argument&) {
      rd.Fail(&v, key, fmt::format("'{}' {}", text, k.check(-1.0)));  // a choice's check lists the names
    }
  } else {
    value = k.type == OptionType::kInteger ? static_cast<double>(rd.Integer(v, key)) : rd.Number(v, key);
    if (std::string what = k.check(value); !what.empty()) rd.Fail(&v, key, fmt::format("{} {}", value, what));
  }
  k.set(*s, value);
}

void ParseIdentifier(const TomlReader& rd, const toml::table& root, SweepConfig* c) {
  const toml::node* idn = root.get("identifier");
  if (!idn) return;
  const toml::table& id = rd.Table(*idn, "identifier");
  std::vector<std::string> allowed;
  for (const IdentifierKey& k : IdentifierKeys()) allowed.push_back(k.key);
  allowed.insert(allowed.end(), {"localize", "second_pass", "sets", "known_sigma", "oracle"});
  rd.OnlyKeys(id, "identifier", allowed);
  IdentifierSettings& s = c->identifier;
  for (auto&& [k, v] : id) {
    const std::string key = fmt::format("identifier.{}", k.str());
    if (k == "localize") s.localize = rd.Boolean(v, key);
    if (k == "second_pass") s.second_pass = rd.Boolean(v, key);
    if (k == "sets") s.sets = rd.Boolean(v, key);
    if (k == "known_sigma") c->known_sigma = rd.Boolean(v, key);
    if (k == "oracle") c->oracle = rd.Boolean(v, key);
    for (const IdentifierKey& ik : IdentifierKeys()) {
      if (ik.key == k.str()) SetIdentifierKey(rd, v, key, ik, &s);
    }
  }
}

// What the identifier refuses for a model, refused when the file is read (as `hysid identify` refuses
// the flags): identifier.localize = true for a hybrid automaton or a model with inputs (the jump
// localiser fits one flow and one jump map without inputs), and on grid.estimator an estimator that
// needs a noise shape (gtls, frisch) for a model with inputs (the shape is derived without them).
void CheckSettingsForModels(const TomlReader& rd, const toml::table& root, const SweepConfig& c,
                            const ModelRegistry& registry) {
  for (std::size_t i = 0; i < c.models.size(); ++i) {
    const Model model = c.models[i].Build(registry);
    const std::string which =
        c.models.size() == 1 ? fmt::format("model '{}'", model.name()) : fmt::format("model[{}] '{}'", i, model.name());
    const bool inputs = model.input_size() > 0;
    if (c.identifier.localize && (IsAutomaton(model.spec()) || inputs)) {
      rd.Fail(root.at_path("identifier.localize").node(), "identifier.localize",
              fmt::format("{} {}, so localize = true is not available for it", which,
                          inputs ? "has inputs; the jump localiser fits flows without inputs"
                                 : "is a hybrid automaton (modes or jump maps); the jump localiser fits one flow "
                                   "and one jump map"));
    }
    for (EstimatorKind e : c.grid.estimator) {
      if (!inputs || !DescriptorOf(e).traits.needs_noise_shape) continue;
      rd.Fail(root.at_path("grid.estimator").node(), "grid.estimator",
              fmt::format("'{}' needs a noise shape, which is not derived for {} with inputs (rls, for one, needs none)",
                          ToString(e), which));
    }
  }
}

void ParseSimulator(const TomlReader& rd, const toml::table& root, SimOptions* sim) {
  const toml::node* sn = root.get("simulator");
  if (!sn) return;
  const toml::table& st = rd.Table(*sn, "simulator");
  rd.OnlyKeys(st, "simulator", {"rtol", "atol", "max_steps", "max_jumps"});
  for (auto&& [k, v] : st) {
    const std::string key = fmt::format("simulator.{}", k.str());
    for (auto [name, tol] : {std::pair{"rtol", &sim->rtol}, std::pair{"atol", &sim->atol}}) {
      if (k != name) continue;
      *tol = rd.Number(v, key);
      rd.Above(&v, key, *tol, 0.0);
    }
    if (k == "max_steps") sim->max_steps = rd.Integer(v, key, 1);
    if (k == "max_jumps")
      sim->max_jumps = static_cast<int>(rd.Integer(v, key, 1, std::numeric_limits<int>::max()));
  }
}

void ParseRun(const TomlReader& rd, const toml::table& root, SweepConfig* c) {
  const toml::node* rn = root.get("run");
  if (!rn) return;
  const toml::table& run = rd.Table(*rn, "run");
  rd.OnlyKeys(run, "run", {"trials", "seed", "out"});
  for (auto&& [k, v] : run) {
    const std::string key = fmt::format("run.{}", k.str());
    if (k == "trials") {
      c->trials = rd.Integer(v, key, 1);
      CheckLimit(kMaxTrials, c->trials, rd.Where(&v, key));
    }
    if (k == "seed") {
      c->seed = static_cast<std::uint64_t>(rd.Integer(v, key, 0));
    }
    if (k == "out") c->out = rd.String(v, key);
  }
}

// [summary] baseline = { key = value, ... }: each value must be on the grid's axis (sigma, estimator,
// detector, refine or a sweepable option such as r); the detector named, if any, must read the options
// named.
void ParseSummary(const TomlReader& rd, const toml::table& t, SweepConfig* c) {
  rd.OnlyKeys(t, "summary", {"baseline"});
  const toml::node* bn = t.get("baseline");
  if (bn == nullptr) return;
  const toml::table& b = rd.Table(*bn, "summary.baseline");
  const SweepGrid& g = c->grid;
  std::vector<std::string> allowed{"sigma", "estimator", "detector"};
  if (g.refine_axis) allowed.emplace_back("refine");
  for (const OptionAxis& a : g.options) allowed.push_back(a.name);
  rd.OnlyKeys(b, "summary.baseline", allowed);
  rd.NotEmpty(bn, "summary.baseline", b.size(), fmt::format("of {}", fmt::join(allowed, ", ")));
  for (auto&& [k, v] : b) {
    const std::string key = fmt::format("summary.baseline.{}", k.str());
    std::string text;
    if (k == "estimator" || k == "detector" || k == "refine") {
      text = rd.String(v, key);
      std::vector<std::string> axis;
      if (k == "estimator") {
        for (EstimatorKind e : g.estimator) axis.emplace_back(ToString(e));
      } else if (k == "detector") {
        for (DetectorKind d : g.detector) axis.emplace_back(ToString(d));
      } else {
        axis = g.refine;
      }
      if (std::find(axis.begin(), axis.end(), text) == axis.end()) {
        rd.Fail(&v, key, fmt::format("'{}' is not on grid.{} ({})", text, k.str(), fmt::join(axis, ", ")));
      }
    } else {
      const double x = rd.Number(v, key);
      const std::string name(k.str());  // a structured binding cannot be captured by clang 14
      const auto it = std::find_if(g.options.begin(), g.options.end(),
                                   [&](const OptionAxis& a) { return a.name == name; });
      const std::vector<double>& axis = k == "sigma" ? g.sigma : it->values;
      if (std::find(axis.begin(), axis.end(), x) == axis.end()) {
        rd.Fail(&v, key, fmt::format("{} is not on grid.{} ({})", x, k.str(), fmt::join(axis, ", ")));
      }
      text = fmt::format("{}", x);
    }
    c->baseline.emplace_back(std::string(k.str()), text);
  }
  if (const toml::node* d = b.get("detector")) {
    const DetectorDescriptor& det = DescriptorOf(ParseKind<DetectorKind>(*d->value<std::string>()));
    for (const OptionAxis& a : g.options) {
      if (a.family == OptionAxis::Family::kDetector && b.contains(a.name) && !det.Reads(a.name)) {
        rd.Fail(b.get(a.name), "summary.baseline." + a.name,
                fmt::format("detector '{}' does not use {}", det.name, a.name));
      }
    }
  }
}

}  // namespace

Model SweepModel::Build(const ModelRegistry& registry) const {
  Model model = from_file ? *from_file : registry.Make(name);
  for (const auto& [k, v] : params) model.SetParameter(k, v);
  return model;
}

SweepConfig ParseSweepText(std::string_view text, const std::string& name, const ModelRegistry& registry) {
  const TomlReader rd(name);
  const toml::table root = ParseToml(text, name);
  rd.OnlyKeys(root, "", {"model", "grid", "identifier", "simulator", "run", "summary"});
  SweepConfig c;
  c.source = name;
  c.models = ParseModels(rd, root, registry);
  ParseIdentifier(rd, root, &c);
  ParseGrid(rd, root, &c);
  CheckSettingsForModels(rd, root, c, registry);
  ParseSimulator(rd, root, &c.simulator);
  ParseRun(rd, root, &c);
  CheckCellCount(c);
  if (const toml::node* sn = root.get("summary")) ParseSummary(rd, rd.Table(*sn, "summary"), &c);
  return c;
}

SweepConfig ParseSweepFile(const std::filesystem::path& path, const ModelRegistry& registry) {
  const std::string text = ReadWholeFile(path, "sweep file");
  if (text.find_first_not_of(" \t\r\n") == std::string::npos) {
    throw std::invalid_argument(fmt::format("{}: empty sweep file", path.string()));
  }
  return ParseSweepText(text, path.string(), registry);
}

nlohmann::json SweepConfig::ToJson() const {
  nlohmann::json ms = nlohmann::json::array();
  for (const SweepModel& m : models) {
    nlohmann::json params = nlohmann::json::array();
    for (const auto& [k, v] : m.params) params.push_back({k, v});
    nlohmann::json j = {{"name", m.name}, {"params", params}, {"t_end", m.t_end}};
    if (m.from_file) {
      j["definition"] = ModelDefinitionJson(*m.from_file);  // what the file defines, readable
      j["file_digest"] = m.file_digest;                     // and every byte of it
    }
    if (!m.x0_range.empty()) {
      j["x0_range"] = m.x0_range;
    } else {
      j["x0"] = m.x0;
    }
    ms.push_back(j);
  }
  nlohmann::json g = {{"dt", grid.dt}, {"sigma", grid.sigma}};
  for (const OptionAxis& a : grid.options) g[a.name] = a.values;
  for (EstimatorKind k : grid.estimator) g["estimator"].push_back(ToString(k));
  for (DetectorKind k : grid.detector) g["detector"].push_back(ToString(k));
  if (grid.refine_axis) g["refine"] = grid.refine;
  nlohmann::json id = {{"localize", identifier.localize},
                       {"second_pass", identifier.second_pass},
                       {"sets", identifier.sets},
                       {"known_sigma", known_sigma},
                       {"oracle", oracle}};
  for (const IdentifierKey& k : IdentifierKeys()) {
    const double v = k.get(identifier);
    if (k.type == OptionType::kChoice) {
      id[k.key] = k.format(v);
    } else {
      id[k.key] = v;
    }
  }
  nlohmann::json j = {
      {"model", ms},
      {"grid", g},
      {"identifier", id},
      {"simulator",
       {{"rtol", simulator.rtol},
        {"atol", simulator.atol},
        {"max_steps", simulator.max_steps},
        {"max_jumps", simulator.max_jumps}}},
      {"run", {{"trials", trials}, {"seed", seed}}},
  };
  // The noise scheme: a run directory written with another one is refused, not mixed in.
  j["noise"] = "ziggurat stream per (seed, trial, model, dt)";
  if (!baseline.empty()) {
    nlohmann::json b = nlohmann::json::object();
    for (const auto& [k, v] : baseline) b[k] = v;
    j["summary"] = {{"baseline", b}};
  }
  return j;
}

std::string SweepConfig::Hash() const { return Fnv1aDigest(ToJson().dump()); }

std::string Fnv1aDigest(std::string_view bytes) {
  std::uint64_t h = 1469598103934665603ull;
  for (const unsigned char ch : bytes) {
    h ^= ch;
    h *= 1099511628211ull;
  }
  return fmt::format("{:016x}", h);
}

std::string DescribeConfigChange(const nlohmann::json& before, const SweepConfig& now) {
  const nlohmann::json patch = nlohmann::json::diff(before, now.ToJson());
  if (patch.empty()) return "";
  // A JSON pointer (/model/0/file_digest) as a key (model[0].file_digest).
  const std::string pointer = patch[0].value("path", "");
  std::string key;
  std::vector<std::string> parts;
  for (std::size_t at = 1; at <= pointer.size();) {
    const std::size_t end = std::min(pointer.find('/', at), pointer.size());
    parts.push_back(pointer.substr(at, end - at));
    at = end + 1;
  }
  for (const std::string& part : parts) {
    const bool index = !part.empty() && part.find_first_not_of("0123456789") == std::string::npos;
    key += index ? "[" + part + "]" : (key.empty() ? "" : ".") + part;
  }
  if (key.empty()) return "the configuration";
  if (parts.size() >= 3 && parts[0] == "model" && (parts[2] == "file_digest" || parts[2] == "definition")) {
    const std::size_t m = std::stoul(parts[1]);
    if (m < now.models.size()) return fmt::format("{} (the model file {} changed)", key, now.models[m].file);
  }
  return key;
}

}  // namespace hysid
