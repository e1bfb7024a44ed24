// libFuzzer harness: the model-file reader (toml++, hysid's checks, muParser). Any input must give a
// model or std::invalid_argument. ParseModelFile does not simulate the default trajectory, so one
// input stays cheap. A model that loads is evaluated (φ, ψ, guards, sets, the jump-set distance, the
// flow Jacobian, the guard projections) at a few states, finite and not: values may be anything, but
// the shapes must be the spec's, the block evaluators (PhiColumns, PhiRowColumns) must agree with
// Phi, and nothing may crash. A model with candidate terms is written as its chosen model with every
// candidate kept (ChosenModelText), which must load with the same α, β, φ, ψ and flow-Jacobian
// declaration and no candidates.
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "core/model/model.hpp"
#include "core/model_file/chosen.hpp"
#include "core/model_file/model_file.hpp"

namespace {

std::vector<hysid::Vec> ProbeStates(const hysid::Model& model) {
  const int n = model.state_size();
  std::vector<hysid::Vec> states;
  const auto& x0 = model.spec().default_x0;
  if (static_cast<int>(x0.size()) == n) states.push_back(Eigen::Map<const hysid::Vec>(x0.data(), n));
  for (double v : {0.0, 1.0, -2.5, 1e300, std::numeric_limits<double>::quiet_NaN(),
                   std::numeric_limits<double>::infinity()}) {
    states.push_back(hysid::Vec::Constant(n, v));
  }
  return states;
}

void Evaluate(const hysid::Model& model) {
  const int n = model.state_size();
  const int a = model.alpha_size();
  const int b = model.beta_size();
  if (n < 1 || model.alpha().size() != a || model.beta().size() != b) __builtin_trap();
  hysid::Mat phi(n, a), psi(n, b), jac(n, n);
  hysid::Vec h(model.guard_count()), f(n), g(n);
  const std::vector<hysid::Vec> states = ProbeStates(model);
  for (const hysid::Vec& x : states) {
    model.Phi(x, phi);
    model.Psi(x, psi);
    model.Guards(x, h);
    (void)model.InFlowSet(x);
    (void)model.InJumpSet(x);
    (void)model.DistanceToJumpSet(x);
    model.Flow(x, model.alpha(), f);
    model.Jump(x, model.beta(), g);
    model.FlowJacobian(x, model.alpha(), jac);
    for (int i = 0; i < model.guard_count(); ++i) {
      hysid::Vec y = x;
      model.ProjectOntoGuard(i, y);
      if (y.size() != n) __builtin_trap();
    }
  }
  // The block evaluator must agree with one state at a time (NaN where either is NaN).
  hysid::Vec block(n * static_cast<Eigen::Index>(states.size()));
  for (std::size_t k = 0; k < states.size(); ++k)
    block.segment(static_cast<Eigen::Index>(k) * n, n) = states[k];
  std::vector<double> columns(static_cast<std::size_t>(n) * a * states.size());
  model.PhiColumns(block.data(), static_cast<Eigen::Index>(states.size()), columns.data());
  for (std::size_t k = 0; k < states.size(); ++k) {
    model.Phi(states[k], phi);
    const Eigen::Map<const hysid::Mat> one(columns.data() + k * n * a, n, a);
    for (Eigen::Index i = 0; i < phi.size(); ++i) {
      const double p = phi.data()[i], q = one.data()[i];
      if (!(p == q || (p != p && q != q))) __builtin_trap();
    }
  }
  // Each row alone (PhiRowColumns, that row's expressions) must give the block evaluator's row.
  std::vector<double> row(columns.size());
  for (int r = 0; r < n; ++r) {
    model.PhiRowColumns(r, block.data(), static_cast<Eigen::Index>(states.size()), row.data());
    for (std::size_t k = 0; k < states.size(); ++k) {
      for (int c = 0; c < a; ++c) {
        const std::size_t at = k * n * a + static_cast<std::size_t>(c * n + r);
        const double p = row[at], q = columns[at];
        if (!(p == q || (p != p && q != q))) __builtin_trap();
      }
    }
  }
}

// Equal entries, NaN where either is NaN.
bool Same(const hysid::Mat& p, const hysid::Mat& q) {
  for (Eigen::Index i = 0; i < p.size(); ++i) {
    const double a = p.data()[i], b = q.data()[i];
    if (!(a == b || (a != a && b != b))) return false;
  }
  return true;
}

// The chosen model with every candidate kept, at the library's values, evaluates as the library.
void RoundTrip(std::string_view text, const hysid::Model& model) {
  const hysid::ModelSpec& spec = model.spec();
  if (spec.candidates.empty() && spec.jump_candidates.empty()) return;
  std::vector<std::string> kept;
  for (const hysid::CandidateTerm& c : spec.candidates) kept.push_back(spec.alpha[std::size_t(c.alpha)].name);
  for (const hysid::JumpCandidateTerm& c : spec.jump_candidates) kept.push_back(spec.beta[std::size_t(c.beta)].name);
  std::optional<hysid::ModelFile> chosen;
  try {
    chosen.emplace(hysid::ParseModelFile(hysid::ChosenModelText(text, "fuzz.toml", kept, {}), "chosen.toml"));
  } catch (const std::invalid_argument&) {
    __builtin_trap();
  }
  const hysid::Model& m = chosen->model;
  if (m.alpha_size() != model.alpha_size() || m.beta_size() != model.beta_size() || !m.spec().candidates.empty() ||
      !m.spec().jump_candidates.empty() || m.spec().flow_jacobian_constant != spec.flow_jacobian_constant) {
    __builtin_trap();
  }
  const int n = model.state_size();
  hysid::Mat phi(n, model.alpha_size()), phi_chosen(n, model.alpha_size());
  hysid::Mat psi(n, model.beta_size()), psi_chosen(n, model.beta_size());
  for (const hysid::Vec& x : ProbeStates(model)) {
    model.Phi(x, phi);
    m.Phi(x, phi_chosen);
    model.Psi(x, psi);
    m.Psi(x, psi_chosen);
    if (!Same(phi, phi_chosen) || !Same(psi, psi_chosen)) __builtin_trap();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const hysid::ModelFile file =
        hysid::ParseModelFile(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.toml");
    if (static_cast<int>(file.guard_where.size()) != file.model.guard_count()) __builtin_trap();
    Evaluate(file.model);
    RoundTrip(std::string_view(reinterpret_cast<const char*>(data), size), file.model);
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
