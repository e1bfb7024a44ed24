#include "core/model_file/model_file.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <stdexcept>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <muParser.h>

#include "core/io/files.hpp"
#include "core/io/limits.hpp"
#include "core/io/toml_guard.hpp"
#include "core/io/toml_reader.hpp"

namespace hysid {
namespace {

// A matrix of expressions, column-major: constant entries are stored as numbers, the others are
// joined into one muParser expression list "e1, e2, ..." evaluated with one call.
struct ExprMatrix {
  Eigen::Index rows = 0, cols = 0;
  std::vector<double> constant;     // rows·cols values (0 where the entry is an expression)
  std::vector<Eigen::Index> index;  // column-major position of each expression
  std::vector<std::string> text;    // every entry as written (for the equations)
  std::string joined;               // the expressions, comma-separated
};

// The parsed file, shared (immutable) by every copy of the model.
struct Definition {
  std::uint64_t id = 0;
  ModelSpec spec;
  ExprMatrix phi, psi, guards;  // guards: |guards| × 1
  std::string in_c, in_d, distance;
  std::vector<ExprMatrix> project;               // per guard: assigned states × 1 (may be empty)
  std::vector<std::vector<int>> project_states;  // per guard: which state each entry assigns
};

std::atomic<std::uint64_t> next_definition_id{1};

// One thread's compiled parsers; `var` holds ξ, bound to the state names.
struct Compiled {
  std::array<double, Model::kMaxStates> var{};
  mu::Parser phi, psi, guards, in_c, in_d, distance;
  std::vector<mu::Parser> project;
};

void Bind(mu::Parser& p, const Definition& def, Compiled& c, const std::string& expr) {
  for (std::size_t i = 0; i < def.spec.state_names.size(); ++i)
    p.DefineVar(def.spec.state_names[i], &c.var[i]);
  p.SetExpr(expr.empty() ? "0" : expr);
}

std::unique_ptr<Compiled> Compile(const Definition& def) {
  auto c = std::make_unique<Compiled>();
  Bind(c->phi, def, *c, def.phi.joined);
  Bind(c->psi, def, *c, def.psi.joined);
  Bind(c->guards, def, *c, def.guards.joined);
  Bind(c->in_c, def, *c, def.in_c);
  Bind(c->in_d, def, *c, def.in_d);
  Bind(c->distance, def, *c, def.distance);
  c->project.resize(def.project.size());
  for (std::size_t g = 0; g < def.project.size(); ++g) Bind(c->project[g], def, *c, def.project[g].joined);
  return c;
}

// This thread's parsers for `def` (muParser's evaluation is not thread-safe: it writes a stack
// buffer inside the parser). The last definition used is remembered, so the look-up is one compare.
Compiled& Local(const std::shared_ptr<const Definition>& def) {
  thread_local std::uint64_t last_id = 0;
  thread_local Compiled* last = nullptr;
  if (last_id == def->id) return *last;
  thread_local std::map<std::uint64_t, std::pair<std::weak_ptr<const Definition>, std::unique_ptr<Compiled>>>
      cache;
  std::erase_if(cache, [](const auto& e) { return e.second.first.expired(); });
  auto it = cache.find(def->id);
  if (it == cache.end()) it = cache.emplace(def->id, std::pair{std::weak_ptr(def), Compile(*def)}).first;
  last_id = def->id;
  last = it->second.second.get();
  return *last;
}

void Load(Compiled& c, const double* x, std::size_t n) { std::copy(x, x + n, c.var.begin()); }

// Fills out (column-major, rows·cols) with the matrix at the loaded state.
void Evaluate(const ExprMatrix& m, const mu::Parser& p, double* out) {
  std::copy(m.constant.begin(), m.constant.end(), out);
  if (m.index.empty()) return;
  int count = 0;
  const double* v = p.Eval(count);
  for (std::size_t k = 0; k < m.index.size(); ++k) out[m.index[k]] = v[k];
}

// The HybridModel struct over a Definition.
struct FileModel {
  std::shared_ptr<const Definition> def;

