#include "core/model_file/model_file.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <map>
#include <memory>
#include <set>
#include <span>
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
#include "core/model/automaton.hpp"

namespace hysid {
namespace {

// A matrix of expressions, column-major: constant entries are stored as numbers, the others are
// joined into one muParser expression list "e1, e2, ..." evaluated with one call. A part of a matrix
// (one row of φ, RowOf) keeps the whole matrix's rows and cols and lists its constants' positions.
struct ExprMatrix {
  Eigen::Index rows = 0, cols = 0;
  std::vector<double> constant = {};     // rows·cols values (0 where the entry is an expression) ...
  std::vector<Eigen::Index> index = {};  // column-major position of each expression
  std::vector<std::string> text = {};    // every entry as written (for the equations; empty for a part)
  std::string joined = {};               // the expressions, comma-separated
  std::vector<Eigen::Index> constant_at = {};  // ... or a part's constants, at these positions
  bool part = false;                           // a part: constant and constant_at hold its constants alone
};

// Slots of Compiled::var: the states, then the inputs u, the guard parameters γ, the time t, and α and
// β (read by the guards and sets only).
constexpr std::size_t kInputSlot = Model::kMaxStates;
constexpr std::size_t kGammaSlot = kInputSlot + Model::kMaxParameters;
constexpr std::size_t kTimeSlot = kGammaSlot + Model::kMaxParameters;
constexpr std::size_t kAlphaSlot = kTimeSlot + 1;
constexpr std::size_t kBetaSlot = kAlphaSlot + Model::kMaxAlpha;
constexpr std::size_t kSlots = kBetaSlot + Model::kMaxParameters;

// The entries of a matrix that read one variable slot (Compiled::var) of the expressions: a part of
// the matrix with those expressions alone.
struct SlotPart {
  std::size_t slot = 0;
  ExprMatrix part;
};

// The parsed file, shared (immutable) by every copy of the model.
struct Definition {
  std::uint64_t id = 0;
  bool contextual = false;  // inputs or γ: every evaluation loads them (and t) from the context
  bool binds_time = false;  // `t` is a variable (a model with inputs and no state named t)
  bool reads_parameters = false;  // a guard or set reads an α or β name: Load loads them
  std::vector<bool> flow_reads_gamma;  // per guard parameter: some φ_q names it
  ModelSpec spec;
  std::vector<ExprMatrix> phi;  // per mode q: φ_q, n × |α|
  std::vector<std::vector<ExprMatrix>> phi_rows;  // per mode q and row r: row r of φ_q alone
  std::vector<std::vector<SlotPart>> phi_reading;  // per mode q: per slot φ_q reads, its entries that read it
  // The single [jump]: one n × |β| matrix. [[jump]] maps (`sliced`): per map its n × |β_m| slice
  // (0 columns for an identity map), written into columns [beta_first, beta_first + beta_count).
  std::vector<ExprMatrix> psi;
  bool sliced = false;
  bool has_sets = true;  // false: an automaton without [sets] (C every state, D empty)
  ExprMatrix guards;     // |guards| × 1
  std::string in_c, in_d, distance;
  std::vector<ExprMatrix> project;               // per guard: assigned states × 1 (may be empty)
  std::vector<std::vector<int>> project_states;  // per guard: which state each entry assigns
};

std::atomic<std::uint64_t> next_definition_id{1};

// One thread's compiled parsers; `var` holds ξ, u, γ, t, α and β, bound to their names.
struct Compiled {
  std::array<double, kSlots> var{};
  std::vector<mu::Parser> phi, psi;  // as Definition::phi, ::psi
  // Per mode q and row r, at q·n + r: row r of φ_q's expressions, compiled when first asked for.
  std::vector<std::unique_ptr<mu::Parser>> phi_rows;
  std::vector<std::vector<mu::Parser>> phi_reading;  // as Definition::phi_reading
  mu::Parser guards, in_c, in_d, distance;
  std::vector<mu::Parser> project;
  // The last φ Phi evaluated (EvaluatePhi): its mode (−1: none yet), the variables it was evaluated
  // at (the slots its mode reads) and its entries.
  int phi_mode = -1;
  std::array<double, kSlots> phi_var{};
  std::vector<double> phi_last;
};

// Whether α or β entry `p` is a variable of the guards and sets: its name a valid variable name (α and
// β names are free text), not t, a built-in function or constant, and no state's (the state's, there).
bool ParameterBound(const ModelSpec& s, const Parameter& p) {
  if (p.name == "t" || std::find(s.state_names.begin(), s.state_names.end(), p.name) != s.state_names.end()) {
    return false;
  }
  mu::Parser probe;
  try {
    double dummy = 0.0;
    probe.DefineVar(p.name, &dummy);
  } catch (const mu::Parser::exception_type&) {
    return false;
  }
  return !probe.GetFunDef().contains(p.name) && !probe.GetConst().contains(p.name);
}

// `parameters`: the α and β names too (guards, sets).
void Bind(mu::Parser& p, const Definition& def, Compiled& c, const std::string& expr, bool parameters = false) {
  const ModelSpec& s = def.spec;
  for (std::size_t i = 0; i < s.state_names.size(); ++i) p.DefineVar(s.state_names[i], &c.var[i]);
  for (std::size_t i = 0; i < s.inputs.size(); ++i) p.DefineVar(s.inputs[i], &c.var[kInputSlot + i]);
  for (std::size_t i = 0; i < s.guard_params.size(); ++i)
    p.DefineVar(s.guard_params[i].name, &c.var[kGammaSlot + i]);
  if (def.binds_time) p.DefineVar("t", &c.var[kTimeSlot]);
  for (std::size_t i = 0; parameters && i < s.alpha.size(); ++i) {
    if (ParameterBound(s, s.alpha[i])) p.DefineVar(s.alpha[i].name, &c.var[kAlphaSlot + i]);
  }
  for (std::size_t i = 0; parameters && i < s.beta.size(); ++i) {
    if (ParameterBound(s, s.beta[i])) p.DefineVar(s.beta[i].name, &c.var[kBetaSlot + i]);
  }
  p.SetExpr(expr.empty() ? "0" : expr);
}

std::unique_ptr<Compiled> Compile(const Definition& def) {
  auto c = std::make_unique<Compiled>();
  c->phi.resize(def.phi.size());
  for (std::size_t q = 0; q < def.phi.size(); ++q) Bind(c->phi[q], def, *c, def.phi[q].joined);
  c->phi_rows.resize(def.phi.size() * def.spec.state_names.size());
  c->phi_reading.resize(def.phi.size());
  for (std::size_t q = 0; q < def.phi.size(); ++q) {
    c->phi_reading[q].resize(def.phi_reading[q].size());
    for (std::size_t k = 0; k < def.phi_reading[q].size(); ++k)
      Bind(c->phi_reading[q][k], def, *c, def.phi_reading[q][k].part.joined);
  }
  c->psi.resize(def.psi.size());
  for (std::size_t m = 0; m < def.psi.size(); ++m) Bind(c->psi[m], def, *c, def.psi[m].joined);
  Bind(c->guards, def, *c, def.guards.joined, true);
  Bind(c->in_c, def, *c, def.in_c, true);
  Bind(c->in_d, def, *c, def.in_d, true);
  Bind(c->distance, def, *c, def.distance, true);
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

// The parser of row r of φ_q's expressions (compiled on first use; a row of constants gets one that
// is never evaluated).
const mu::Parser& RowParser(const Definition& def, Compiled& c, std::size_t q, std::size_t r) {
  std::unique_ptr<mu::Parser>& p = c.phi_rows[q * def.spec.state_names.size() + r];
  if (p == nullptr) {
    p = std::make_unique<mu::Parser>();
    Bind(*p, def, c, def.phi_rows[q][r].joined);
  }
  return *p;
}

// out[0, n) = from[0, n) for the few entries of a state or an expression matrix, by a plain loop:
// std::copy calls memmove, which costs more than these copies (two per sample in PhiColumns).
void CopySmall(const double* from, std::size_t n, double* out) {
  for (std::size_t i = 0; i < n; ++i) out[i] = from[i];
}

// Loads ξ; for a model whose guards or sets read α or β also those (when the context has them: Model
// resolves them for the guards and sets); and for a model with inputs or γ also u, γ and t.
void Load(const Definition& def, Compiled& c, const double* x, std::size_t n, const Context& ctx) {
  CopySmall(x, n, c.var.data());
  if (def.reads_parameters) {
    for (std::size_t i = 0; ctx.alpha != nullptr && i < def.spec.alpha.size(); ++i) c.var[kAlphaSlot + i] = ctx.alpha[i];
    for (std::size_t i = 0; ctx.beta != nullptr && i < def.spec.beta.size(); ++i) c.var[kBetaSlot + i] = ctx.beta[i];
  }
  if (!def.contextual) return;
  const std::size_t m = def.spec.inputs.size(), g = def.spec.guard_params.size();
  // Loops, not std::copy: the x-only path's context (never reaching here) has null pointers that
  // g++ would flag in memmove.
  for (std::size_t i = 0; i < m; ++i) c.var[kInputSlot + i] = ctx.u[i];
  for (std::size_t i = 0; i < g; ++i) c.var[kGammaSlot + i] = ctx.gamma[i];
  c.var[kTimeSlot] = ctx.t;
}

// Fills out (column-major, rows·cols) with the matrix (a part: its entries) at the loaded state.
void Evaluate(const ExprMatrix& m, const mu::Parser& p, double* out) {
  if (!m.part) {
    CopySmall(m.constant.data(), m.constant.size(), out);
  } else {
    for (std::size_t j = 0; j < m.constant.size(); ++j) out[m.constant_at[j]] = m.constant[j];
  }
  if (m.index.empty()) return;
  int count = 0;
  const double* v = p.Eval(count);
  for (std::size_t k = 0; k < m.index.size(); ++k) out[m.index[k]] = v[k];
}

// φ_q at the loaded variables into out (column-major). Each entry is a function of the slots it
// reads, and a part's entries are the whole matrix's bit for bit (PartOf), so when the last φ was of
// the same mode, only the entries that read a slot moved since (compared bit for bit) are evaluated
// again, when they are fewer than all: a central difference in one state or γ, and Phi after Flow at
// the same state, evaluate a few entries instead of the matrix.
void EvaluatePhi(const Definition& def, Compiled& c, std::size_t q, double* out) {
  const ExprMatrix& m = def.phi[q];
  const std::vector<SlotPart>& parts = def.phi_reading[q];
  const auto size = static_cast<std::size_t>(m.rows * m.cols);
  const auto moved = [&](const SlotPart& p) {
    return std::bit_cast<std::uint64_t>(c.var[p.slot]) != std::bit_cast<std::uint64_t>(c.phi_var[p.slot]);
  };
  if (c.phi_mode == static_cast<int>(q)) {
    std::size_t again = 0;
    for (const SlotPart& p : parts) again += moved(p) ? p.part.index.size() : 0;
    if (again < m.index.size()) {
      CopySmall(c.phi_last.data(), size, out);
      for (std::size_t k = 0; k < parts.size(); ++k) {
        if (moved(parts[k])) Evaluate(parts[k].part, c.phi_reading[q][k], out);
      }
      for (const SlotPart& p : parts) c.phi_var[p.slot] = c.var[p.slot];
      CopySmall(out, size, c.phi_last.data());
      return;
    }
  }
  Evaluate(m, c.phi[q], out);
  c.phi_mode = static_cast<int>(q);
  for (const SlotPart& p : parts) c.phi_var[p.slot] = c.var[p.slot];
  c.phi_last.resize(size);
  CopySmall(out, size, c.phi_last.data());
}

// φ (the matrix m, or a part of it, evaluated by p) at `count` states x_k = x[k·n .. k·n + n) of a
// model without inputs or γ, to phi + k·|m| (Load and Evaluate for each): N = n when fixed at
// compile time (else 0). What the loop holds is read once: the expression list's positions and the
// constant entries, written by plain loops of their own (a loop of run-time length over a few
// doubles is vectorised by g++ behind a run-time check that costs more than the copy).
template <int N>
void PhiColumnsOf(const ExprMatrix& m, Compiled& c, const mu::Parser& p, const double* x, Eigen::Index count,
                  double* phi) {
  const Eigen::Index n = N > 0 ? N : m.rows, size = m.rows * m.cols;
  const auto expressions = static_cast<Eigen::Index>(m.index.size());
  const auto constants = static_cast<Eigen::Index>(m.constant.size());
  const double* constant = m.constant.data();
  const Eigen::Index* constant_at = m.constant_at.data();
  const bool part = m.part;
  const Eigen::Index* index = m.index.data();
  double* var = c.var.data();
  for (Eigen::Index k = 0; k < count; ++k) {
    const double* xk = x + k * n;
    double* out = phi + k * size;
    for (Eigen::Index i = 0; i < n; ++i) var[i] = xk[i];
    if (!part) {
      for (Eigen::Index j = 0; j < size; ++j) out[j] = constant[j];
    } else {
      for (Eigen::Index j = 0; j < constants; ++j) out[constant_at[j]] = constant[j];
    }
    if (expressions == 0) continue;
    int results = 0;
    const double* v = p.Eval(results);
    for (Eigen::Index e = 0; e < expressions; ++e) out[index[e]] = v[e];
  }
}

// The HybridModel struct over a Definition (the context forms; Model resolves the context).
struct FileModel {
  std::shared_ptr<const Definition> def;

  ModelSpec Spec() const { return def->spec; }
  void Phi(ConstVecRef x, const Context& ctx, MatRef phi) const {
    const std::size_t q = Index(ctx.mode, def->phi.size(), "mode");
    EvaluatePhi(*def, Loaded(x, ctx), q, phi.data());
  }
  void PhiColumns(const double* x, Eigen::Index count, const Context& ctx, double* phi) const {
    Compiled& c = Local(def);
    const std::size_t q = Index(ctx.mode, def->phi.size(), "mode");
    Columns(def->phi[q], c, c.phi[q], x, count, ctx, phi);
  }
  // Row `row` of φ alone: that row's expressions (its own parser) and constants.
  void PhiRowColumns(int row, const double* x, Eigen::Index count, const Context& ctx, double* phi) const {
    Compiled& c = Local(def);
    const std::size_t q = Index(ctx.mode, def->phi.size(), "mode");
    const std::size_t r = Index(row, def->spec.state_names.size(), "row");
    Columns(def->phi_rows[q][r], c, RowParser(*def, c, q, r), x, count, ctx, phi);
  }
  // ψ_m in its β slice, zeros elsewhere (an identity map: all zeros; Model::Jump applies ξ+ = ξ).
  void Psi(ConstVecRef x, const Context& ctx, MatRef psi) const {
    if (!def->sliced) return Evaluate(def->psi[0], Loaded(x, ctx).psi[0], psi.data());
    const std::size_t m = Index(ctx.map, def->psi.size(), "jump map");
    psi.setZero();
    const JumpMap& map = def->spec.jumps[m];
    if (map.identity) return;
    Evaluate(def->psi[m], Loaded(x, ctx).psi[m], psi.data() + Eigen::Index(map.beta_first) * psi.rows());
  }
  void Guards(ConstVecRef x, const Context& ctx, VecRef h) const {
    Evaluate(def->guards, Loaded(x, ctx).guards, h.data());
  }
  bool InFlowSet(ConstVecRef x, const Context& ctx) const {
    return !def->has_sets || Loaded(x, ctx).in_c.Eval() != 0.0;
  }
  bool InJumpSet(ConstVecRef x, const Context& ctx) const {
    return def->has_sets && Loaded(x, ctx).in_d.Eval() != 0.0;
  }
  bool ProvidesJumpSetDistance() const { return !def->distance.empty(); }
  bool FlowReadsGamma(int i) const { return def->flow_reads_gamma.at(std::size_t(i)); }
  double DistanceToJumpSet(ConstVecRef x, const Context& ctx) const {
    if (def->distance.empty()) return std::numeric_limits<double>::quiet_NaN();
    return Loaded(x, ctx).distance.Eval();
  }
  void ProjectOntoGuard(int guard, const Context& ctx, VecRef x) const {
    const auto g = static_cast<std::size_t>(guard);
    if (g >= def->project.size() || def->project[g].rows == 0) return;
    Compiled& c = Loaded(x, ctx);
    std::array<double, Model::kMaxStates> value{};
    Evaluate(def->project[g], c.project[g], value.data());
    for (std::size_t k = 0; k < def->project_states[g].size(); ++k) x[def->project_states[g][k]] = value[k];
  }

 private:
  // A context's mode or map as an index into `size` entries (an index outside is a caller's bug).
  static std::size_t Index(int value, std::size_t size, const char* what) {
    if (value < 0 || std::size_t(value) >= size) {
      throw std::logic_error(fmt::format("model file: Context {} {} outside [0, {})", what, value, size));
    }
    return std::size_t(value);
  }
  // The matrix m (or part) evaluated by p at `count` states, to phi + k·|m|.
  void Columns(const ExprMatrix& m, Compiled& c, const mu::Parser& p, const double* x, Eigen::Index count,
               const Context& ctx, double* phi) const {
    const Eigen::Index n = m.rows, size = m.rows * m.cols;
    if (!def->contextual) {  // ξ alone: the loop of PhiColumnsOf, with n fixed when it is small
      switch (n) {
        case 1: return PhiColumnsOf<1>(m, c, p, x, count, phi);
        case 2: return PhiColumnsOf<2>(m, c, p, x, count, phi);
        case 3: return PhiColumnsOf<3>(m, c, p, x, count, phi);
        case 4: return PhiColumnsOf<4>(m, c, p, x, count, phi);
        default: return PhiColumnsOf<0>(m, c, p, x, count, phi);
      }
    }
    for (Eigen::Index k = 0; k < count; ++k) {
      Load(*def, c, x + k * n, static_cast<std::size_t>(n), ctx);
      Evaluate(m, p, phi + k * size);
    }
  }
  // This thread's parsers with (x, ctx) loaded.
  Compiled& Loaded(ConstVecRef x, const Context& ctx) const {
    Compiled& c = Local(def);
    Load(*def, c, x.data(), static_cast<std::size_t>(x.size()), ctx);
    return c;
  }
};
static_assert(ContextModel<FileModel>);

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

// The variables of the file's expressions (states, inputs, guard parameters, t when bound) and which
// of them the expressions use.
struct Symbols {
  std::vector<std::string> names;
  std::set<std::string> varying;  // the names that change along a run: states, inputs, t
  std::set<std::string> used;
  std::string list;  // for messages: "states x, v; inputs u; ..."
};

struct Checked {
  double value = 0.0;      // at every variable 0
  bool variable = false;   // uses a variable (else a constant)
  bool varies = false;     // uses a state, an input or t (else constants and parameters only)
};

// A token muParser could not read that is a decimal number beyond a double's range ("1e999", "1e-400"):
// strtod reads all of it and reports ERANGE.
bool NumberOutOfRange(const std::string& token) {
  if (token.empty() || !(std::isdigit(static_cast<unsigned char>(token[0])) != 0 || token[0] == '.'))
    return false;
  char* end = nullptr;
  errno = 0;
  std::strtod(token.c_str(), &end);
  return errno == ERANGE && end != token.c_str();
}

// Compiles one expression alone with the file's variables; throws naming the key and the text.
Checked CheckExpression(const TomlReader& rd, const toml::node* node, const std::string& key,
                        const std::string& expr, Symbols& sym) {
  std::vector<double> var(sym.names.size(), 0.0);
  mu::Parser p;
  if (HasAssignment(p, expr)) {
    rd.Fail(node, key,
            fmt::format("\"{}\": '=' is muParser's assignment (it would change a state for every later "
                        "entry); an expression may not assign: write '==' to compare",
                        expr));
  }
  try {
    for (std::size_t i = 0; i < sym.names.size(); ++i) p.DefineVar(sym.names[i], &var[i]);
    p.SetExpr(expr);
    int count = 0;
    const double* v = p.Eval(count);
    if (count != 1) rd.Fail(node, key, fmt::format("\"{}\": one expression expected, found {}", expr, count));
    Checked out{v[0], !p.GetUsedVar().empty(), false};
    for (const auto& [name, ptr] : p.GetUsedVar()) {
      sym.used.insert(name);
      out.varies = out.varies || sym.varying.contains(name);
    }
    return out;
  } catch (const mu::Parser::exception_type& e) {
    if (e.GetCode() == mu::ecUNASSIGNABLE_TOKEN && NumberOutOfRange(e.GetToken())) {
      rd.Fail(
          node, key,
          fmt::format("\"{}\": the number {} is out of range (a finite double: magnitude below 1.8e308, not "
                      "below 2.2e-308 unless 0)",
                      expr, e.GetToken()));
    }
    if (e.GetCode() == mu::ecUNASSIGNABLE_TOKEN) {
      rd.Fail(node, key,
              fmt::format("\"{}\": unknown symbol \"{}\" (the variables: {})", expr, e.GetToken(), sym.list));
    }
    if (e.GetCode() == mu::ecINTERNAL_ERROR) {  // muParser's bare "Internal error": "v++", "-" alone, ...
      rd.Fail(node, key,
              fmt::format("\"{}\": not a valid expression (an operator without its operand?)", expr));
    }
    rd.Fail(node, key, fmt::format("\"{}\": {}", expr, e.GetMsg()));
  }
}

Symbols MakeSymbols(const Definition& def) {
  const ModelSpec& s = def.spec;
  Symbols sym;
  sym.names = s.state_names;
  sym.varying.insert(s.state_names.begin(), s.state_names.end());
  sym.varying.insert(s.inputs.begin(), s.inputs.end());
  sym.list = fmt::format("states {}", fmt::join(s.state_names, ", "));
  if (!s.inputs.empty()) {
    sym.names.insert(sym.names.end(), s.inputs.begin(), s.inputs.end());
    sym.list += fmt::format("; inputs {}", fmt::join(s.inputs, ", "));
  }
  if (!s.guard_params.empty()) {
    std::vector<std::string> g;
    for (const Parameter& p : s.guard_params) g.push_back(p.name);
    sym.names.insert(sym.names.end(), g.begin(), g.end());
    sym.list += fmt::format("; guard parameters {}", fmt::join(g, ", "));
  }
  if (def.binds_time) {
    sym.names.push_back("t");
    sym.varying.insert("t");
    sym.list += "; time t";
  }
  return sym;
}

// The guards' and sets' variables: `sym` and the α and β names (ParameterBound).
Symbols WithParameters(const Symbols& sym, const ModelSpec& s) {
  Symbols out = sym;
  for (const auto& [list, what] : {std::pair{&s.alpha, "flow parameters"}, std::pair{&s.beta, "jump parameters"}}) {
    std::vector<std::string> names;
    for (const Parameter& p : *list) {
      if (ParameterBound(s, p)) names.push_back(p.name);
    }
    if (names.empty()) continue;
    out.names.insert(out.names.end(), names.begin(), names.end());
    out.list += fmt::format("; {} {}", what, fmt::join(names, ", "));
  }
  return out;
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
                       Eigen::Index rows, Eigen::Index cols, Symbols& sym) {
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
      const auto [value, uses_variable, varies] = CheckExpression(rd, &row[std::size_t(j)], ekey, text, sym);
      const Eigen::Index at = j * rows + i;
      m.text[std::size_t(at)] = text;
      if (uses_variable) {
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

// The entries of m at the column-major positions `at` alone: their expressions in one list as
// ParseMatrix writes them (muParser evaluates each entry of a list on its own, so the values are the
// whole matrix's bit for bit) and their constants.
ExprMatrix PartOf(const ExprMatrix& m, const std::vector<Eigen::Index>& at) {
  ExprMatrix part{.rows = m.rows, .cols = m.cols, .part = true};
  std::vector<std::string> exprs;
  for (const Eigen::Index k : at) {
    if (std::find(m.index.begin(), m.index.end(), k) != m.index.end()) {
      part.index.push_back(k);
      exprs.push_back("(" + m.text[std::size_t(k)] + ")");
    } else {
      part.constant_at.push_back(k);
      part.constant.push_back(m.constant[std::size_t(k)]);
    }
  }
  part.joined = fmt::format("{}", fmt::join(exprs, ","));
  return part;
}

// Row r of φ alone (PartOf).
ExprMatrix RowOf(const ExprMatrix& m, Eigen::Index r) {
  std::vector<Eigen::Index> at;
  for (Eigen::Index j = 0; j < m.cols; ++j) at.push_back(j * m.rows + r);
  return PartOf(m, at);
}

// Per variable slot m's expressions read (a state, an input, γ or t), the part of m with the entries
// that read it (PartOf), in the order of the slots.
std::vector<SlotPart> PartsReading(const Definition& def, const ExprMatrix& m) {
  std::map<std::size_t, std::vector<Eigen::Index>> reading;
  Compiled probe;
  for (const Eigen::Index at : m.index) {
    mu::Parser p;
    Bind(p, def, probe, m.text[std::size_t(at)]);
    for (const auto& [name, ptr] : p.GetUsedVar()) {
      reading[static_cast<std::size_t>(ptr - probe.var.data())].push_back(at);
    }
  }
  std::vector<SlotPart> parts;
  for (const auto& [slot, at] : reading) parts.push_back({slot, PartOf(m, at)});
  return parts;
}

// PARAM.name: an identifier (a letter or _, then letters, digits and _), as the flags (--param
// NAME=VALUE), the tables' columns and Python's dict keys name it.
void CheckParameterName(const TomlReader& rd, const toml::node* node, const std::string& key,
                        const std::string& name) {
  const auto word = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_'; };
  const bool first =
      !name.empty() && (std::isalpha(static_cast<unsigned char>(name[0])) != 0 || name[0] == '_');
  if (first && std::all_of(name.begin(), name.end(), word)) return;
  rd.Fail(
      node, key,
      fmt::format("'{}': a parameter name must be an identifier (a letter or _, then letters, digits or _)",
                  Abbreviated(name, 40)));
}

// PARAM.bounds = [lo, hi]: lo < hi, the value inside.
void ParseBounds(const TomlReader& rd, const toml::node& node, const std::string& key, Parameter& p) {
  const std::vector<double> b = rd.Numbers(node, key);
  rd.Size(&node, key, b.size(), 2, "[lower, upper]");
  if (!(b[0] < b[1])) rd.Fail(&node, key, fmt::format("[{}, {}]: lower must be below upper", b[0], b[1]));
  if (p.value < b[0] || p.value > b[1]) {
    rd.Fail(&node, key, fmt::format("[{}, {}] excludes the value {} of '{}'", b[0], b[1], p.value, p.name));
  }
  p.lower = b[0];
  p.upper = b[1];
}

// A list of parameter tables at `key` (alpha, beta, guard_params, jump[m].beta), not empty unless
// `optional`.
std::vector<Parameter> ParseParameterList(const TomlReader& rd, const toml::node& node, const std::string& which,
                                         bool optional) {
  const toml::array& arr = rd.Array(node, which);
  if (!optional) rd.NotEmpty(&arr, which, arr.size(), "parameter");
  std::vector<Parameter> out;
  for (std::size_t i = 0; i < arr.size(); ++i) {
    const std::string key = TomlReader::Index(which, i);
    const toml::table& t = rd.Table(arr[i], key);
    rd.OnlyKeys(t, key, {"name", "value", "known", "description", "bounds"});
    Parameter p;
    p.name = rd.String(rd.Require(t, key, "name"), key + ".name");
    if (p.name.starts_with("x0[")) {  // the refinement's and the bound's names of the initial state
      rd.Fail(t.get("name"), key + ".name",
              fmt::format("\"{}\": names x0[...] are the initial states' (x0[STATE])", p.name));
    }
    CheckParameterName(rd, t.get("name"), key + ".name", p.name);
    p.value = rd.Number(rd.Require(t, key, "value"), key + ".value");
    if (const toml::node* k = t.get("known")) p.known = rd.Boolean(*k, key + ".known");
    if (const toml::node* d = t.get("description")) p.description = rd.String(*d, key + ".description");
    if (const toml::node* b = t.get("bounds")) {
      if (p.known) {
        rd.Fail(b, key + ".bounds",
                fmt::format("'{}' is known (known = true): it is held at its value; bounds are for unknown "
                            "parameters",
                            p.name));
      }
      ParseBounds(rd, *b, key + ".bounds", p);
    }
    out.push_back(std::move(p));
  }
  return out;
}

// alpha, beta (required, not empty) or guard_params (optional).
std::vector<Parameter> ParseParameters(const TomlReader& rd, const toml::table& root, const char* which) {
  const bool optional = std::string_view(which) == "guard_params";
  if (optional && !root.contains(which)) return {};
  return ParseParameterList(rd, rd.Require(root, "", which), which, optional);
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
void ParseProjection(const TomlReader& rd, const toml::node& node, const std::string& key, Definition& def,
                     Symbols& sym) {
  const std::vector<std::string>& states = def.spec.state_names;
  ExprMatrix& proj = def.project.back();
  std::vector<std::string> exprs;
  for (auto&& [k, v] : rd.Table(node, key)) {
    const std::string skey = TomlReader::Join(key, k.str());
    const std::size_t state = rd.Choice(&v, skey, "state", std::string(k.str()), states);
    const std::string text = EntryText(rd, v, skey);
    CheckExpression(rd, &v, skey, text, sym);
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

// The [[guard]] tables' names and directions (the jump maps name their guard); their expressions
// come after the maps (ParseGuardExpressions), when every β name is known.
void ParseGuardHeads(const TomlReader& rd, const toml::table& root, Definition& def) {
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
  }
}

// Each guard's h and projection. h may read the states, inputs, t (with inputs), γ, α and β (`with`);
// it must read something that changes along a run (a state, an input or t): one of constants and
// parameters alone never crosses zero. A projection reads `sym` (no α or β: the sensitivities
// differentiate it in ξ and γ only).
void ParseGuardExpressions(const TomlReader& rd, const toml::table& root, Definition& def, Symbols& with,
                           Symbols& sym) {
  const toml::array& arr = *root.get("guard")->as_array();
  for (std::size_t g = 0; g < arr.size(); ++g) {
    const std::string key = TomlReader::Index("guard", g);
    const toml::table& t = *arr[g].as_table();
    const toml::node& h = rd.Require(t, key, "h");
    const std::string text = EntryText(rd, h, key + ".h");
    if (!CheckExpression(rd, &h, key + ".h", text, with).varies) {
      rd.Fail(&h, key + ".h",
              fmt::format("guard '{}': \"{}\" reads no state, input or time, so it never changes along a run "
                          "and can never cross zero",
                          def.spec.guards[g].name, text));
    }
    def.guards.text.push_back(text);
    def.guards.index.push_back(static_cast<Eigen::Index>(g));
    def.guards.joined += (g ? ",(" : "(") + text + ")";
    def.project.emplace_back();
    def.project_states.emplace_back();
    if (const toml::node* p = t.get("project")) ParseProjection(rd, *p, key + ".project", def, sym);
  }
  def.guards.rows = static_cast<Eigen::Index>(arr.size());
  def.guards.cols = 1;
  def.guards.constant.assign(arr.size(), 0.0);
}

// An optional top-level list of distinct names (inputs, modes), at most kMaxParameters; `check(node,
// key, name)` vets each new name.
template <class Check>
std::vector<std::string> ParseNames(const TomlReader& rd, const toml::table& root, const char* which, Check check) {
  const toml::node* node = root.get(which);
  if (node == nullptr) return {};
  const toml::array& arr = rd.Array(*node, which);
  if (arr.size() > std::size_t(Model::kMaxParameters)) {
    rd.Fail(&arr, which, fmt::format("has {} entries, at most {}", arr.size(), Model::kMaxParameters));
  }
  std::vector<std::string> out;
  for (std::size_t i = 0; i < arr.size(); ++i) {
    const std::string key = TomlReader::Index(which, i);
    std::string name = rd.String(arr[i], key);
    if (std::find(out.begin(), out.end(), name) != out.end()) rd.Twice(&arr[i], key, fmt::format("'{}'", name));
    check(arr[i], key, name);
    out.push_back(std::move(name));
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// Hybrid automata: modes = [...], one [[flow]] per mode, [[jump]] maps with their own β slices.

// modes = ["NAME", ...]: at least one, distinct (absent: one unnamed mode).
std::vector<std::string> ParseModes(const TomlReader& rd, const toml::table& root) {
  std::vector<std::string> out =
      ParseNames(rd, root, "modes", [&](const toml::node& node, const std::string& key, const std::string& name) {
        if (name.empty()) rd.Fail(&node, key, "empty: give the mode a name");
      });
  if (const toml::node* node = root.get("modes")) rd.NotEmpty(node, "modes", out.size(), "mode");
  return out;
}

// The rows of φ_q with an entry that is not the constant 0 in an unknown α's column: a [[flow]]'s
// rows when it gives none.
std::vector<int> RowsWithUnknowns(const ExprMatrix& m, const std::vector<Parameter>& alpha) {
  std::vector<int> rows;
  for (Eigen::Index i = 0; i < m.rows; ++i) {
    for (Eigen::Index j = 0; j < m.cols; ++j) {
      const Eigen::Index at = j * m.rows + i;
      const bool expr = std::find(m.index.begin(), m.index.end(), at) != m.index.end();
      if (!alpha[std::size_t(j)].known && (expr || m.constant[std::size_t(at)] != 0.0)) {
        rows.push_back(static_cast<int>(i));
        break;
      }
    }
  }
  return rows;
}

// Every unknown parameter that enters the matrix enters one of `rows`: the recursive pass regresses
// the identified rows alone, so a parameter outside them would be reported at its initial value as
// an estimate. `key` names the table (flow, jump, flow[i], jump[m]); the error names KEY.rows.
void CheckRowsCarryUnknowns(const TomlReader& rd, const toml::table& t, const std::string& key, const ExprMatrix& m,
                            const std::vector<Parameter>& params, const std::vector<int>& rows,
                            const std::vector<std::string>& states) {
  auto enters = [&](Eigen::Index i, Eigen::Index j) {
    const Eigen::Index at = j * m.rows + i;
    return std::find(m.index.begin(), m.index.end(), at) != m.index.end() || m.constant[std::size_t(at)] != 0.0;
  };
  for (Eigen::Index j = 0; j < m.cols; ++j) {
    if (params[std::size_t(j)].known) continue;
    std::vector<std::string> outside;
    bool inside = false;
    for (Eigen::Index i = 0; i < m.rows; ++i) {
      if (!enters(i, j)) continue;
      const bool identified = std::find(rows.begin(), rows.end(), static_cast<int>(i)) != rows.end();
      inside = inside || identified;
      if (!identified) outside.push_back(states[std::size_t(i)]);
    }
    if (inside || outside.empty()) continue;
    std::vector<std::string> given;
    for (int r : rows) given.push_back(states[std::size_t(r)]);
    rd.Fail(t.get("rows"), TomlReader::Join(key, "rows"),
            fmt::format("the unknown parameter '{}' enters none of the rows ({}), only {}: add a row it enters, or "
                        "mark it known",
                        params[std::size_t(j)].name, fmt::join(given, ", "), fmt::join(outside, ", ")));
  }
}

// What a missing `rows` should hold: the rows that the matrix's unknown parameters enter.
std::string RowsHint(const ExprMatrix& m, const std::vector<Parameter>& params,
                     const std::vector<std::string>& states) {
  std::vector<std::string> names;
  for (int r : RowsWithUnknowns(m, params)) names.push_back(fmt::format("\"{}\"", states[std::size_t(r)]));
  if (names.empty()) return "give the identified rows (no row of the matrix has an unknown parameter)";
  return fmt::format("give the identified rows; the rows the unknown parameters enter are rows = [{}]",
                     fmt::join(names, ", "));
}

// KEY.rows of a table whose matrix is `m` over `params`: [flow], [jump], a [[flow]] that gives rows and
// a [[jump]] map with psi all read their rows here, so every form has the same checks (states
// named, each once, every unknown parameter of `m` in a row); missing, they are refused with RowsHint.
std::vector<int> ParseCheckedRows(const TomlReader& rd, const toml::table& t, const std::string& key,
                                  const ExprMatrix& m, const std::vector<Parameter>& params,
                                  const std::vector<std::string>& states) {
  if (!t.contains("rows")) rd.Require(t, key, "rows", RowsHint(m, params, states));
  std::vector<int> rows = ParseRows(rd, t, key, states);
  CheckRowsCarryUnknowns(rd, t, key, m, params, rows, states);
  return rows;
}

// One [[flow]] table (`key` = "flow[i]") of a file with modes: its mode, φ_q and rows (given, or
// the rows with unknown α); returns the mode's index and whether it declares jacobian_constant.
std::pair<std::size_t, bool> ParseModeFlow(const TomlReader& rd, const toml::table& t, const std::string& key,
                                           Definition& def, Symbols& sym, std::set<int>& rows) {
  ModelSpec& spec = def.spec;
  rd.OnlyKeys(t, key, {"mode", "phi", "rows", "jacobian_constant", "candidates"});
  const toml::node& mode = rd.Require(t, key, "mode");
  const std::string mkey = TomlReader::Join(key, "mode");
  const std::string name = rd.String(mode, mkey);
  const std::size_t q = rd.Choice(&mode, mkey, "mode", name, spec.modes);
  if (def.phi[q].rows != 0) rd.Twice(&mode, mkey, fmt::format("a [[flow]] for mode '{}'", name));
  def.phi[q] = ParseMatrix(rd, rd.Require(t, key, "phi"), TomlReader::Join(key, "phi"),
                           static_cast<Eigen::Index>(spec.state_names.size()),
                           static_cast<Eigen::Index>(spec.alpha.size()), sym);
  for (int r : t.contains("rows") ? ParseCheckedRows(rd, t, key, def.phi[q], spec.alpha, spec.state_names)
                                  : RowsWithUnknowns(def.phi[q], spec.alpha))
    rows.insert(r);
  const toml::node* jc = t.get("jacobian_constant");
  return {q, jc != nullptr && rd.Boolean(*jc, TomlReader::Join(key, "jacobian_constant"))};
}

std::vector<std::string> TakenNames(const ModelSpec& spec);

// A column appended to each of `mats` (φ of every mode, the one ψ, or a [[jump]] map's ψ), as
// ParseMatrix writes an entry: `text` in row r of mats[q], 0 elsewhere (every other matrix gets a zero
// column).
void AppendColumn(const TomlReader& rd, const toml::node& node, const std::string& key, int r, std::size_t q,
                  const std::string& text, std::span<ExprMatrix> mats, Symbols& sym) {
  const auto [value, uses_variable, varies] = CheckExpression(rd, &node, key, text, sym);
  for (std::size_t p = 0; p < mats.size(); ++p) {
    ExprMatrix& m = mats[p];
    for (Eigen::Index i = 0; i < m.rows; ++i) {
      const Eigen::Index at = m.cols * m.rows + i;
      const bool here = p == q && i == r;
      m.constant.push_back(here && !uses_variable ? value : 0.0);
      m.text.push_back(here ? text : "0");
      if (here && uses_variable) {
        m.index.push_back(at);
        m.joined += (m.joined.empty() ? "(" : ",(") + text + ")";
      }
    }
    ++m.cols;
  }
}

// One candidate term `text` of row r in mode q: an unknown α entry `name` (value 0) and its φ column,
// the term in row r of φ_q and 0 elsewhere (every other mode's φ gets a zero column).
void AppendCandidate(const TomlReader& rd, const toml::node& node, const std::string& key, int r, std::size_t q,
                     const std::string& text, Definition& def, Symbols& sym, const std::string& name) {
  ModelSpec& spec = def.spec;
  AppendColumn(rd, node, key, r, q, text, def.phi, sym);
  spec.candidates.push_back({static_cast<int>(spec.alpha.size()), r, text, static_cast<int>(q)});
  spec.alpha.push_back(Parameter{.name = name, .value = 0.0, .description = "candidate term " + text});
}

// Where a table's candidates go: its key (flow, flow[i], jump, jump[m]), its mode q (0 for [flow] and
// the jumps), the prefix of their names ("" for [flow], "MODE_" for a [[flow]], "jump_" for [jump],
// "MAP_" for a [[jump]] map) and the table's identified rows.
struct CandidateTable {
  std::string key;
  std::size_t mode = 0;
  std::string prefix;
  std::vector<int> rows;
  bool jump = false;  // [jump] or a [[jump]] map: β entries and ψ columns
  // A [[jump]] map (being parsed: its ψ is def.psi.back() and its β slice ends β): the candidates
  // extend its slice. Null for [jump] and the flows.
  JumpMap* map = nullptr;
};

// KEY.candidates = { ROW = ["TERM", ...] } (at least one row): per identified row of the table its candidate terms, each
// appended to α and φ (a flow's) or to β and ψ (the [jump]'s, a [[jump]] map's), named PREFIX + ROW_K; the name may be
// no state's, parameter's (α, β, γ, the flow candidates' included) or input's. The flow Jacobian of a
// model with flow candidates is not declared constant.
void ParseCandidates(const TomlReader& rd, const toml::node& node, const CandidateTable& table, Definition& def,
                     Symbols& sym) {
  ModelSpec& spec = def.spec;
  std::vector<std::string> taken = TakenNames(spec);
  taken.insert(taken.end(), spec.inputs.begin(), spec.inputs.end());
  for (const Parameter& p : spec.guard_params) taken.push_back(p.name);
  const std::string ckey = TomlReader::Join(table.key, "candidates");
  const char* vector = table.jump ? "beta" : "alpha";
  const std::size_t limit = std::size_t(table.jump ? Model::kMaxParameters : Model::kMaxAlpha);
  const toml::table& rows = rd.Table(node, ckey);
  rd.NotEmpty(&node, ckey, rows.size(), "row of candidate terms (ROW = [\"TERM\", ...])");
  for (auto&& [k, v] : rows) {
    const std::string row_name(k.str());
    const std::string key = TomlReader::Join(ckey, row_name);
    const int r = static_cast<int>(rd.Choice(&v, key, "state", row_name, spec.state_names));
    if (std::find(table.rows.begin(), table.rows.end(), r) == table.rows.end()) {
      rd.Fail(&v, key, fmt::format("'{}' is not one of {}.rows: candidate terms are in identified rows", row_name,
                                   table.key));
    }
    const toml::array& terms = rd.Array(v, key);
    rd.NotEmpty(&terms, key, terms.size(), "candidate term");
    std::vector<std::string> seen;
    for (std::size_t i = 0; i < terms.size(); ++i) {
      const std::string ikey = TomlReader::Index(key, i);
      const std::string text = EntryText(rd, terms[i], ikey);
      if (std::find(seen.begin(), seen.end(), text) != seen.end()) rd.Twice(&terms[i], ikey, fmt::format("\"{}\"", text));
      seen.push_back(text);
      const std::string name = fmt::format("{}{}_{}", table.prefix, row_name, i + 1);
      if (std::find(taken.begin(), taken.end(), name) != taken.end()) {
        rd.Fail(&terms[i], ikey, fmt::format("the candidate's name '{}' is already taken (a state, parameter or input)", name));
      }
      if ((table.jump ? spec.beta.size() : spec.alpha.size()) >= limit) {
        rd.Fail(&terms[i], ikey, fmt::format("{} with the candidates would have more than {} entries", vector, limit));
      }
      if (table.jump) {
        AppendColumn(rd, terms[i], ikey, r, 0, text,
                     table.map ? std::span<ExprMatrix>(&def.psi.back(), 1) : std::span<ExprMatrix>(def.psi), sym);
        const int map = table.map ? static_cast<int>(spec.jumps.size()) : -1;
        spec.jump_candidates.push_back({static_cast<int>(spec.beta.size()), r, text, map});
        spec.beta.push_back(Parameter{.name = name, .value = 0.0, .description = "candidate jump term " + text});
        if (table.map) ++table.map->beta_count;
      } else {
        AppendCandidate(rd, terms[i], ikey, r, table.mode, text, def, sym, name);
      }
      taken.push_back(name);
    }
  }
  if (!table.jump) spec.flow_jacobian_constant = false;
}

// A table with candidates (a [[flow]] or a [[jump]] map) must give its rows, and its mode's or map's
// name (`what`: "mode" or "map") must make parameter names (NAME_ROW_K).
void CheckCandidateTable(const TomlReader& rd, const toml::table& t, const std::string& key, const char* what,
                         const std::string& name) {
  const toml::node* c = t.get("candidates");
  if (!t.contains("rows")) {
    rd.Fail(c, TomlReader::Join(key, "candidates"),
            fmt::format("candidate terms need the table's identified rows: give {}.rows", key));
  }
  const auto word = [](char ch) { return std::isalnum(static_cast<unsigned char>(ch)) != 0 || ch == '_'; };
  if (name.empty() || !(std::isalpha(static_cast<unsigned char>(name[0])) != 0 || name[0] == '_') ||
      !std::all_of(name.begin(), name.end(), word)) {
    rd.Fail(c, TomlReader::Join(key, "candidates"),
            fmt::format("{} '{}' does not make candidate names {}_ROW_K: candidate terms need a {} name that "
                        "is an identifier (a letter or _, then letters, digits or _)",
                        what, Abbreviated(name, 40), what == std::string_view("mode") ? "MODE" : "MAP", what));
  }
}

// The candidates of a [[flow]] table, named MODE_ROW_K.
CandidateTable ModeCandidateTable(const TomlReader& rd, const toml::table& t, const std::string& key, std::size_t q,
                                  const ModelSpec& spec) {
  CheckCandidateTable(rd, t, key, "mode", spec.modes[q]);
  return {key, q, spec.modes[q] + "_", ParseRows(rd, t, key, spec.state_names)};
}

// [flow] (one mode) or, with modes, one [[flow]] per mode: φ_q over the one α. flow_rows is the union
// of the modes' rows; jacobian_constant holds when every mode declares it. Candidate terms are
// appended after every φ_q is read (each adds a column to every mode's φ).
void ParseFlows(const TomlReader& rd, const toml::table& root, Definition& def, Symbols& sym) {
  ModelSpec& spec = def.spec;
  const toml::node& node = rd.Require(root, "", "flow");
  if (!node.is_array()) {
    if (!spec.modes.empty()) {
      rd.Fail(&node, "flow", "with modes = [...], give one [[flow]] table per mode (mode = \"NAME\")");
    }
    const toml::table& t = rd.Table(node, "flow");
    rd.OnlyKeys(t, "flow", {"phi", "rows", "jacobian_constant", "candidates"});
    def.phi = {ParseMatrix(rd, rd.Require(t, "flow", "phi"), "flow.phi",
                           static_cast<Eigen::Index>(spec.state_names.size()),
                           static_cast<Eigen::Index>(spec.alpha.size()), sym)};
    // Without rows: the rows of φ with an unknown α entry (as a [[flow]] table's).
    spec.flow_rows = t.contains("rows") || RowsWithUnknowns(def.phi[0], spec.alpha).empty()
                         ? ParseCheckedRows(rd, t, "flow", def.phi[0], spec.alpha, spec.state_names)
                         : RowsWithUnknowns(def.phi[0], spec.alpha);
    if (const toml::node* jc = t.get("jacobian_constant"))
      spec.flow_jacobian_constant = rd.Boolean(*jc, "flow.jacobian_constant");
    if (const toml::node* c = t.get("candidates")) ParseCandidates(rd, *c, {"flow", 0, "", spec.flow_rows}, def, sym);
    return;
  }
  const toml::array& arr = *node.as_array();
  if (spec.modes.empty()) {
    rd.Fail(&arr, "flow", "[[flow]] tables need modes = [\"NAME\", ...] (one [flow] table has no mode)");
  }
  def.phi.assign(spec.modes.size(), ExprMatrix{});
  std::set<int> rows;
  bool constant = true;
  std::vector<std::pair<const toml::node*, CandidateTable>> candidates;
  for (std::size_t i = 0; i < arr.size(); ++i) {
    const std::string key = TomlReader::Index("flow", i);
    const toml::table& t = rd.Table(arr[i], key);
    const auto [q, jc] = ParseModeFlow(rd, t, key, def, sym, rows);
    constant = jc && constant;
    if (const toml::node* c = t.get("candidates")) candidates.emplace_back(c, ModeCandidateTable(rd, t, key, q, spec));
  }
  for (std::size_t q = 0; q < spec.modes.size(); ++q) {
    if (def.phi[q].rows == 0)
      rd.Fail(root.get("modes"), "modes", fmt::format("mode '{}' has no [[flow]] table", spec.modes[q]));
  }
  if (rows.empty()) rd.Fail(&arr, "flow", "no mode's phi has an unknown alpha: give rows");
  spec.flow_rows.assign(rows.begin(), rows.end());
  spec.flow_jacobian_constant = constant;
  for (const auto& [c, table] : candidates) ParseCandidates(rd, *c, table, def, sym);
}

// The names a map's β may not take: α, β so far, γ, inputs.
bool NameTaken(const ModelSpec& spec, const std::string& name) {
  for (const auto* list : {&spec.alpha, &spec.beta, &spec.guard_params}) {
    for (const Parameter& p : *list) {
      if (p.name == name) return true;
    }
  }
  return std::find(spec.inputs.begin(), spec.inputs.end(), name) != spec.inputs.end();
}

// jump[m].beta and .psi: the map's parameters, appended to β as its slice, and ψ_m (n × |β_m|).
void ParseMapPsi(const TomlReader& rd, const toml::table& t, const std::string& key, Definition& def, Symbols& sym,
                 JumpMap& map) {
  ModelSpec& spec = def.spec;
  const toml::node* beta = t.get("beta");
  if (beta == nullptr) {
    rd.Fail(t.get("psi"), TomlReader::Join(key, "psi"), "psi needs the map's own parameters: give beta = [...]");
  }
  const std::string bkey = TomlReader::Join(key, "beta");
  std::vector<Parameter> params = ParseParameterList(rd, *beta, bkey, false);
  for (std::size_t i = 0; i < params.size(); ++i) {
    if (!NameTaken(spec, params[i].name)) continue;
    const std::string nkey = TomlReader::Join(TomlReader::Index(bkey, i), "name");
    rd.Fail(t.at_path(nkey.substr(key.size() + 1)).node(), nkey,
            fmt::format("'{}' is already the name of a parameter or an input", params[i].name));
  }
  if (spec.beta.size() + params.size() > std::size_t(Model::kMaxParameters)) {
    rd.Fail(beta, bkey, fmt::format("the maps' β would have {} entries, at most {}", spec.beta.size() + params.size(),
                                    Model::kMaxParameters));
  }
  map.beta_first = static_cast<int>(spec.beta.size());
  map.beta_count = static_cast<int>(params.size());
  spec.beta.insert(spec.beta.end(), params.begin(), params.end());
  def.psi.push_back(ParseMatrix(rd, *t.get("psi"), TomlReader::Join(key, "psi"),
                                static_cast<Eigen::Index>(spec.state_names.size()), map.beta_count, sym));
  map.rows = ParseCheckedRows(rd, t, key, def.psi.back(), params, spec.state_names);
}

// One [[jump]] table: name, guard, from/to modes, and β, ψ, rows (none of the three: the identity),
// and candidates of its rows (named MAP_ROW_K, extending its β slice).
void ParseJumpMap(const TomlReader& rd, const toml::table& t, const std::string& key, Definition& def, Symbols& sym,
                  const std::vector<std::string>& guards) {
  ModelSpec& spec = def.spec;
  rd.OnlyKeys(t, key, {"name", "guard", "from", "to", "beta", "psi", "rows", "candidates"});
  JumpMap map;
  const std::string nkey = TomlReader::Join(key, "name");
  map.name = rd.String(rd.Require(t, key, "name"), nkey);
  for (const JumpMap& other : spec.jumps) {
    if (other.name == map.name) rd.Twice(t.get("name"), nkey, fmt::format("jump map name '{}'", map.name));
  }
  const std::string gkey = TomlReader::Join(key, "guard");
  const toml::node& guard = rd.Require(t, key, "guard");
  map.guard = static_cast<int>(rd.Choice(&guard, gkey, "guard", rd.String(guard, gkey), guards));
  for (auto [k, field] : {std::pair{"from", &map.from}, std::pair{"to", &map.to}}) {
    const toml::node* mode = t.get(k);
    if (mode == nullptr) continue;
    const std::string mkey = TomlReader::Join(key, k);
    if (spec.modes.empty()) rd.Fail(mode, mkey, "names a mode, but the file has no modes = [...]");
    *field = static_cast<int>(rd.Choice(mode, mkey, "mode", rd.String(*mode, mkey), spec.modes));
  }
  if (t.contains("psi")) {
    ParseMapPsi(rd, t, key, def, sym, map);
    if (const toml::node* c = t.get("candidates")) {
      CheckCandidateTable(rd, t, key, "map", map.name);
      ParseCandidates(rd, *c, {key, 0, map.name + "_", map.rows, true, &map}, def, sym);
    }
  } else {
    for (const char* k : {"beta", "rows", "candidates"}) {
      if (t.contains(k)) {
        rd.Fail(t.get(k), TomlReader::Join(key, k),
                fmt::format("an identity map (no psi: a mode switch, ξ+ = ξ) has no {}: give psi or drop {}",
                            std::string_view(k) == "beta" ? "parameters" : std::string_view(k) == "rows" ? "rows" : "candidate terms", k));
      }
    }
    map.identity = true;
    def.psi.push_back(ExprMatrix{static_cast<Eigen::Index>(spec.state_names.size()), 0, {}, {}, {}, {}});
  }
  spec.jumps.push_back(std::move(map));
}

// The guards' names, distinct: the maps name their guard.
std::vector<std::string> GuardNames(const TomlReader& rd, const toml::table& root, const ModelSpec& spec) {
  std::vector<std::string> names;
  for (std::size_t g = 0; g < spec.guards.size(); ++g) {
    const std::string key = TomlReader::Join(TomlReader::Index("guard", g), "name");
    if (std::find(names.begin(), names.end(), spec.guards[g].name) != names.end())
      rd.Twice(root.at_path(key).node(), key, fmt::format("guard name '{}' (jump maps name their guard)", spec.guards[g].name));
    names.push_back(spec.guards[g].name);
  }
  return names;
}

// Every guard triggers a map, and no guard triggers two maps in one mode (a map without `from`
// leaves every mode).
void CheckArming(const TomlReader& rd, const toml::table& root, const toml::array& jumps, const ModelSpec& spec,
                 const std::vector<std::string>& names) {
  std::map<std::pair<int, int>, std::size_t> armed;
  for (std::size_t m = 0; m < spec.jumps.size(); ++m) {
    const JumpMap& map = spec.jumps[m];
    for (int q = 0; q < ModeCount(spec); ++q) {
      if (map.from >= 0 && map.from != q) continue;
      const auto [it, fresh] = armed.emplace(std::pair{q, map.guard}, m);
      if (fresh) continue;
      const std::string key = TomlReader::Join(TomlReader::Index("jump", m), "guard");
      rd.Fail(jumps[m].as_table()->get("guard"), key,
              fmt::format("guard '{}' already triggers map '{}'{} (one map per guard and mode)",
                          names[std::size_t(map.guard)], spec.jumps[it->second].name,
                          spec.modes.empty() ? "" : fmt::format(" in mode '{}'", spec.modes[std::size_t(q)])));
    }
  }
  for (std::size_t g = 0; g < spec.guards.size(); ++g) {
    const bool used = std::any_of(spec.jumps.begin(), spec.jumps.end(),
                                  [&](const JumpMap& map) { return map.guard == static_cast<int>(g); });
    if (used) continue;
    const std::string key = TomlReader::Index("guard", g);
    rd.Fail(root.at_path(key).node(), key,
            fmt::format("guard '{}' triggers no [[jump]] map (give one with guard = \"{}\")", names[g], names[g]));
  }
}

// [jump] (one map over all of β, every guard) or [[jump]] maps. jump_rows is the union of the maps' rows.
void ParseJumps(const TomlReader& rd, const toml::table& root, Definition& def, Symbols& sym) {
  ModelSpec& spec = def.spec;
  const toml::node& node = rd.Require(root, "", "jump");
  if (!node.is_array()) {
    if (spec.modes.size() > 1) {
      rd.Fail(&node, "jump", "several modes switch by [[jump]] maps with from/to: one [jump] table has no modes");
    }
    const toml::table& t = rd.Table(node, "jump");
    rd.OnlyKeys(t, "jump", {"psi", "rows", "candidates"});
    def.psi = {ParseMatrix(rd, rd.Require(t, "jump", "psi"), "jump.psi",
                           static_cast<Eigen::Index>(spec.state_names.size()),
                           static_cast<Eigen::Index>(spec.beta.size()), sym)};
    spec.jump_rows = ParseCheckedRows(rd, t, "jump", def.psi[0], spec.beta, spec.state_names);
    if (const toml::node* c = t.get("candidates"))
      ParseCandidates(rd, *c, {"jump", 0, "jump_", spec.jump_rows, true}, def, sym);
    return;
  }
  const toml::array& arr = *node.as_array();
  rd.NotEmpty(&arr, "jump", arr.size(), "[[jump]]");
  def.sliced = true;
  const std::vector<std::string> guards = GuardNames(rd, root, spec);
  for (std::size_t m = 0; m < arr.size(); ++m) {
    const std::string key = TomlReader::Index("jump", m);
    ParseJumpMap(rd, rd.Table(arr[m], key), key, def, sym, guards);
  }
  CheckArming(rd, root, arr, spec, guards);
  std::set<int> rows;
  for (const JumpMap& map : spec.jumps) rows.insert(map.rows.begin(), map.rows.end());
  spec.jump_rows.assign(rows.begin(), rows.end());
}

void ParseSets(const TomlReader& rd, const toml::table& root, Definition& def, Symbols& sym) {
  if (!root.contains("sets") && (def.sliced || !def.spec.modes.empty())) {
    def.has_sets = false;  // C every state, D empty: an automaton jumps at its armed guards' crossings
    return;
  }
  constexpr const char* kMissing =
      "one [flow] and one [jump] need the flow set C and the jump set D "
      "([sets] C = \"...\", D = \"...\"); to jump exactly where the guards are crossed, write the jump "
      "as a [[jump]] map (name, guard, its own beta), where [sets] is optional";
  const toml::table& t = rd.Table(rd.Require(root, "", "sets", kMissing), "sets");
  rd.OnlyKeys(t, "sets", {"C", "D", "distance_to_D"});
  auto one = [&](const char* k) -> std::string {
    const std::string key = TomlReader::Join("sets", k);
    const toml::node& n = rd.Require(t, "sets", k);
    const std::string text = EntryText(rd, n, key);
    CheckExpression(rd, &n, key, text, sym);
    return text;
  };
  def.in_c = one("C");
  def.in_d = one("D");
  if (t.contains("distance_to_D")) def.distance = one("distance_to_D");
}

void ParseDefaults(const TomlReader& rd, const toml::table& root, ModelSpec& spec) {
  const toml::table& t = rd.Table(rd.Require(root, "", "defaults"), "defaults");
  rd.OnlyKeys(t, "defaults", {"x0", "t_end", "dt", "mode"});
  if (const toml::node* mode = t.get("mode")) {
    if (spec.modes.empty()) rd.Fail(mode, "defaults.mode", "names a mode, but the file has no modes = [...]");
    spec.default_mode =
        static_cast<int>(rd.Choice(mode, "defaults.mode", "mode", rd.String(*mode, "defaults.mode"), spec.modes));
  }
  const toml::node& x0 = rd.Require(t, "defaults", "x0");
  spec.default_x0 = rd.Numbers(x0, "defaults.x0");
  rd.Size(&x0, "defaults.x0", spec.default_x0.size(), spec.state_names.size(), "one per state");
  // t_end and dt may be left out: ModelSpec's defaults (10 and 1e-3).
  for (auto [k, field] : {std::pair{"t_end", &spec.default_t_end}, std::pair{"dt", &spec.default_dt}}) {
    const toml::node* n = t.get(k);
    if (n == nullptr) continue;
    *field = rd.Number(*n, TomlReader::Join("defaults", k));
    rd.Above(n, TomlReader::Join("defaults", k), *field, 0.0);
  }
}

// The default trajectory of a user's file is simulated when the file is loaded: within the samples
// limit. A shipped text (the built-in models) is exempt: a small HYSID_MAX_SAMPLES bounds what a run
// asks for, and must not make the built-in models unloadable.
void CheckDefaultSamples(const TomlReader& rd, const toml::table& root, const ModelSpec& spec) {
  const toml::table& t = *root.get("defaults")->as_table();
  const double samples = std::min(spec.default_t_end / spec.default_dt, 9e18) + 1.0;
  if (samples > static_cast<double>(LimitValue(kMaxSamples))) {
    rd.Fail(t.contains("dt") ? t.get("dt") : &t, "defaults.dt",
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

// The [[jump]] maps' lines: "jump NAME (guard G, A -> B): v+ = ..." per state, or "identity".
std::string MapEquations(const Definition& def) {
  const ModelSpec& s = def.spec;
  std::string out;
  for (std::size_t m = 0; m < s.jumps.size(); ++m) {
    const JumpMap& map = s.jumps[m];
    std::string head = fmt::format("jump {} (guard {}", map.name, s.guards[std::size_t(map.guard)].name);
    if (map.from >= 0 || map.to >= 0) {
      head += fmt::format(", {} -> {}", map.from >= 0 ? s.modes[std::size_t(map.from)] : "any",
                          map.to >= 0 ? s.modes[std::size_t(map.to)] : "same");
    }
    if (map.identity) {
      out += head + "): identity (xi+ = xi)\n";
      continue;
    }
    const std::vector<Parameter> slice(s.beta.begin() + map.beta_first,
                                       s.beta.begin() + map.beta_first + map.beta_count);
    for (std::size_t i = 0; i < s.state_names.size(); ++i) {
      out += fmt::format("{}): {}+ = {}\n", head, s.state_names[i], RowText(def.psi[m], Eigen::Index(i), slice));
    }
  }
  return out;
}

std::string Equations(const Definition& def) {
  const ModelSpec& s = def.spec;
  std::string out;
  for (std::size_t q = 0; q < def.phi.size(); ++q) {
    const std::string flow = s.modes.empty() ? "flow" : fmt::format("flow [{}]", s.modes[q]);
    for (std::size_t i = 0; i < s.state_names.size(); ++i) {
      out += fmt::format("{}: {}' = {}\n", flow, s.state_names[i], RowText(def.phi[q], Eigen::Index(i), s.alpha));
    }
  }
  if (def.sliced) {
    out += MapEquations(def);
  } else {
    for (std::size_t i = 0; i < s.state_names.size(); ++i) {
      out += fmt::format("jump: {}+ = {}\n", s.state_names[i], RowText(def.psi[0], Eigen::Index(i), s.beta));
    }
  }
  constexpr const char* kDirection[] = {"falling", "rising", "both"};
  for (std::size_t g = 0; g < s.guards.size(); ++g) {
    out += fmt::format("guard {}: h(xi) = {} ({}){}{}\n", s.guards[g].name, def.guards.text[g],
                       kDirection[static_cast<int>(s.guards[g].direction)],
                       def.project[g].text.empty() ? "" : ", projected: ", fmt::join(def.project[g].text, ", "));
  }
  if (!s.modes.empty()) {
    out += fmt::format("modes: {} (default {})\n", fmt::join(s.modes, ", "), s.modes[std::size_t(s.default_mode)]);
  }
  if (!def.has_sets) {
    out += "C: every state (no [sets])\nD: empty (jumps only at crossings of the guards armed in the mode)\n";
    return out;
  }
  out += fmt::format("C: {}\nD: {}\n", def.in_c, def.in_d);
  if (!def.distance.empty()) out += fmt::format("dist(xi, D) = {}\n", def.distance);
  return out;
}

// A name that becomes a muParser variable (an input or a guard parameter): valid, not a built-in
// function or constant, not t, and not a name already taken.
void CheckVariableName(const TomlReader& rd, const toml::node* node, const std::string& key, const std::string& name,
                       const std::vector<std::string>& taken) {
  mu::Parser probe;
  try {
    double dummy = 0;
    probe.DefineVar(name, &dummy);
  } catch (const mu::Parser::exception_type& e) {
    rd.Fail(node, key, fmt::format("'{}' is not a valid variable name: {}", name, e.GetMsg()));
  }
  if (probe.GetFunDef().contains(name) || probe.GetConst().contains(name) || name == "t") {
    rd.Fail(node, key, fmt::format("'{}' is a built-in name of the expressions (a function, a constant or t)", name));
  }
  if (std::find(taken.begin(), taken.end(), name) != taken.end()) {
    rd.Fail(node, key, fmt::format("'{}' is already the name of a state, a parameter or an input", name));
  }
}

// The names taken before inputs and guard parameters: states, α and β.
std::vector<std::string> TakenNames(const ModelSpec& spec) {
  std::vector<std::string> taken = spec.state_names;
  for (const auto* list : {&spec.alpha, &spec.beta}) {
    for (const Parameter& p : *list) taken.push_back(p.name);
  }
  return taken;
}

// measured = ["x", ...]: state names, at least one, no duplicates (absent: every state).
std::vector<int> ParseMeasured(const TomlReader& rd, const toml::table& root, const std::vector<std::string>& states) {
  const toml::node* node = root.get("measured");
  if (node == nullptr) return {};
  const toml::array& arr = rd.Array(*node, "measured");
  rd.NotEmpty(&arr, "measured", arr.size(), "measured state");
  std::vector<int> out;
  for (std::size_t i = 0; i < arr.size(); ++i) {
    const std::string key = TomlReader::Index("measured", i);
    const std::string name = rd.String(arr[i], key);
    const int at = static_cast<int>(rd.Choice(&arr[i], key, "state", name, states));
    if (std::find(out.begin(), out.end(), at) != out.end()) rd.Twice(&arr[i], key, fmt::format("'{}'", name));
    out.push_back(at);
  }
  return out;
}

// inputs = ["u", ...]: new variable names, no duplicates.
std::vector<std::string> ParseInputs(const TomlReader& rd, const toml::table& root, std::vector<std::string> taken) {
  return ParseNames(rd, root, "inputs", [&](const toml::node& node, const std::string& key, const std::string& name) {
    CheckVariableName(rd, &node, key, name, taken);
    taken.push_back(name);
  });
}

// input_defaults = { u = "expression of t", ... }: one entry per named input at most.
std::vector<std::string> ParseInputDefaults(const TomlReader& rd, const toml::table& root, const ModelSpec& spec) {
  const toml::node* node = root.get("input_defaults");
  if (node == nullptr) return {};
  std::vector<std::string> out(spec.inputs.size());
  Symbols time{{"t"}, {"t"}, {}, "time t"};
  for (auto&& [k, v] : rd.Table(*node, "input_defaults")) {
    const std::string key = TomlReader::Join("input_defaults", k.str());
    const std::size_t at = rd.Choice(&v, key, "input", std::string(k.str()), spec.inputs);
    out[at] = rd.String(v, key);
    CheckExpression(rd, &v, key, out[at], time);
  }
  return out;
}

// Every input and guard parameter must appear in some expression.
void CheckUsed(const TomlReader& rd, const toml::table& root, const ModelSpec& spec, const Symbols& sym) {
  for (std::size_t i = 0; i < spec.inputs.size(); ++i) {
    if (sym.used.contains(spec.inputs[i])) continue;
    const std::string key = TomlReader::Index("inputs", i);
    rd.Fail(root.at_path(key).node(), key,
            fmt::format("input '{}' is used in no expression (phi, psi, guards, projections, sets)", spec.inputs[i]));
  }
  for (std::size_t i = 0; i < spec.guard_params.size(); ++i) {
    if (sym.used.contains(spec.guard_params[i].name)) continue;
    const std::string key = TomlReader::Join(TomlReader::Index("guard_params", i), "name");
    rd.Fail(root.at_path(key).node(), key,
            fmt::format("guard parameter '{}' is used in no expression (phi, psi, guards, projections, sets)",
                        spec.guard_params[i].name));
  }
}

std::shared_ptr<Definition> ParseDefinition(const TomlReader& rd, const toml::table& root) {
  rd.OnlyKeys(
      root, "",
      {"name", "description", "states", "measured", "inputs", "input_defaults", "alpha", "beta", "guard_params",
       "modes", "flow", "jump", "guard", "sets", "defaults"});
  auto def = std::make_shared<Definition>();
  ModelSpec& spec = def->spec;
  spec.name = rd.String(rd.Require(root, "", "name"), "name");
  if (const toml::node* d = root.get("description")) spec.description = rd.String(*d, "description");
  spec.state_names = ParseStates(rd, root);
  spec.alpha = ParseParameters(rd, root, "alpha");
  if (const toml::node* jump = root.get("jump"); jump != nullptr && jump->is_array()) {
    if (const toml::node* beta = root.get("beta"))
      rd.Fail(beta, "beta", "with [[jump]] maps each map has its own beta (jump[m].beta)");
  } else {
    spec.beta = ParseParameters(rd, root, "beta");
  }
  spec.modes = ParseModes(rd, root);
  spec.measured = ParseMeasured(rd, root, spec.state_names);
  spec.inputs = ParseInputs(rd, root, TakenNames(spec));
  spec.input_defaults = ParseInputDefaults(rd, root, spec);
  spec.guard_params = ParseParameters(rd, root, "guard_params");
  std::vector<std::string> taken = TakenNames(spec);
  taken.insert(taken.end(), spec.inputs.begin(), spec.inputs.end());
  for (std::size_t i = 0; i < spec.guard_params.size(); ++i) {
    const std::string key = TomlReader::Join(TomlReader::Index("guard_params", i), "name");
    CheckVariableName(rd, root.at_path(key).node(), key, spec.guard_params[i].name, taken);
    taken.push_back(spec.guard_params[i].name);
  }
  def->contextual = !spec.inputs.empty() || !spec.guard_params.empty();
  def->binds_time = !spec.inputs.empty() &&
                    std::find(spec.state_names.begin(), spec.state_names.end(), "t") == spec.state_names.end();
  Symbols sym = MakeSymbols(*def);
  ParseFlows(rd, root, *def, sym);
  for (const Parameter& g : spec.guard_params) def->flow_reads_gamma.push_back(sym.used.contains(g.name));
  for (const ExprMatrix& phi : def->phi) {
    def->phi_rows.emplace_back();
    for (Eigen::Index r = 0; r < phi.rows; ++r) def->phi_rows.back().push_back(RowOf(phi, r));
    def->phi_reading.push_back(PartsReading(*def, phi));
  }
  ParseGuardHeads(rd, root, *def);
  ParseJumps(rd, root, *def, sym);
  Symbols with = WithParameters(sym, spec);
  ParseGuardExpressions(rd, root, *def, with, sym);
  ParseSets(rd, root, *def, with);
  sym.used.insert(with.used.begin(), with.used.end());
  for (const auto* list : {&spec.alpha, &spec.beta}) {
    for (const Parameter& p : *list) def->reads_parameters = def->reads_parameters || (ParameterBound(spec, p) && with.used.contains(p.name));
  }
  CheckUsed(rd, root, spec, sym);
  ParseDefaults(rd, root, spec);
  spec.equations = Equations(*def);
  def->id = next_definition_id.fetch_add(1);
  return def;
}

// The inputs at t = 0 from their defaults (0 where an input has none): where x0 is checked.
std::vector<double> InputsAtStart(const ModelSpec& spec) {
  std::vector<double> u(spec.inputs.size(), 0.0);
  for (std::size_t i = 0; i < spec.input_defaults.size(); ++i) {
    if (spec.input_defaults[i].empty()) continue;
    double t = 0.0;
    mu::Parser p;
    p.DefineVar("t", &t);
    p.SetExpr(spec.input_defaults[i]);
    u[i] = p.Eval();
  }
  return u;
}

}  // namespace

ModelFile ParseModelFile(std::string_view text, const std::string& name, bool shipped) {
  const TomlReader rd(name);
  const toml::table root = ParseToml(text, name);
  std::shared_ptr<const Definition> def = ParseDefinition(rd, root);
  if (!shipped) CheckDefaultSamples(rd, root, def->spec);
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
  const std::vector<double> u0 = InputsAtStart(s);
  const Context start{.t = 0.0, .u = u0.data(), .mode = s.default_mode};
  if (!out.model.InFlowSet(x0, start) && !out.model.InJumpSet(x0, start)) {
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
