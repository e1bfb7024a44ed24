#include "core/model/model.hpp"

#include "core/model/automaton.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <set>
#include <stdexcept>

#include <fmt/format.h>
#include <fmt/ranges.h>

namespace hysid {
namespace {

void Require(bool ok, const std::string& model, const std::string& what) {
  if (!ok) throw std::invalid_argument(fmt::format("model '{}': {}", model, what));
}

void CheckBounds(const Parameter& p, const std::string& model) {
  Require(!std::isnan(p.lower) && !std::isnan(p.upper) && p.lower < p.upper, model,
          fmt::format("parameter '{}': bounds [{}, {}] need lower < upper", p.name, p.lower, p.upper));
  Require(p.value >= p.lower && p.value <= p.upper, model,
          fmt::format("parameter '{}' = {} is outside its bounds [{}, {}]", p.name, p.value, p.lower, p.upper));
}

Vec Values(const std::vector<Parameter>& params) {
  Vec v(static_cast<Eigen::Index>(params.size()));
  for (std::size_t i = 0; i < params.size(); ++i) v[Eigen::Index(i)] = params[i].value;
  return v;
}

}  // namespace

void Model::Init() {
  spec_ = impl_->Spec();
  CheckSpec();
  alpha_ = Values(spec_.alpha);
  beta_ = Values(spec_.beta);
  gamma_ = Values(spec_.guard_params);
  contextual_ = !spec_.inputs.empty() || !spec_.guard_params.empty() || IsAutomaton(spec_);
}

void Model::CheckSpec() const {
  const std::string& name = spec_.name;
  const int n = state_size();
  Require(!name.empty(), "?", "ModelSpec::name is empty");
  Require(n >= 1 && n <= kMaxStates, name, fmt::format("state size {} outside [1, {}]", n, kMaxStates));
  Require(!spec_.alpha.empty() && static_cast<int>(spec_.alpha.size()) <= kMaxAlpha, name,
          fmt::format("alpha must have between 1 and {} entries", kMaxAlpha));
  const bool all_identity = !spec_.jumps.empty() && std::all_of(spec_.jumps.begin(), spec_.jumps.end(),
                                                                  [](const JumpMap& m) { return m.identity; });
  Require((all_identity || !spec_.beta.empty()) && static_cast<int>(spec_.beta.size()) <= kMaxParameters, name,
          "beta must have between 1 and 32 entries (none only when every jump map is an identity)");
  Require(static_cast<int>(spec_.guard_params.size()) <= kMaxParameters, name,
          "guard_params must have at most 32 entries");
  // α and β names may repeat a state's (they are never variables of an expression); γ and inputs may not.
  const std::set<std::string> states(spec_.state_names.begin(), spec_.state_names.end());
  std::set<std::string> names;
  for (const auto* list : {&spec_.alpha, &spec_.beta, &spec_.guard_params}) {
    for (const Parameter& p : *list) {
      Require(!p.name.empty(), name, "a parameter has an empty name");
      Require(names.insert(p.name).second, name, fmt::format("parameter '{}' twice", p.name));
      Require(list != &spec_.guard_params || !states.contains(p.name), name,
              fmt::format("guard parameter '{}' has a state's name", p.name));
      Require(std::isfinite(p.value), name, fmt::format("parameter '{}' is not finite", p.name));
      CheckBounds(p, name);
    }
  }
  Require(static_cast<int>(spec_.inputs.size()) <= kMaxParameters, name, "inputs must have at most 32 entries");
  for (const std::string& u : spec_.inputs) {
    Require(!u.empty(), name, "an input has an empty name");
    Require(!states.contains(u) && names.insert(u).second, name,
            fmt::format("input '{}' twice, or the name of a state or parameter", u));
  }
  Require(spec_.input_defaults.empty() || spec_.input_defaults.size() == spec_.inputs.size(), name,
          "input_defaults must be empty or have one entry per input");
  std::set<int> measured;
  for (int r : spec_.measured) {
    Require(r >= 0 && r < n, name, fmt::format("measured state {} outside [0, {})", r, n));
    Require(measured.insert(r).second, name, fmt::format("measured state {} twice", r));
  }
  for (const auto* rows : {&spec_.flow_rows, &spec_.jump_rows}) {
    Require(!rows->empty() || (rows == &spec_.jump_rows && all_identity), name,
            "flow_rows and jump_rows must not be empty");
    for (int r : *rows) Require(r >= 0 && r < n, name, fmt::format("row {} outside [0, {})", r, n));
  }
  Require(!spec_.guards.empty(), name, "a hybrid model needs at least one guard");
  CheckAutomaton();
  Require(static_cast<int>(spec_.default_x0.size()) == n, name, "default_x0 must have one entry per state");
}

// Modes and jump maps (core/model/automaton.hpp): indices in range, β slices inside β and apart, every
// guard triggering a map, no (mode, guard) pair with two maps.
void Model::CheckAutomaton() const {
  const std::string& name = spec_.name;
  const int modes = static_cast<int>(spec_.modes.size());
  const int guards = guard_count();
  const int nbeta = beta_size_spec();
  Require(modes <= kMaxParameters, name, "modes must have at most 32 entries");
  Require(std::set<std::string>(spec_.modes.begin(), spec_.modes.end()).size() == spec_.modes.size(), name,
          "a mode name appears twice");
  Require(modes <= 1 || !spec_.jumps.empty(), name, "several modes need jump maps to switch between them");
  Require(spec_.default_mode >= 0 && spec_.default_mode < std::max(1, modes), name,
          fmt::format("default_mode {} outside [0, {})", spec_.default_mode, std::max(1, modes)));
  if (spec_.jumps.empty()) return;
  std::vector<int> owner(static_cast<std::size_t>(nbeta), -1);
  std::set<std::pair<int, int>> armed;
  std::set<std::string> names;
  std::vector<char> triggers(static_cast<std::size_t>(guards), 0);
  for (std::size_t m = 0; m < spec_.jumps.size(); ++m) {
    const JumpMap& map = spec_.jumps[m];
    const std::string what = fmt::format("jump map '{}'", map.name);
    Require(!map.name.empty() && names.insert(map.name).second, name, "jump map names must be non-empty and distinct");
    Require(map.guard >= 0 && map.guard < guards, name, fmt::format("{}: guard {} outside [0, {})", what, map.guard, guards));
    for (int q : {map.from, map.to}) {
      Require(q >= -1 && q < std::max(1, modes), name, fmt::format("{}: mode {} outside [0, {})", what, q, std::max(1, modes)));
    }
    for (int q = 0; q < std::max(1, modes); ++q) {
      if (map.from >= 0 && map.from != q) continue;
      Require(armed.insert({q, map.guard}).second, name,
              fmt::format("{}: guard '{}' already triggers another map in mode {}", what,
                          spec_.guards[std::size_t(map.guard)].name, q));
    }
    triggers[std::size_t(map.guard)] = 1;
    Require(!map.identity || (map.beta_count == 0 && map.rows.empty()), name,
            fmt::format("{}: an identity map has no β and no rows", what));
    Require(map.beta_first >= 0 && map.beta_count >= 0 && map.beta_first + map.beta_count <= nbeta, name,
            fmt::format("{}: β slice [{}, {}) outside β's {} entries", what, map.beta_first,
                        map.beta_first + map.beta_count, nbeta));
    for (int b = map.beta_first; b < map.beta_first + map.beta_count; ++b) {
      Require(owner[std::size_t(b)] < 0, name, fmt::format("{}: β entry {} belongs to two maps", what, b));
      owner[std::size_t(b)] = static_cast<int>(m);
    }
    for (int r : map.rows) Require(r >= 0 && r < state_size(), name, fmt::format("{}: row {} outside [0, {})", what, r, state_size()));
  }
  for (int g = 0; g < guards; ++g) {
    Require(triggers[std::size_t(g)] != 0, name,
            fmt::format("guard '{}' triggers no jump map", spec_.guards[std::size_t(g)].name));
  }
  for (int b = 0; b < nbeta; ++b) {
    Require(owner[std::size_t(b)] >= 0, name, fmt::format("β entry '{}' belongs to no jump map", spec_.beta[std::size_t(b)].name));
  }
}

void Model::Jump(const ConstVecRef& x, const ConstVecRef& beta, VecRef xplus, const Context& ctx) const {
  if (IsIdentityMap(ctx.map)) {
    for (Eigen::Index i = 0; i < x.size(); ++i) xplus(i) = x(i);
    return;
  }
  impl_->Jump(x, beta, Resolve(ctx), xplus);
}

void Model::ThrowMissingInputs() const {
  throw std::logic_error(fmt::format("model '{}' has inputs ({}): it must be evaluated with Context::u set",
                                     spec_.name, fmt::join(spec_.inputs, ", ")));
}

void Model::SetParameter(std::string_view pname, double value) {
  for (auto [list, vec] : {std::pair{&spec_.alpha, &alpha_}, std::pair{&spec_.beta, &beta_},
                           std::pair{&spec_.guard_params, &gamma_}}) {
    for (std::size_t i = 0; i < list->size(); ++i) {
      Parameter& p = (*list)[i];
      if (p.name != pname) continue;
      if (p.known) {
        throw std::invalid_argument(fmt::format(
            "parameter '{}' of model '{}' is a known constant of the model structure", pname, spec_.name));
      }
      if (!std::isfinite(value)) {
        throw std::invalid_argument(fmt::format("parameter '{}' = {}: must be finite", pname, value));
      }
      if (value < p.lower || value > p.upper) {
        throw std::invalid_argument(
            fmt::format("parameter '{}' = {}: outside its bounds [{}, {}]", pname, value, p.lower, p.upper));
      }
      p.value = value;
      (*vec)[Eigen::Index(i)] = value;
      return;
    }
  }
  std::string known;
  for (const auto* list : {&spec_.alpha, &spec_.beta, &spec_.guard_params}) {
    for (const Parameter& p : *list) {
      if (!p.known) known += (known.empty() ? "" : ", ") + p.name;
    }
  }
  throw std::invalid_argument(
      fmt::format("model '{}' has no parameter '{}' (parameters: {})", spec_.name, pname, known));
}

void Model::SetBounds(std::string_view pname, double lower, double upper) {
  for (auto* list : {&spec_.alpha, &spec_.beta, &spec_.guard_params}) {
    for (Parameter& p : *list) {
      if (p.name != pname) continue;
      if (p.known) {
        throw std::invalid_argument(fmt::format(
            "parameter '{}' of model '{}' is a known constant of the model structure", pname, spec_.name));
      }
      Parameter bounded = p;
      bounded.lower = lower;
      bounded.upper = upper;
      CheckBounds(bounded, spec_.name);
      p = bounded;
      return;
    }
  }
  SetParameter(pname, 0.0);  // throws: no such parameter, naming the unknown ones
}

void Model::SetParameter(std::string_view assignment) {
  const auto eq = assignment.find('=');
  if (eq == std::string_view::npos || eq == 0) {
    throw std::invalid_argument(
        fmt::format("parameter assignment '{}' is not of the form name=value", assignment));
  }
  const std::string_view pname = assignment.substr(0, eq);
  const std::string_view text = assignment.substr(eq + 1);
  // A leading + is accepted (from_chars takes none): "+5" is 5; "+-5" and "++5" are not numbers.
  const std::string_view digits =
      text.starts_with('+') && text.size() > 1 && text[1] != '-' && text[1] != '+' ? text.substr(1) : text;
  double value = 0.0;
  const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
  if (ec == std::errc::result_out_of_range && end == digits.data() + digits.size()) {
    throw std::invalid_argument(
        fmt::format("parameter '{}': value '{}' is out of range (a finite double: magnitude below 1.8e308, "
                    "not below 2.2e-308 "
                    "unless 0)",
                    pname, text));
  }
  if (ec != std::errc() || end != digits.data() + digits.size() || digits.empty()) {
    throw std::invalid_argument(fmt::format("parameter '{}': value '{}' is not a number", pname, text));
  }
  SetParameter(pname, value);
}

void Model::CentralDifferenceJacobian(const Concept& c, const ConstVecRef& x, const ConstVecRef& alpha,
                                      const Context& ctx, MatRef jac) {
  const Eigen::Index n = x.size();
  Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxStates, 1> xp = x, xm = x, fp(n), fm(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const double h = 1e-6 * std::max(1.0, std::abs(x[i]));
    xp[i] = x[i] + h;
    xm[i] = x[i] - h;
    c.Flow(xp, alpha, ctx, fp);
    c.Flow(xm, alpha, ctx, fm);
    jac.col(i) = (fp - fm) / (2.0 * h);
    xp[i] = x[i];
    xm[i] = x[i];
  }
}

void Model::GuardParameterJacobian(const ConstVecRef& x, const Context& ctx, ParameterBlock block,
                                   MatRef dh) const {
  const Context base = Resolve(ctx);
  const double* Context::*const field = block == ParameterBlock::kAlpha  ? &Context::alpha
                                        : block == ParameterBlock::kBeta ? &Context::beta
                                                                          : &Context::gamma;
  const Eigen::Index m = block == ParameterBlock::kAlpha  ? alpha_.size()
                         : block == ParameterBlock::kBeta ? beta_.size()
                                                           : gamma_.size();
  const double* value = base.*field;
  Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxAlpha, 1> vp = Eigen::Map<const Vec>(value, m);
  Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxAlpha, 1> vm = vp;
  const Eigen::Index g = guard_count();
  Vec hp(g), hm(g);
  Context cp = base, cm = base;
  cp.*field = vp.data();
  cm.*field = vm.data();
  for (Eigen::Index i = 0; i < m; ++i) {
    const double step = 1e-6 * std::max(1.0, std::abs(value[i]));
    vp[i] = value[i] + step;
    vm[i] = value[i] - step;
    impl_->Guards(x, cp, hp);
    impl_->Guards(x, cm, hm);
    dh.col(i) = (hp - hm) / (2.0 * step);
    vp[i] = value[i];
    vm[i] = value[i];
  }
}

Vec DefaultState(const Model& model) {
  const std::vector<double>& x0 = model.spec().default_x0;
  return Eigen::Map<const Vec>(x0.data(), static_cast<Eigen::Index>(x0.size()));
}

std::vector<std::string> UnknownNames(const std::vector<Parameter>& params) {
  std::vector<std::string> names;
  for (const Parameter& p : params) {
    if (!p.known) names.push_back(p.name);
  }
  return names;
}

std::vector<int> MeasuredIndices(const Model& model) {
  if (!model.spec().measured.empty()) return model.spec().measured;
  std::vector<int> all(static_cast<std::size_t>(model.state_size()));
  for (int i = 0; i < model.state_size(); ++i) all[std::size_t(i)] = i;
  return all;
}

}  // namespace hysid
