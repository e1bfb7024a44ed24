// The hysid command line with one more model, written in C++: a unit mass on a spring (stiffness
// k, damping b) hitting a wall at x = 1 (restitution lambda, impact term mu).
//   my-hysid simulate --model wall-msd-cpp --sigma 1e-4 --out wall.csv
//   my-hysid identify --model wall-msd-cpp --data wall.csv
#include <algorithm>
#include <cmath>
#include <utility>

#include "core/builtin/builtin.hpp"
#include "core/model/model.hpp"
#include "core/model/registry.hpp"
#include "experiments/cli/entry.hpp"

namespace {

using namespace hysid;

struct WallMsd {
  ModelSpec Spec() const {
    return ModelSpec{
        .name = "wall-msd-cpp",
        .description = "mass on a spring hitting a wall at x = 1 (C++)",
        .state_names = {"x", "v"},
        .alpha = {{"alpha_x", 1.0, true, "coefficient of v in x' (known)"},
                  {"k", 4.0, false, "spring stiffness"},
                  {"b", 0.2, false, "damping coefficient"}},
        .beta = {{"beta_x", 1.0, true, "coefficient of x in x+ (known)"},
                 {"lambda", 0.8, false, "restitution coefficient"},
                 {"mu", 0.0, false, "additive impact term"}},
        .flow_rows = {1},
        .jump_rows = {1},
        .guards = {{"wall", Crossing::kRising}},
        .flow_jacobian_constant = true,
        .default_x0 = {0.0, 5.0},
        .default_t_end = 20.0,
        .default_dt = 5e-4,
        .equations =
            "flow: x' = alpha_x*v, v' = -k*x - b*v\n"
            "jump: x+ = beta_x*x, v+ = -lambda*v + mu\n"
            "guard wall: h(xi) = x - 1 (rising)\n"
            "C: x < 1 || (x == 1 && v <= 0)\n"
            "D: x == 1 && v >= 0\n",
    };
  }
  void Phi(ConstVecRef x, MatRef phi) const { phi << x[1], 0.0, 0.0, 0.0, -x[0], -x[1]; }
  void Psi(ConstVecRef x, MatRef psi) const { psi << x[0], 0.0, 0.0, 0.0, -x[1], 1.0; }
  void Guards(ConstVecRef x, VecRef h) const { h[0] = x[0] - 1.0; }
  bool InFlowSet(ConstVecRef x) const { return x[0] < 1.0 || (x[0] == 1.0 && x[1] <= 0.0); }
  bool InJumpSet(ConstVecRef x) const { return x[0] == 1.0 && x[1] >= 0.0; }
  double DistanceToJumpSet(ConstVecRef x) const { return std::hypot(x[0] - 1.0, std::min(x[1], 0.0)); }
  void ProjectOntoGuard(int /*guard*/, VecRef x) const { x[0] = 1.0; }
};

}  // namespace

int main(int argc, char** argv) {
  hysid::ModelRegistry registry;
  hysid::RegisterBuiltinModels(registry);
  registry.Register(WallMsd{});
  return hysid::cli::Main(argc, argv, std::move(registry));
}