  ModelSpec Spec() const { return def->spec; }
  void Phi(ConstVecRef x, MatRef phi) const {
    Compiled& c = Local(def);
    Load(c, x.data(), static_cast<std::size_t>(x.size()));
    Evaluate(def->phi, c.phi, phi.data());
  }
  void PhiColumns(const double* x, Eigen::Index count, double* phi) const {
    Compiled& c = Local(def);
    const Eigen::Index n = def->phi.rows, size = def->phi.rows * def->phi.cols;
    for (Eigen::Index k = 0; k < count; ++k) {
      Load(c, x + k * n, static_cast<std::size_t>(n));
      Evaluate(def->phi, c.phi, phi + k * size);
    }
  }
  void Psi(ConstVecRef x, MatRef psi) const {
    Compiled& c = Local(def);
    Load(c, x.data(), static_cast<std::size_t>(x.size()));
    Evaluate(def->psi, c.psi, psi.data());
  }
  void Guards(ConstVecRef x, VecRef h) const {
    Compiled& c = Local(def);
    Load(c, x.data(), static_cast<std::size_t>(x.size()));
    Evaluate(def->guards, c.guards, h.data());
  }
  bool InFlowSet(ConstVecRef x) const { return Test(x, &Compiled::in_c); }
  bool InJumpSet(ConstVecRef x) const { return Test(x, &Compiled::in_d); }
  bool ProvidesJumpSetDistance() const { return !def->distance.empty(); }
  double DistanceToJumpSet(ConstVecRef x) const {
    if (def->distance.empty()) return std::numeric_limits<double>::quiet_NaN();
    Compiled& c = Local(def);
    Load(c, x.data(), static_cast<std::size_t>(x.size()));
    return c.distance.Eval();
  }
  void ProjectOntoGuard(int guard, VecRef x) const {
    const auto g = static_cast<std::size_t>(guard);
    if (g >= def->project.size() || def->project[g].rows == 0) return;
    Compiled& c = Local(def);
    Load(c, x.data(), static_cast<std::size_t>(x.size()));
    std::array<double, Model::kMaxStates> value{};
    Evaluate(def->project[g], c.project[g], value.data());
    for (std::size_t k = 0; k < def->project_states[g].size(); ++k) x[def->project_states[g][k]] = value[k];
  }

