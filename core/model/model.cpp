#include "core/model/model.hpp"

#include <charconv>
#include <cmath>
#include <set>
#include <stdexcept>

#include <fmt/format.h>

namespace hysid {
namespace {

void Require(bool ok, const std::string& model, const std::string& what) {
  if (!ok) throw std::invalid_argument(fmt::format("model '{}': {}", model, what));
}

}  // namespace

void Model::Init() {
  spec_ = impl_->Spec();
  const std::string& name = spec_.name;
  const int n = state_size();
  Require(!name.empty(), "?", "ModelSpec::name is empty");
  Require(n >= 1 && n <= kMaxStates, name, fmt::format("state size {} outside [1, {}]", n, kMaxStates));
  Require(!spec_.alpha.empty() && static_cast<int>(spec_.alpha.size()) <= kMaxParameters, name,
          "alpha must have between 1 and 32 entries");
  Require(!spec_.beta.empty() && static_cast<int>(spec_.beta.size()) <= kMaxParameters, name,
          "beta must have between 1 and 32 entries");
  std::set<std::string> names;
  for (const auto* list : {&spec_.alpha, &spec_.beta}) {
    for (const Parameter& p : *list) {
      Require(!p.name.empty(), name, "a parameter has an empty name");
      Require(names.insert(p.name).second, name, fmt::format("parameter '{}' twice", p.name));
      Require(std::isfinite(p.value), name, fmt::format("parameter '{}' is not finite", p.name));
    }
  }
  for (const auto* rows : {&spec_.flow_rows, &spec_.jump_rows}) {
    Require(!rows->empty(), name, "flow_rows and jump_rows must not be empty");
    for (int r : *rows) Require(r >= 0 && r < n, name, fmt::format("row {} outside [0, {})", r, n));
  }
  Require(!spec_.guards.empty(), name, "a hybrid model needs at least one guard");
  Require(static_cast<int>(spec_.default_x0.size()) == n, name, "default_x0 must have one entry per state");
  alpha_.resize(static_cast<Eigen::Index>(spec_.alpha.size()));
  for (std::size_t i = 0; i < spec_.alpha.size(); ++i) alpha_[Eigen::Index(i)] = spec_.alpha[i].value;
  beta_.resize(static_cast<Eigen::Index>(spec_.beta.size()));
  for (std::size_t i = 0; i < spec_.beta.size(); ++i) beta_[Eigen::Index(i)] = spec_.beta[i].value;
}

void Model::SetParameter(std::string_view pname, double value) {
  for (auto [list, vec] : {std::pair{&spec_.alpha, &alpha_}, std::pair{&spec_.beta, &beta_}}) {
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
      p.value = value;
      (*vec)[Eigen::Index(i)] = value;
      return;
    }
  }
  std::string known;
  for (const auto* list : {&spec_.alpha, &spec_.beta}) {
    for (const Parameter& p : *list) {
      if (!p.known) known += (known.empty() ? "" : ", ") + p.name;
    }
  }
  throw std::invalid_argument(
      fmt::format("model '{}' has no parameter '{}' (parameters: {})", spec_.name, pname, known));
}

void Model::SetParameter(std::string_view assignment) {
  const auto eq = assignment.find('=');
  if (eq == std::string_view::npos || eq == 0) {
    throw std::invalid_argument(
        fmt::format("parameter assignment '{}' is not of the form name=value", assignment));
  }
  const std::string_view pname = assignment.substr(0, eq);
  const std::string_view text = assignment.substr(eq + 1);
  double value = 0.0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc() || end != text.data() + text.size() || text.empty()) {
    throw std::invalid_argument(fmt::format("parameter '{}': value '{}' is not a number", pname, text));
  }
  SetParameter(pname, value);
}

void Model::CentralDifferenceJacobian(const Concept& c, const ConstVecRef& x, const ConstVecRef& alpha,
                                      MatRef jac) {
  const Eigen::Index n = x.size();
  Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxStates, 1> xp = x, xm = x, fp(n), fm(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const double h = 1e-6 * std::max(1.0, std::abs(x[i]));
    xp[i] = x[i] + h;
    xm[i] = x[i] - h;
    c.Flow(xp, alpha, fp);
    c.Flow(xm, alpha, fm);
    jac.col(i) = (fp - fm) / (2.0 * h);
    xp[i] = x[i];
    xm[i] = x[i];
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

}  // namespace hysid
