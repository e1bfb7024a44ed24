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

#include <fmt/format.h>
#include <fmt/ranges.h>
// toml++ 3.3.0 turns its internal assertions into __builtin_assume under NDEBUG (clang) and into
// assert() otherwise; both are reachable from malformed input (upstream issues 294/295). With NDEBUG
// undefined and TOML_ASSERT a no-op, neither happens in any build type: the parser's own checks
// report the error. Non-ASCII input that reaches its __builtin_unreachable is refused before parsing
// (CheckTomlCharacters, core/io/toml_guard.hpp).
#pragma push_macro("NDEBUG")
#undef NDEBUG
#define TOML_ASSERT(expr) static_cast<void>(0)
#include <toml++/toml.h>
#pragma pop_macro("NDEBUG")

#include "core/detectors/detector.hpp"
#include "core/estimators/estimator.hpp"
#include "core/io/files.hpp"
#include "core/io/limits.hpp"
#include "core/io/toml_guard.hpp"
#include "core/model_file/model_file.hpp"
#include "experiments/sweep/plan.hpp"
#include "experiments/sweep/run_context.hpp"

namespace hysid {
namespace {

// A computed grid value (a range's from + u·(to − from), or its log-spaced form) rounded to 12
// significant digits, so that a log range from 0.01 to 1 holds 0.1 and not 0.10000000000000006: the
// grid then matches what a user types when filtering the tables.
double ShortDecimal(double v) { return std::strtod(fmt::format("{:.12g}", v).c_str(), nullptr); }

// Reads one TOML document; every error names file, line and the dotted key.
class Reader {
 public:
  explicit Reader(std::string file) : file_(std::move(file)) {}

  static long Line(const toml::node* node) { return node ? static_cast<long>(node->source().begin.line) : 0; }

  [[noreturn]] void Fail(const toml::node* node, const std::string& key, const std::string& what) const {
    const long line = Line(node);
    if (line > 0) throw std::invalid_argument(fmt::format("{}:{}: {}: {}", file_, line, key, what));
    throw std::invalid_argument(fmt::format("{}: {}: {}", file_, key, what));
  }

  // Rejects keys that are not in `allowed`.
  void OnlyKeys(const toml::table& table, const std::string& prefix,
                const std::vector<std::string>& allowed) const {
    for (auto&& [k, v] : table) {
      if (std::find(allowed.begin(), allowed.end(), k.str()) == allowed.end()) {
        Fail(&v, Join(prefix, k.str()),
             fmt::format("unknown key (known here: {})", fmt::join(allowed, ", ")));
      }
    }
  }

  static std::string Join(const std::string& prefix, std::string_view key) {
    return prefix.empty() ? std::string(key) : fmt::format("{}.{}", prefix, key);
  }

  double Number(const toml::node& node, const std::string& key) const {
    if (!node.is_number()) Fail(&node, key, fmt::format("expected a number, got {}", TypeName(node)));
    const double v = *node.value<double>();
    if (!std::isfinite(v)) Fail(&node, key, "must be finite");
    return v;
  }

  // A 64-bit integer in [lo, hi]; the error quotes the value as written.
  std::int64_t Integer(const toml::node& node, const std::string& key,
                       std::int64_t lo = std::numeric_limits<std::int64_t>::min(),
                       std::int64_t hi = std::numeric_limits<std::int64_t>::max()) const {
    if (!node.is_integer()) Fail(&node, key, fmt::format("expected an integer, got {}", TypeName(node)));
    const std::int64_t v = *node.value_exact<std::int64_t>();
    if (v < lo || v > hi) Fail(&node, key, fmt::format("{} is out of range [{}, {}]", v, lo, hi));
    return v;
  }
  int Int(const toml::node& node, const std::string& key, int lo) const {
    return static_cast<int>(Integer(node, key, lo, std::numeric_limits<int>::max()));
  }

  bool Boolean(const toml::node& node, const std::string& key) const {
    if (!node.is_boolean()) Fail(&node, key, fmt::format("expected true or false, got {}", TypeName(node)));
    return *node.value<bool>();
  }

