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
  std::string model = "impact-msd";
  std::vector<std::string> params;
  std::vector<double> x0;
  double t_end = NAN;  // NaN: the model's default
  double dt = NAN;
  std::vector<double> sigma{1.0};
  bool x0_known = false;
  SensitivityOptions options;
};

Vec ParseSigma(const std::vector<double>& values, int n) {
  RequireFinite("--sigma", values);
  Vec sigma(n);
  if (values.size() == 1) {
    sigma.setConstant(values[0]);
  } else if (static_cast<int>(values.size()) == n) {
    sigma = Eigen::Map<const Vec>(values.data(), n);
  } else {
    BadFlag(fmt::format("--sigma has {} values; give one, or one per state ({})", values.size(), n));
  }
  if (!(sigma.array() > 0.0).all()) BadFlag(fmt::format("--sigma = {}: must be > 0", fmt::join(values, ",")));
  return sigma;
}

int RunCrlb(const CrlbArgs& args, const Environment& env) {
  const Model model = MakeModel(env, args.model, args.params);
  const ModelSpec& spec = model.spec();
  const int n = model.state_size();
  const SampleGrid grid{.t_end = std::isnan(args.t_end) ? spec.default_t_end : args.t_end,
                        .dt = std::isnan(args.dt) ? spec.default_dt : args.dt};
  if (std::string e; !grid.IsValid(&e)) BadFlag(fmt::format("--t-end/--dt: {}", e));
  if (std::string e; !args.options.IsValid(&e)) BadFlag(fmt::format("--rtol/--atol: {}", e));
  Vec x0 = Eigen::Map<const Vec>(spec.default_x0.data(), n);
  if (!args.x0.empty()) {
    RequireFinite("--x0", args.x0);
    if (static_cast<int>(args.x0.size()) != n) {
      BadFlag(fmt::format("--x0 has {} values; model '{}' has {} states", args.x0.size(), spec.name, n));
    }
    x0 = Eigen::Map<const Vec>(args.x0.data(), n);
  }
  if (!model.InFlowSet(x0) && !model.InJumpSet(x0)) {
    BadFlag(fmt::format("--x0 = {}: outside C and D of '{}'", fmt::join(x0, ","), spec.name));
  }
  const Vec sigma = ParseSigma(args.sigma, n);
  const Unknowns unknowns = Unknowns::Of(model, !args.x0_known);
  const Crlb c = ComputeCrlb(model, x0, grid, sigma, unknowns, args.options);
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
  CLI::App* sub = app.add_subcommand(
      "crlb",
      "Cramér–Rao lower bound of the unknown alpha, beta and x0 for samples with Gaussian noise\n"
      "sigma: per-parameter sd and the CRLB-implied mean e_alpha, e_beta. Exit 1 when the bound\n"
      "cannot be computed (simulation stopped, singular Fisher information).");
  sub->add_option("--model", args->model, "model name (see `hysid models`)")->capture_default_str();
  sub->add_option("--param", args->params, "set a true parameter, name=value (repeatable)");
  sub->add_option("--x0", args->x0, "initial state, comma-separated (default: the model's)")->delimiter(',');
  sub->add_option("--t-end", args->t_end, "horizon in seconds (default: the model's)");
  sub->add_option("--dt", args->dt, "sample time in seconds (default: the model's)");
  sub->add_option("--sigma", args->sigma, "measurement noise sd: one value, or one per state")
      ->delimiter(',')
      ->capture_default_str();
  sub->add_flag("--x0-known", args->x0_known, "x0 is known (not estimated)");
  sub->add_option("--rtol", args->options.sim.rtol, "CVODES relative tolerance")->capture_default_str();
  sub->add_option("--atol", args->options.sim.atol, "CVODES absolute tolerance")->capture_default_str();
  sub->callback([args, &env] {
    const int code = RunCrlb(*args, env);
    if (code != 0) throw CLI::RuntimeError(code);
  });
}

}  // namespace hysid::cli