 private:
  bool Test(ConstVecRef x, mu::Parser Compiled::*which) const {
    Compiled& c = Local(def);
    Load(c, x.data(), static_cast<std::size_t>(x.size()));
    return (c.*which).Eval() != 0.0;
  }
};

// ---------------------------------------------------------------------------------------------
// Reading the TOML file (core/io/toml_reader.hpp): every error names the file, the line and the key.

// Whether `expr` holds muParser's assignment operator ("x = 1" written for "x == 1"), read with the
// parser's own operator table in its order ("<=", ">=", "!=", "==" before "="), as its tokenizer reads
// operators. Assignment is the one operator with a side effect: it writes to the state variable that
// every later entry evaluated in the same call reads.
bool HasAssignment(const mu::Parser& p, std::string_view expr) {
  const mu::char_type** ops = p.GetOprtDef();
  for (std::size_t i = 0; i < expr.size();) {
    std::size_t step = 1;
    for (int k = 0; ops[k] != nullptr; ++k) {
      const std::string_view op(ops[k]);
      if (expr.substr(i, op.size()) != op) continue;
      if (k == mu::cmASSIGN) return true;
      step = op.size();
      break;
    }
    i += step;
  }
  return false;
}

// Compiles one expression alone at the given state names; throws naming the key and the text.
// Returns the value at ξ = 0 and whether the expression uses a state.
std::pair<double, bool> CheckExpression(const TomlReader& rd, const toml::node* node, const std::string& key,
                                        const std::string& expr, const std::vector<std::string>& states) {
  std::array<double, Model::kMaxStates> var{};
  mu::Parser p;
  if (HasAssignment(p, expr)) {
    rd.Fail(node, key,
            fmt::format("\"{}\": '=' is muParser's assignment (it would change a state for every later "
                        "entry); an expression may not assign: write '==' to compare",
                        expr));
  }
  try {
    for (std::size_t i = 0; i < states.size(); ++i) p.DefineVar(states[i], &var[i]);
    p.SetExpr(expr);
    int count = 0;
    const double* v = p.Eval(count);
    if (count != 1) rd.Fail(node, key, fmt::format("\"{}\": one expression expected, found {}", expr, count));
    return {v[0], !p.GetUsedVar().empty()};
  } catch (const mu::Parser::exception_type& e) {
    if (e.GetCode() == mu::ecUNASSIGNABLE_TOKEN) {
      rd.Fail(node, key,
              fmt::format("\"{}\": unknown symbol \"{}\" (the variables are the states: {})", expr,
                          e.GetToken(), fmt::join(states, ", ")));
    }
    if (e.GetCode() == mu::ecINTERNAL_ERROR) {  // muParser's bare "Internal error": "v++", "-" alone, ...
      rd.Fail(node, key,
              fmt::format("\"{}\": not a valid expression (an operator without its operand?)", expr));
    }
    rd.Fail(node, key, fmt::format("\"{}\": {}", expr, e.GetMsg()));
  }
}

// An entry of a matrix: a number or a string expression.
std::string EntryText(const TomlReader& rd, const toml::node& n, const std::string& key) {
  if (n.is_string()) return std::string(*n.value<std::string>());
  if (n.is_number()) return fmt::format("{}", rd.Number(n, key));
  rd.Fail(&n, key,
          fmt::format("expected an expression (a string) or a number, got {}", TomlReader::TypeName(n)));
}

// A rows × cols matrix (a list of rows) of expressions.
ExprMatrix ParseMatrix(const TomlReader& rd, const toml::node& node, const std::string& key,
                       Eigen::Index rows, Eigen::Index cols, const std::vector<std::string>& states) {
  const toml::array& arr = rd.Array(node, key);
  rd.Size(&node, key, arr.size(), std::size_t(rows), "one row per state");
  ExprMatrix m{rows, cols, std::vector<double>(std::size_t(rows * cols), 0.0), {}, {}, {}};
  m.text.resize(std::size_t(rows * cols));
  std::vector<std::string> exprs;
  for (Eigen::Index i = 0; i < rows; ++i) {
    const std::string rkey = TomlReader::Index(key, std::size_t(i));
    const toml::array& row = rd.Array(arr[std::size_t(i)], rkey);
    rd.Size(&arr[std::size_t(i)], rkey, row.size(), std::size_t(cols), "one per parameter");
    for (Eigen::Index j = 0; j < cols; ++j) {
      const std::string ekey = TomlReader::Index(rkey, std::size_t(j));
      const std::string text = EntryText(rd, row[std::size_t(j)], ekey);
      const auto [value, uses_state] = CheckExpression(rd, &row[std::size_t(j)], ekey, text, states);
      const Eigen::Index at = j * rows + i;
      m.text[std::size_t(at)] = text;
      if (uses_state) {
        m.index.push_back(at);
        exprs.push_back("(" + text + ")");
      } else {
        m.constant[std::size_t(at)] = value;
      }
    }
  }
  m.joined = fmt::format("{}", fmt::join(exprs, ","));
  return m;
}

std::vector<Parameter> ParseParameters(const TomlReader& rd, const toml::table& root, const char* which) {
  const toml::array& arr = rd.Array(rd.Require(root, "", which), which);
  rd.NotEmpty(&arr, which, arr.size(), "parameter");
  std::vector<Parameter> out;
  for (std::size_t i = 0; i < arr.size(); ++i) {
    const std::string key = TomlReader::Index(which, i);
    const toml::table& t = rd.Table(arr[i], key);
    rd.OnlyKeys(t, key, {"name", "value", "known", "description"});
    Parameter p;
    p.name = rd.String(rd.Require(t, key, "name"), key + ".name");
    if (p.name.starts_with("x0[")) {  // the refinement's and the bound's names of the initial state
      rd.Fail(t.get("name"), key + ".name",
              fmt::format("\"{}\": names x0[...] are the initial states' (x0[STATE])", p.name));
    }
    p.value = rd.Number(rd.Require(t, key, "value"), key + ".value");
    if (const toml::node* k = t.get("known")) p.known = rd.Boolean(*k, key + ".known");
    if (const toml::node* d = t.get("description")) p.description = rd.String(*d, key + ".description");
    out.push_back(std::move(p));
  }
  return out;
}

std::vector<int> ParseRows(const TomlReader& rd, const toml::table& t, const std::string& prefix,
                           const std::vector<std::string>& states) {
  const std::string key = prefix + ".rows";
  const toml::array& arr = rd.Array(rd.Require(t, prefix, "rows"), key);
  rd.NotEmpty(&arr, key, arr.size(), "state whose row carries unknown parameters");
  std::vector<int> rows;
  for (std::size_t i = 0; i < arr.size(); ++i) {
    const std::string ikey = TomlReader::Index(key, i);
    const std::string name = rd.String(arr[i], ikey);
    const int row = static_cast<int>(rd.Choice(&arr[i], ikey, "state", name, states));
    if (std::find(rows.begin(), rows.end(), row) != rows.end()) rd.Twice(&arr[i], ikey, fmt::format("'{}'", name));
    rows.push_back(row);
  }
  return rows;
}

std::vector<std::string> ParseStates(const TomlReader& rd, const toml::table& root) {
  const toml::array& arr = rd.Array(rd.Require(root, "", "states"), "states");
  rd.NotEmpty(&arr, "states", arr.size(), "state");
  if (arr.size() > std::size_t(Model::kMaxStates)) {
    rd.Fail(&arr, "states",
            fmt::format("has {} entries, at most {} (hysid's limit)", arr.size(), Model::kMaxStates));
  }
  std::vector<std::string> states;
  mu::Parser probe;
  for (std::size_t i = 0; i < arr.size(); ++i) {
    const std::string key = TomlReader::Index("states", i);
    std::string s = rd.String(arr[i], key);
    try {
      double dummy = 0;
      probe.DefineVar(s, &dummy);
    } catch (const mu::Parser::exception_type& e) {
      rd.Fail(&arr[i], key, fmt::format("'{}' is not a valid variable name: {}", s, e.GetMsg()));
    }
    if (std::find(states.begin(), states.end(), s) != states.end())
      rd.Twice(&arr[i], key, fmt::format("'{}'", s));
    states.push_back(std::move(s));
  }
  return states;
}

Crossing ParseDirection(const TomlReader& rd, const toml::node& n, const std::string& key) {
  // In the order of the enumerators.
  static const std::vector<std::string> kDirections{"falling", "rising", "both"};
  return static_cast<Crossing>(rd.Choice(&n, key, "direction", rd.String(n, key), kDirections));
}

// guard[g].project: { state = expression, ... }, assigned when a jump starts on the guard.
void ParseProjection(const TomlReader& rd, const toml::node& node, const std::string& key, Definition& def) {
  const std::vector<std::string>& states = def.spec.state_names;
  ExprMatrix& proj = def.project.back();
  std::vector<std::string> exprs;
  for (auto&& [k, v] : rd.Table(node, key)) {
    const std::string skey = TomlReader::Join(key, k.str());
    const std::size_t state = rd.Choice(&v, skey, "state", std::string(k.str()), states);
    const std::string text = EntryText(rd, v, skey);
    CheckExpression(rd, &v, skey, text, states);
    def.project_states.back().push_back(static_cast<int>(state));
    proj.text.push_back(fmt::format("{}+ = {}", k.str(), text));
    proj.index.push_back(static_cast<Eigen::Index>(exprs.size()));
    exprs.push_back("(" + text + ")");
  }
  proj.rows = static_cast<Eigen::Index>(exprs.size());
  proj.cols = 1;
  proj.constant.assign(exprs.size(), 0.0);
  proj.joined = fmt::format("{}", fmt::join(exprs, ","));
}

void ParseGuards(const TomlReader& rd, const toml::table& root, Definition& def) {
  const toml::array& arr = rd.Array(rd.Require(root, "", "guard"), "guard");
  rd.NotEmpty(&arr, "guard", arr.size(), "[[guard]]");
  for (std::size_t g = 0; g < arr.size(); ++g) {
    const std::string key = TomlReader::Index("guard", g);
    const toml::table& t = rd.Table(arr[g], key);
    rd.OnlyKeys(t, key, {"name", "h", "direction", "project"});
    Guard guard;
    guard.name = t.get("name") ? rd.String(*t.get("name"), key + ".name") : fmt::format("guard{}", g);
    guard.direction = ParseDirection(rd, rd.Require(t, key, "direction"), key + ".direction");
    def.spec.guards.push_back(guard);
    const toml::node& h = rd.Require(t, key, "h");
    const std::string text = EntryText(rd, h, key + ".h");
    if (!CheckExpression(rd, &h, key + ".h", text, def.spec.state_names).second) {
      rd.Fail(&h, key + ".h", fmt::format("\"{}\" does not depend on the state", text));
    }
    def.guards.text.push_back(text);
    def.guards.index.push_back(static_cast<Eigen::Index>(g));
    def.guards.joined += (g ? ",(" : "(") + text + ")";
    def.project.emplace_back();
    def.project_states.emplace_back();
    if (const toml::node* p = t.get("project")) ParseProjection(rd, *p, key + ".project", def);
  }
  def.guards.rows = static_cast<Eigen::Index>(arr.size());
  def.guards.cols = 1;
  def.guards.constant.assign(arr.size(), 0.0);
}

void ParseSets(const TomlReader& rd, const toml::table& root, Definition& def) {
  const toml::table& t = rd.Table(rd.Require(root, "", "sets"), "sets");
  rd.OnlyKeys(t, "sets", {"C", "D", "distance_to_D"});
  auto one = [&](const char* k) -> std::string {
    const std::string key = TomlReader::Join("sets", k);
    const toml::node& n = rd.Require(t, "sets", k);
    const std::string text = EntryText(rd, n, key);
    CheckExpression(rd, &n, key, text, def.spec.state_names);
    return text;
  };
  def.in_c = one("C");
  def.in_d = one("D");
  if (t.contains("distance_to_D")) def.distance = one("distance_to_D");
}

void ParseDefaults(const TomlReader& rd, const toml::table& root, ModelSpec& spec) {
  const toml::table& t = rd.Table(rd.Require(root, "", "defaults"), "defaults");
  rd.OnlyKeys(t, "defaults", {"x0", "t_end", "dt"});
  const toml::node& x0 = rd.Require(t, "defaults", "x0");
  spec.default_x0 = rd.Numbers(x0, "defaults.x0");
  rd.Size(&x0, "defaults.x0", spec.default_x0.size(), spec.state_names.size(), "one per state");
  for (auto [k, field] : {std::pair{"t_end", &spec.default_t_end}, std::pair{"dt", &spec.default_dt}}) {
    const toml::node& n = rd.Require(t, "defaults", k);
    *field = rd.Number(n, TomlReader::Join("defaults", k));
    rd.Above(&n, TomlReader::Join("defaults", k), *field, 0.0);
  }
  // The default trajectory is simulated when the file is loaded: within the samples limit.
  const double samples = std::min(spec.default_t_end / spec.default_dt, 9e18) + 1.0;
  if (samples > static_cast<double>(LimitValue(kMaxSamples))) {
    rd.Fail(&rd.Require(t, "defaults", "dt"), "defaults.dt",
            fmt::format("t_end {} / dt {}: {:.0f} exceeds the limit of {} {} (raise it with {}=N)",
                        spec.default_t_end, spec.default_dt, samples, LimitValue(kMaxSamples),
                        kMaxSamples.what, kMaxSamples.variable));
  }
}

// "name*(expr) + ..." for one row of a matrix times its parameter vector.
std::string RowText(const ExprMatrix& m, Eigen::Index row, const std::vector<Parameter>& params) {
  std::vector<std::string> terms;
  for (Eigen::Index j = 0; j < m.cols; ++j) {
    const Eigen::Index at = j * m.rows + row;
    const bool expr = std::find(m.index.begin(), m.index.end(), at) != m.index.end();
    if (!expr && m.constant[std::size_t(at)] == 0.0) continue;
    const std::string& e = m.text[std::size_t(at)];
    terms.push_back(!expr && m.constant[std::size_t(at)] == 1.0
                        ? params[std::size_t(j)].name
                        : fmt::format("{}*({})", params[std::size_t(j)].name, e));
  }
  return terms.empty() ? "0" : fmt::format("{}", fmt::join(terms, " + "));
}

std::string Equations(const Definition& def) {
  const ModelSpec& s = def.spec;
  std::string out;
  for (std::size_t i = 0; i < s.state_names.size(); ++i) {
    out += fmt::format("flow: {}' = {}\n", s.state_names[i], RowText(def.phi, Eigen::Index(i), s.alpha));
  }
  for (std::size_t i = 0; i < s.state_names.size(); ++i) {
    out += fmt::format("jump: {}+ = {}\n", s.state_names[i], RowText(def.psi, Eigen::Index(i), s.beta));
  }
  constexpr const char* kDirection[] = {"falling", "rising", "both"};
  for (std::size_t g = 0; g < s.guards.size(); ++g) {
    out += fmt::format("guard {}: h(xi) = {} ({}){}{}\n", s.guards[g].name, def.guards.text[g],
                       kDirection[static_cast<int>(s.guards[g].direction)],
                       def.project[g].text.empty() ? "" : ", projected: ", fmt::join(def.project[g].text, ", "));
  }
  out += fmt::format("C: {}\nD: {}\n", def.in_c, def.in_d);
  if (!def.distance.empty()) out += fmt::format("dist(xi, D) = {}\n", def.distance);
  return out;
}

std::shared_ptr<Definition> ParseDefinition(const TomlReader& rd, const toml::table& root) {
  rd.OnlyKeys(
      root, "",
      {"name", "description", "states", "alpha", "beta", "flow", "jump", "guard", "sets", "defaults"});
  auto def = std::make_shared<Definition>();
  ModelSpec& spec = def->spec;
  spec.name = rd.String(rd.Require(root, "", "name"), "name");
  if (const toml::node* d = root.get("description")) spec.description = rd.String(*d, "description");
  spec.state_names = ParseStates(rd, root);
  spec.alpha = ParseParameters(rd, root, "alpha");
  spec.beta = ParseParameters(rd, root, "beta");
  const auto n = static_cast<Eigen::Index>(spec.state_names.size());
  for (auto [key, matrix, params, rows] : {std::tuple{"flow", &def->phi, &spec.alpha, &spec.flow_rows},
                                           std::tuple{"jump", &def->psi, &spec.beta, &spec.jump_rows}}) {
    const toml::table& t = rd.Table(rd.Require(root, "", key), key);
    const bool flow = std::string_view(key) == "flow";
    const char* mkey = flow ? "phi" : "psi";
    rd.OnlyKeys(t, key,
                flow ? std::vector<std::string>{mkey, "rows", "jacobian_constant"}
                     : std::vector<std::string>{mkey, "rows"});
    *matrix = ParseMatrix(rd, rd.Require(t, key, mkey), TomlReader::Join(key, mkey), n,
                          static_cast<Eigen::Index>(params->size()), spec.state_names);
    *rows = ParseRows(rd, t, key, spec.state_names);
    if (const toml::node* jc = t.get("jacobian_constant"))
      spec.flow_jacobian_constant = rd.Boolean(*jc, "flow.jacobian_constant");
  }
  ParseGuards(rd, root, *def);
  ParseSets(rd, root, *def);
  ParseDefaults(rd, root, spec);
  spec.equations = Equations(*def);
  def->id = next_definition_id.fetch_add(1);
  return def;
}

}  // namespace

ModelFile ParseModelFile(std::string_view text, const std::string& name) {
  const TomlReader rd(name);
  const toml::table root = ParseToml(text, name);
  std::shared_ptr<const Definition> def = ParseDefinition(rd, root);
  ModelFile out{[&] {
                  try {
                    return Model(FileModel{def});
                  } catch (const std::invalid_argument& e) {
                    throw std::invalid_argument(fmt::format("{}: {}", name, e.what()));
                  }
                }(),
                {}};
  const ModelSpec& s = def->spec;
  const Vec x0 = Eigen::Map<const Vec>(s.default_x0.data(), out.model.state_size());
  if (!out.model.InFlowSet(x0) && !out.model.InJumpSet(x0)) {
    rd.Fail(root.at_path("defaults.x0").node(), "defaults.x0",
            fmt::format("({}) is outside C and D", fmt::join(s.default_x0, ", ")));
  }
  const toml::array& guards = *root.get("guard")->as_array();
  for (std::size_t g = 0; g < guards.size(); ++g)
    out.guard_where.push_back(rd.Where(guards.get(g), TomlReader::Join(TomlReader::Index("guard", g), "h")));
  return out;
}

ModelFile ReadModelFile(const std::filesystem::path& path) {
  return ParseModelFile(ReadWholeFile(path, "model file"), path.string());
}

}  // namespace hysid