  std::string String(const toml::node& node, const std::string& key) const {
    if (!node.is_string()) Fail(&node, key, fmt::format("expected a string, got {}", TypeName(node)));
    return *node.value<std::string>();
  }

  const toml::table& Table(const toml::node& node, const std::string& key) const {
    if (!node.is_table()) Fail(&node, key, fmt::format("expected a table, got {}", TypeName(node)));
    return *node.as_table();
  }

  std::vector<double> NumberList(const toml::node& node, const std::string& key) const {
    if (!node.is_array()) Fail(&node, key, fmt::format("expected a list of numbers, got {}", TypeName(node)));
    std::vector<double> out;
    const auto& arr = *node.as_array();
    for (std::size_t i = 0; i < arr.size(); ++i) out.push_back(Number(arr[i], fmt::format("{}[{}]", key, i)));
    return out;
  }

  // A grid axis of numbers: a number, a list, or { from, to, count [, log] }. Never empty.
  std::vector<double> NumberAxis(const toml::node& node, const std::string& key) const {
    std::vector<double> out;
    if (node.is_number()) {
      out.push_back(Number(node, key));
    } else if (node.is_array()) {
      out = NumberList(node, key);
    } else if (node.is_table()) {
      const auto& t = *node.as_table();
      OnlyKeys(t, key, {"from", "to", "count", "log"});
      for (const char* k : {"from", "to", "count"}) {
        if (!t.contains(k))
          Fail(&node, key, fmt::format("a range needs from, to and count (missing '{}')", k));
      }
      const double from = Number(*t.get("from"), key + ".from");
      const double to = Number(*t.get("to"), key + ".to");
      const std::int64_t count = Integer(*t.get("count"), key + ".count");
      const bool log = t.contains("log") && Boolean(*t.get("log"), key + ".log");
      if (count < 1) Fail(t.get("count"), key + ".count", fmt::format("{} must be ≥ 1", count));
      CheckLimit(kMaxAxisValues, count, fmt::format("{}:{}: {}.count", file_, Line(t.get("count")), key));
      if (log && (from <= 0 || to <= 0)) Fail(&node, key, "a log range needs from > 0 and to > 0");
      for (std::int64_t i = 0; i < count; ++i) {
        const double u = count == 1 ? 0.0 : static_cast<double>(i) / static_cast<double>(count - 1);
        out.push_back(ShortDecimal(log ? std::exp(std::log(from) + u * (std::log(to) - std::log(from)))
                                       : from + u * (to - from)));
      }
    } else {
      Fail(&node, key,
           fmt::format("expected a number, a list or {{ from, to, count }}, got {}", TypeName(node)));
    }
    if (out.empty()) Fail(&node, key, "empty grid: give at least one value");
    return out;
  }

  std::vector<std::string> StringAxis(const toml::node& node, const std::string& key) const {
    std::vector<std::string> out;
    if (node.is_string()) {
      out.push_back(String(node, key));
    } else if (node.is_array()) {
      const auto& arr = *node.as_array();
      for (std::size_t i = 0; i < arr.size(); ++i)
        out.push_back(String(arr[i], fmt::format("{}[{}]", key, i)));
    } else {
      Fail(&node, key, fmt::format("expected a string or a list of strings, got {}", TypeName(node)));
    }
    if (out.empty()) Fail(&node, key, "empty grid: give at least one value");
    return out;
  }

  static std::string TypeName(const toml::node& node) {
    switch (node.type()) {
      case toml::node_type::table: return "a table";
      case toml::node_type::array: return "a list";
      case toml::node_type::string: return "a string";
      case toml::node_type::integer: return "an integer";
      case toml::node_type::floating_point: return "a number";
      case toml::node_type::boolean: return "a boolean";
      default: return "a date/time";
    }
  }

  const std::string& file() const { return file_; }

