#include "sim/model_check/model_check.hpp"

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/model_file/model_file.hpp"
#include "sim/simulator.hpp"

namespace hysid {
namespace {

// φ at the default initial state: every entry finite (an expression such as -x/0 or sqrt(-1-x*x) is
// named here, not blamed later on a guard the trajectory then never reaches).
void CheckPhiFiniteAtStart(const ModelFile& file, const std::string& name, const Vec& x0) {
  const Model& model = file.model;
  const ModelSpec& s = model.spec();
  Mat phi(model.state_size(), model.alpha_size());
  model.Phi(x0, phi);
  for (Eigen::Index c = 0; c < phi.cols(); ++c) {
    for (Eigen::Index r = 0; r < phi.rows(); ++r) {
      if (std::isfinite(phi(r, c))) continue;
      throw std::invalid_argument(fmt::format(
          "{}: flow: phi[{}][{}] (the row of {}, the column of {}) is {} at the default initial state x0 = "
          "({}): "
          "its expression is not finite there (a division by zero, a root or log of a negative number?)",
          name, r, c, s.state_names[static_cast<std::size_t>(r)], s.alpha[static_cast<std::size_t>(c)].name,
          std::isnan(phi(r, c)) ? "NaN" : fmt::format("{}", phi(r, c)), fmt::join(s.default_x0, ", ")));
    }
  }
}

// Every guard of the file's model reaches D at least once on the default trajectory (kStart: the first
// that does not is put in `note`). A model with inputs is not simulated here (its u(t) comes with each
// run), nor one with candidate terms (its flow or jump map is what the data will choose).
Model CheckGuardsFire(ModelFile file, const std::string& name, ModelValues values, std::string* note) {
  if (note != nullptr) note->clear();
  const Model& model = file.model;
  const ModelSpec& s = model.spec();
  if (!s.inputs.empty() || !s.candidates.empty() || !s.jump_candidates.empty()) return std::move(file.model);
  const Vec x0 = Eigen::Map<const Vec>(s.default_x0.data(), model.state_size());
  CheckPhiFiniteAtStart(file, name, x0);
  const Trajectory traj = Simulate(model, x0, SampleGrid{.t_end = s.default_t_end, .dt = s.default_dt});
  std::vector<long> fired(s.guards.size(), 0);
  for (const JumpRecord& j : traj.jumps) {
    if (j.guard >= 0) ++fired[std::size_t(j.guard)];
  }
  for (std::size_t g = 0; g < fired.size(); ++g) {
    if (fired[g] > 0) continue;
    if (values == ModelValues::kStart) {
      if (note != nullptr) {
        *note = fmt::format("{}: with its start values, guard \"{}\" never reaches D on the default trajectory "
                            "(x0 = ({}), t_end = {}); the fit places the switches from the data",
                            file.guard_where[g], s.guards[g].name, fmt::join(s.default_x0, ", "), s.default_t_end);
      }
      break;
    }
    throw std::invalid_argument(
        fmt::format("{}: guard \"{}\" never reaches D on the default trajectory (x0 = ({}), t_end = {}; "
                    "simulation {}: {})",
                    file.guard_where[g], s.guards[g].name, fmt::join(s.default_x0, ", "), s.default_t_end,
                    ToString(traj.status.stop), traj.status.message));
  }
  return std::move(file.model);
}

}  // namespace

Model LoadModelFile(const std::filesystem::path& path, ModelValues values, std::string* note) {
  return CheckGuardsFire(ReadModelFile(path), path.string(), values, note);
}

Model ParseModelText(std::string_view text, const std::string& name, ModelValues values, std::string* note) {
  return CheckGuardsFire(ParseModelFile(text, name), name, values, note);
}

}  // namespace hysid
