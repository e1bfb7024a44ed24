// hysid crlb: the Cramér–Rao lower bound of a model's unknown α, β (and ξ0) for sampled states with
// Gaussian noise σ, from the hybrid forward sensitivities (sim/sensitivity/crlb.hpp).
#include <cmath>
#include <cstdio>
#include <memory>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "experiments/cli/cli.hpp"
#include "sim/sensitivity/crlb.hpp"

namespace hysid::cli {
namespace {

struct CrlbArgs {
  ModelFlags model;
  TrajectoryFlags trajectory;
  std::vector<double> sigma{1.0};
  bool x0_known = false;
  SensitivityOptions options;
  std::string inputs;  // --inputs FILE (empty: the model file's defaults)
};

int RunCrlb(const CrlbArgs& args, const Environment& env) {
  const Model model = MakeModel(env, args.model);
  const ModelSpec& spec = model.spec();
  const int n = model.state_size();
  const SampleGrid grid = GridFlag(args.trajectory, model);
  if (std::string e; !args.options.IsValid(&e)) BadFlag(fmt::format("--rtol/--atol: {}", e));
  const InputSignal inputs = InputsFlag(args.inputs, spec, grid);
  std::vector<double> u0(static_cast<std::size_t>(inputs.size()));
  if (!inputs.empty()) inputs.At(0.0, u0.data());
  const Vec x0 =
      InitialStateFlag(args.trajectory, model, {.t = 0.0, .u = inputs.empty() ? nullptr : u0.data()});
  const Vec sigma = SigmaFlag(args.sigma, n, /*allow_zero=*/false);
  const Unknowns unknowns = Unknowns::Of(model, !args.x0_known);
  const Crlb c =
      ComputeCrlb(model, x0, grid, sigma, unknowns, args.options, inputs.empty() ? nullptr : &inputs);
  std::printf("model %s, x0 = (%s), t_end = %g, dt = %g (%ld samples), sigma = (%s), x0 %s\n",
              spec.name.c_str(), fmt::format("{:g}", fmt::join(x0, ", ")).c_str(), grid.t_end, grid.dt,
              grid.size(), fmt::format("{:g}", fmt::join(sigma, ", ")).c_str(),
              args.x0_known ? "known" : "unknown");
  if (!c.ok()) {
    std::printf("status: %s: %s\n", ToString(c.status), c.message.c_str());
    if (c.message.find("Zeno") != std::string::npos) {
      std::printf("(the bound needs a horizon that ends before the accumulation time: --t-end)\n");
    }
    return 1;
  }
  std::printf("%d jumps; sqrt(CRLB) (jump-time information left out):\n", c.jumps);
  const HybridParameters truth = HybridParameters::Of(model, x0);
  const Vec theta = truth.Theta(unknowns);
  for (std::size_t i = 0; i < c.names.size(); ++i) {
    const auto ii = static_cast<Eigen::Index>(i);
    std::printf("  %-10s = %-12.6g sd %.6g\n", c.names[i].c_str(), theta[ii], c.sd[ii]);
  }
  std::printf("CRLB-implied mean e_alpha %.6g, mean e_beta %.6g\n", c.mean_e_alpha, c.mean_e_beta);
  std::printf("status: ok\n");
  return 0;
}

}  // namespace

void AddCrlbCommand(CLI::App& app, Environment& env) {
  auto args = std::make_shared<CrlbArgs>();
  CLI::App* sub =
      app.add_subcommand("crlb", "Cramér–Rao lower bound of a model's unknown alpha, beta and x0");
  AddModelFlags(*sub, args->model, "set a true parameter, name=value (repeatable)");
  AddTrajectoryFlags(*sub, args->trajectory);
  AddSigmaOption(*sub, args->sigma, "measurement noise sd: one value, or one per state")
      ->capture_default_str();
  sub->add_flag("--x0-known", args->x0_known, "x0 is known (not estimated)");
  sub->add_option("--inputs", args->inputs,
                  "a model with inputs: CSV with a column t and one per input name (default: the model "
                  "file's input_defaults at the sample times)");
  AddToleranceOptions(*sub, args->options.sim, "states and sensitivities");
  sub->footer(
      "The bound for samples with Gaussian noise sigma: per-parameter sd and the CRLB-implied mean\n"
      "e_alpha, e_beta. Exit 1 when it cannot be computed (simulation stopped, singular Fisher "
      "information).");
  sub->callback([args, &env] {
    const int code = RunCrlb(*args, env);
    if (code != 0) throw CLI::RuntimeError(code);
  });
}

}  // namespace hysid::cli
