#include "sim/model_check/model_check.hpp"

#include <stdexcept>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/model_file/model_file.hpp"
#include "sim/simulator.hpp"

namespace hysid {
namespace {

// Every guard of the file's model reaches D at least once on the default trajectory. A model with
// inputs is not simulated here (its u(t) comes with each run).
Model CheckGuardsFire(ModelFile file) {
  const Model& model = file.model;
  const ModelSpec& s = model.spec();
  if (!s.inputs.empty()) return std::move(file.model);
  const Vec x0 = Eigen::Map<const Vec>(s.default_x0.data(), model.state_size());
  const Trajectory traj = Simulate(model, x0, SampleGrid{.t_end = s.default_t_end, .dt = s.default_dt});
  std::vector<long> fired(s.guards.size(), 0);
  for (const JumpRecord& j : traj.jumps) {
    if (j.guard >= 0) ++fired[std::size_t(j.guard)];
  }
  for (std::size_t g = 0; g < fired.size(); ++g) {
    if (fired[g] > 0) continue;
    throw std::invalid_argument(
        fmt::format("{}: guard \"{}\" never reaches D on the default trajectory (x0 = ({}), t_end = {}; "
                    "simulation {}: {})",
                    file.guard_where[g], s.guards[g].name, fmt::join(s.default_x0, ", "), s.default_t_end,
                    ToString(traj.status.stop), traj.status.message));
  }
  return std::move(file.model);
}

}  // namespace

Model LoadModelFile(const std::filesystem::path& path) { return CheckGuardsFire(ReadModelFile(path)); }

Model ParseModelText(std::string_view text, const std::string& name) {
  return CheckGuardsFire(ParseModelFile(text, name));
}

}  // namespace hysid