 private:
  std::string file_;
};

template <class T>
void NoDuplicates(const Reader& rd, const toml::node& node, const std::string& key, const std::vector<T>& v) {
  std::set<T> seen;
  for (const T& x : v) {
    if (!seen.insert(x).second) rd.Fail(&node, key, fmt::format("value {} appears twice", x));
  }
}

// model.name (a registry name) or model.file (a model file, relative to the sweep file's folder).
void ParseModelSource(const Reader& rd, const toml::table& t, const std::string& key,
                      const ModelRegistry& registry, SweepModel* m) {
  const toml::node* name = t.get("name");
  const toml::node* file = t.get("file");
  if (name && file) rd.Fail(file, key + ".file", "give name or file, not both");
  if (file) {
    const std::filesystem::path path =
        std::filesystem::path(rd.file()).parent_path() / rd.String(*file, key + ".file");
    try {
      m->from_file = std::make_shared<const Model>(LoadModelFile(path));
    } catch (const std::invalid_argument& e) {
      rd.Fail(file, key + ".file", e.what());
    }
    m->file = path.lexically_normal().string();
    m->name = m->from_file->name();
    return;
  }
  if (!name)
    rd.Fail(&t, key + ".name",
            "missing (the model's registry name, see `hysid models`, or file = a model file)");
  m->name = rd.String(*name, key + ".name");
  if (!registry.Contains(m->name)) {
    std::vector<std::string> names = registry.names();
    rd.Fail(name, key + ".name",
            fmt::format("unknown model '{}' (known: {})", m->name, fmt::join(names, ", ")));
  }
}

// model.params: each value set on `model` (an unknown name or a bad value names its key).
void ParseModelParams(const Reader& rd, const toml::table& t, const std::string& key, Model* model,
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
void ParseInitialState(const Reader& rd, const toml::table& t, const std::string& key, const Model& model,
                       SweepModel* m) {
  const int n = model.state_size();
  const toml::node* x0 = t.get("x0");
  const toml::node* range = t.get("x0_range");
  if (x0 && range) rd.Fail(range, key + ".x0_range", "give x0 or x0_range, not both");
  if (x0) {
    m->x0 = rd.NumberList(*x0, key + ".x0");
    if (static_cast<int>(m->x0.size()) != n) {
      rd.Fail(x0, key + ".x0",
              fmt::format("has {} entries, model '{}' has {} states", m->x0.size(), m->name, n));
    }
  } else if (range) {
    if (!range->is_array()) rd.Fail(range, key + ".x0_range", "expected a list of [lo, hi] pairs");
    const auto& arr = *range->as_array();
    if (static_cast<int>(arr.size()) != n) {
      rd.Fail(range, key + ".x0_range",
              fmt::format("has {} entries, model '{}' has {} states", arr.size(), m->name, n));
    }
    for (std::size_t i = 0; i < arr.size(); ++i) {
      const std::string ik = fmt::format("{}.x0_range[{}]", key, i);
      const std::vector<double> lohi = rd.NumberList(arr[i], ik);
      if (lohi.size() != 2 || lohi[0] > lohi[1]) rd.Fail(&arr[i], ik, "expected [lo, hi] with lo ≤ hi");
      m->x0_range.push_back({lohi[0], lohi[1]});
    }
  } else {
    m->x0 = model.spec().default_x0;
  }
}

SweepModel ParseModel(const Reader& rd, const toml::table& t, const std::string& key,
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
    if (m.t_end <= 0) rd.Fail(te, key + ".t_end", fmt::format("{} must be > 0", m.t_end));
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
  std::function<void(double)> require;
};

template <class S, class Member>
void AddKeys(std::vector<IdentifierKey>* keys, const std::vector<Option<S>>& table, const std::string& prefix,
             Member member) {
  for (const Option<S>& o : table) {
    keys->push_back({prefix + std::string(o.name), o.type,
                     [&o, member](IdentifierSettings& s, double v) { o.set(s.*member, v); },
                     [&o, member](const IdentifierSettings& s) { return o.get(s.*member); },
                     [&o](double v) { return o.Format(v); }, [&o](std::string_view t) { return o.Parse(t); },
                     [&o](double v) { o.Require(v); }});
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

std::vector<SweepModel> ParseModels(const Reader& rd, const toml::table& root,
                                    const ModelRegistry& registry) {
  std::vector<SweepModel> out;
  const toml::node* models = root.get("model");
  if (!models) rd.Fail(nullptr, "model", "missing: a [model] table with at least name");
  if (models->is_table()) {
    out.push_back(ParseModel(rd, *models->as_table(), "model", registry));
  } else if (models->is_array()) {
    const auto& arr = *models->as_array();
    if (arr.empty()) rd.Fail(models, "model", "empty grid: give at least one model");
    for (std::size_t i = 0; i < arr.size(); ++i) {
      const std::string k = fmt::format("model[{}]", i);
      out.push_back(ParseModel(rd, rd.Table(arr[i], k), k, registry));
    }
  } else {
    rd.Fail(models, "model", "expected a [model] table or [[model]] tables");
  }
  return out;
}

template <class Kind>
std::vector<Kind> KindAxis(const Reader& rd, const toml::table& grid, const char* name, const char* fallback,
                           Kind (*parse)(std::string_view)) {
  const std::string key = fmt::format("grid.{}", name);
  const toml::node* node = grid.get(name);
  const std::vector<std::string> names =
      node ? rd.StringAxis(*node, key) : std::vector<std::string>{fallback};
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

void CheckGridSteps(const Reader& rd, const toml::table& grid, const SweepConfig& c) {
  for (double s : c.grid.sigma) {
    if (s < 0) rd.Fail(grid.get("sigma"), "grid.sigma", fmt::format("{} must be ≥ 0", s));
  }
  for (double dt : c.grid.dt) {
    if (dt <= 0) rd.Fail(grid.get("dt"), "grid.dt", fmt::format("{} must be > 0", dt));
    for (const SweepModel& m : c.models) {
      CheckLimit(kMaxSamples, static_cast<std::int64_t>(std::min(m.t_end / dt, 9e18)) + 1,
                 fmt::format("{}:{}: grid.dt = {} with t_end = {} of model '{}'", c.source,
                             Reader::Line(grid.get("dt")), dt, m.t_end, m.name));
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

// [grid]: after [identifier], whose values are the defaults of the option axes.
void ParseGrid(const Reader& rd, const toml::table& root, SweepConfig* c) {
  const toml::node* grid_node = root.get("grid");
  if (!grid_node) rd.Fail(nullptr, "grid", "missing: a [grid] table (at least sigma and dt)");
  const toml::table& grid = rd.Table(*grid_node, "grid");
  c->grid.options = SweepableAxes(c->identifier);
  std::vector<std::string> allowed{"sigma", "dt", "estimator", "detector", "refine"};
  for (const OptionAxis& a : c->grid.options) allowed.push_back(a.name);
  rd.OnlyKeys(grid, "grid", allowed);
  if (const toml::node* rn = grid.get("refine")) {
    c->grid.refine_axis = true;
    c->grid.refine = rd.StringAxis(*rn, "grid.refine");
    for (const std::string& m : c->grid.refine) {
      if (m != "none" && m != "ml")
        rd.Fail(rn, "grid.refine", fmt::format("unknown '{}' (known: none, ml)", m));
    }
    NoDuplicates(rd, *rn, "grid.refine", c->grid.refine);
  }
  for (const char* k : {"sigma", "dt"}) {
    if (!grid.contains(k)) rd.Fail(grid_node, fmt::format("grid.{}", k), "missing");
  }
  c->grid.sigma = rd.NumberAxis(*grid.get("sigma"), "grid.sigma");
  c->grid.dt = rd.NumberAxis(*grid.get("dt"), "grid.dt");
  CheckGridSteps(rd, grid, *c);
  for (OptionAxis& axis : c->grid.options) {
    const toml::node* node = grid.get(axis.name);
    if (!node) continue;
    const std::string key = "grid." + axis.name;
    axis.values = rd.NumberAxis(*node, key);
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
}

void SetIdentifierKey(const Reader& rd, const toml::node& v, const std::string& key, const IdentifierKey& k,
                      IdentifierSettings* s) {
  double value = 0.0;
  try {
    if (k.type == OptionType::kChoice) {
      value = k.parse(rd.String(v, key));
    } else {
      value = k.type == OptionType::kInteger ? static_cast<double>(rd.Integer(v, key)) : rd.Number(v, key);
      k.require(value);
    }
  } catch (const std::invalid_argument& e) {
    rd.Fail(&v, key, e.what());
  }
  k.set(*s, value);
}

void ParseIdentifier(const Reader& rd, const toml::table& root, SweepConfig* c) {
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

void ParseSimulator(const Reader& rd, const toml::table& root, SimOptions* sim) {
  const toml::node* sn = root.get("simulator");
  if (!sn) return;
  const toml::table& st = rd.Table(*sn, "simulator");
  rd.OnlyKeys(st, "simulator", {"rtol", "atol", "max_steps", "max_jumps"});
  for (auto&& [k, v] : st) {
    const std::string key = fmt::format("simulator.{}", k.str());
    if (k == "rtol") sim->rtol = rd.Number(v, key);
    if (k == "atol") sim->atol = rd.Number(v, key);
    if (k == "max_steps") sim->max_steps = rd.Integer(v, key, 1);
    if (k == "max_jumps") sim->max_jumps = rd.Int(v, key, 1);
    std::string error;
    if (!sim->IsValid(&error)) rd.Fail(&v, key, error);
  }
}

void ParseRun(const Reader& rd, const toml::table& root, SweepConfig* c) {
  const toml::node* rn = root.get("run");
  if (!rn) return;
  const toml::table& run = rd.Table(*rn, "run");
  rd.OnlyKeys(run, "run", {"trials", "seed", "out"});
  for (auto&& [k, v] : run) {
    const std::string key = fmt::format("run.{}", k.str());
    if (k == "trials") {
      c->trials = rd.Integer(v, key);
      if (c->trials < 1) rd.Fail(&v, key, fmt::format("{} must be ≥ 1", c->trials));
      CheckLimit(kMaxTrials, c->trials, fmt::format("{}:{}: {}", c->source, Reader::Line(&v), key));
    }
    if (k == "seed") {
      const std::int64_t seed = rd.Integer(v, key);
      if (seed < 0) rd.Fail(&v, key, fmt::format("{} must be ≥ 0", seed));
      c->seed = static_cast<std::uint64_t>(seed);
    }
    if (k == "out") c->out = rd.String(v, key);
  }
}

// [summary] baseline = { key = value, ... }: each value must be on the grid's axis (sigma, estimator,
// detector, refine or a sweepable option such as r); the detector named, if any, must read the options
// named.
void ParseSummary(const Reader& rd, const toml::table& t, SweepConfig* c) {
  rd.OnlyKeys(t, "summary", {"baseline"});
  const toml::node* bn = t.get("baseline");
  if (bn == nullptr) return;
  const toml::table& b = rd.Table(*bn, "summary.baseline");
  const SweepGrid& g = c->grid;
  std::vector<std::string> allowed{"sigma", "estimator", "detector"};
  if (g.refine_axis) allowed.emplace_back("refine");
  for (const OptionAxis& a : g.options) allowed.push_back(a.name);
  rd.OnlyKeys(b, "summary.baseline", allowed);
  if (b.empty())
    rd.Fail(bn, "summary.baseline", fmt::format("empty: name at least one of {}", fmt::join(allowed, ", ")));
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
  const Reader rd(name);
  const toml::table root = ParseToml(text, name);
  rd.OnlyKeys(root, "", {"model", "grid", "identifier", "simulator", "run", "summary"});
  SweepConfig c;
  c.source = name;
  c.models = ParseModels(rd, root, registry);
  ParseIdentifier(rd, root, &c);
  ParseGrid(rd, root, &c);
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
    if (m.from_file) j["definition"] = ModelDefinitionJson(*m.from_file);  // all the file defines
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

std::string SweepConfig::Hash() const {
  const std::string text = ToJson().dump();
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char ch : text) {
    h ^= ch;
    h *= 1099511628211ull;
  }
  return fmt::format("{:016x}", h);
}

}  // namespace hysid
