// hysid crlb: the Cramér–Rao lower bound of a model's unknown α, β (and ξ0) for sampled states with
// Gaussian noise σ, from the hybrid forward sensitivities (sim/sensitivity/crlb.hpp).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "experiments/cli/cli.hpp"
#include "sim/sensitivity/crlb.hpp"

namespace hysid::cli {
namespace {

struct CrlbArgs {
  ModelFlags model;
  std::vector<std::string> bounds;  // --param-bound NAME=LO,HI, repeatable
  TrajectoryFlags trajectory;
  std::vector<double> sigma{1.0};
  X0Known x0_known;
  SensitivityOptions options;
  std::string inputs;  // --inputs FILE (empty: the model file's defaults)
  std::string mode;    // --mode NAME: the initial mode of a model with modes (empty: its default)
  std::string times;   // --times FILE: the bound on the sample times of a data file (empty: every sample)
};


// A hybrid automaton: the CRLB-implied mean error of each jump map's own unknown β entries (its block
// of the covariance; identity maps and maps with every β known have none).
void PrintPerMap(const ModelSpec& spec, const Unknowns& unknowns, const Crlb& c) {
  const std::vector<double> per_map = MeanEBetaPerMap(spec, unknowns, c);
  for (std::size_t m = 0; m < per_map.size(); ++m) {
    if (std::isnan(per_map[m])) continue;
    std::printf("  map %s: CRLB-implied mean e_beta %.6g\n", spec.jumps[m].name.c_str(), per_map[m]);
  }
}

int RunCrlb(const CrlbArgs& args, const Environment& env) {
  Model model = MakeModel(env, args.model);
  ApplyBoundFlags(args.bounds, &model);
  const ModelSpec& spec = model.spec();
  const int n = model.state_size();
  const SampleGrid grid = GridFlag(args.trajectory, model);
  CheckSimOptions(args.options.sim, Spelling::kFlag);
  const InputSignal inputs = InputsFlag(args.inputs, spec, grid);
  std::vector<double> u0(static_cast<std::size_t>(inputs.size()));
  if (!inputs.empty()) inputs.At(0.0, u0.data());
  const Vec x0 =
      InitialStateFlag(args.trajectory, model, {.t = 0.0, .u = inputs.empty() ? nullptr : u0.data()});
  const std::vector<int> measured = MeasuredIndices(model);
  const bool all = static_cast<int>(measured.size()) == n;
  const Vec sigma = CheckedNoiseSigma(args.sigma, static_cast<int>(measured.size()), Spelling::kFlag);
  CheckBoundGrid(grid, Spelling::kFlag);
  const std::vector<std::uint8_t> present = args.times.empty()
                                                ? std::vector<std::uint8_t>{}
                                                : CheckedSampleTimes(args.times, grid, Spelling::kFlag);
  const std::vector<int> known = X0KnownFlag(args.x0_known, model);
  // Every component known: ξ0 is not in θ; some: in θ, held (sd 0, left out of the inverse).
  const Unknowns unknowns = Unknowns::Of(model, static_cast<int>(known.size()) != n);
  const int mode = ModeFlag(args.mode, model);
  HybridParameters at = HybridParameters::Of(model, x0);
  at.initial_mode = mode;
  const Crlb c = HoldKnownX0(
      ComputeCrlb(model, at, grid, sigma, unknowns, args.options, all ? std::vector<int>{} : measured,
                  inputs.empty() ? nullptr : &inputs, present),
      unknowns, known, n);
  std::vector<std::string> measured_names;
  for (const int i : measured) measured_names.push_back(spec.state_names[static_cast<std::size_t>(i)]);
  const std::string samples =
      present.empty() ? fmt::format("{} samples", grid.size())
                      : fmt::format("{} of {} samples: the times of {}",
                                    std::count(present.begin(), present.end(), 1), grid.size(), args.times);
  std::printf("model %s, x0 = (%s)%s, t_end = %g, dt = %g (%s), sigma = (%s), %s%s\n", spec.name.c_str(),
              fmt::format("{:g}", fmt::join(x0, ", ")).c_str(),
              spec.modes.empty() ? "" : fmt::format(" in mode {}", spec.modes[std::size_t(mode)]).c_str(),
              grid.t_end, grid.dt, samples.c_str(), fmt::format("{:g}", fmt::join(sigma, ", ")).c_str(),
              X0KnownText(known, model).c_str(),
              all ? "" : fmt::format(", measured {} only", fmt::join(measured_names, ", ")).c_str());
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
  const std::vector<const Parameter*> params = unknowns.Parameters(model);
  for (std::size_t i = 0; i < c.names.size(); ++i) {
    const auto ii = static_cast<Eigen::Index>(i);
    if (c.sd[ii] == 0.0) {
      std::printf("  %-10s = %-12.6g known\n", c.names[i].c_str(), theta[ii]);
      continue;
    }
    std::string line = fmt::format("  {:<10} = {:<12.6g} sd {:.6g}", c.names[i], theta[ii], c.sd[ii]);
    if (i < params.size() && (std::isfinite(params[i]->lower) || std::isfinite(params[i]->upper))) {
      const double room = std::min(theta[ii] - params[i]->lower, params[i]->upper - theta[ii]);
      line += fmt::format("  bounds [{:g}, {:g}]{}", params[i]->lower, params[i]->upper,
                          room < 3.0 * c.sd[ii] ? ": within 3 sd of a bound (the Gaussian bound overstates its error)"
                                                : "");
    }
    std::printf("%s\n", line.c_str());
  }
  if (const std::string means = CrlbMeanErrors(unknowns, c, 6); !means.empty()) {
    std::printf("CRLB-implied %s\n", means.c_str());
  }
  if (!spec.jumps.empty()) PrintPerMap(spec, unknowns, c);
  std::printf("status: ok\n");
  return 0;
}

}  // namespace

int ModeFlag(const std::string& name, const Model& model) { return ModeIndex(name, model, Spelling::kFlag); }

void AddCrlbCommand(CLI::App& app, Environment& env) {
  auto args = std::make_shared<CrlbArgs>();
  CLI::App* sub =
      app.add_subcommand("crlb", "Cramér–Rao lower bound of a model's unknown alpha, beta, guard parameters and x0");
  AddModelFlags(*sub, args->model, "set a true parameter, name=value (repeatable)");
  AddBoundFlag(*sub, args->bounds);
  AddTrajectoryFlags(*sub, args->trajectory);
  AddSigmaOption(*sub, args->sigma, "measurement noise sd: one value, or one per measured state")
      ->capture_default_str();
  AddX0KnownOption(*sub, args->x0_known,
                   "x0 is known (not estimated): alone or 'all' every component, or the known components by "
                   "state name, comma-separated (e.g. --x0-known v)");
  sub->add_option("--inputs", args->inputs,
                  "a model with inputs: CSV with a column t and one per input name (default: the model "
                  "file's input_defaults at the sample times)");
  sub->add_option(
      "--times", args->times,
      "the bound on the samples a data file holds: a CSV with a column t (e.g. the data given to "
      "identify, with its missing rows and gaps; a row with a missing cell left out); each time a "
      "sample time k*dt of the grid");
  sub->add_option("--mode", args->mode,
                  "a hybrid automaton with modes: the initial mode, by name (default: the model's default "
                  "mode)");
  AddToleranceOptions(*sub, args->options.sim, "states and sensitivities");
  sub->footer(
      "The bound for samples of the measured states (the model's `measured`; all by default) with\n"
      "Gaussian noise sigma: per-parameter sd and the CRLB-implied mean e_alpha, e_beta, e_gamma (of\n"
      "the blocks with unknown entries). Exit 1 when\n"
      "it cannot be computed (simulation stopped, singular Fisher information: the message names\n"
      "the unidentifiable direction).");
  sub->callback([args, &env] {
    const int code = RunCrlb(*args, env);
    if (code != 0) throw CLI::RuntimeError(code);
  });
}

}  // namespace hysid::cli
