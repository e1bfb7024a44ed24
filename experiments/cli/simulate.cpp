// hysid simulate: one trajectory of a model, its samples (true and measured) and its jumps.
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include "core/io/csv.hpp"
#include "core/io/files.hpp"
#include "core/io/limits.hpp"
#include "core/model/automaton.hpp"
#include "experiments/cli/cli.hpp"
#include "experiments/sweep/run_context.hpp"
#include "sim/input_signal.hpp"
#include "sim/measurement.hpp"
#include "sim/simulator.hpp"

namespace hysid::cli {
namespace {

struct SimulateArgs {
  ModelFlags model;
  TrajectoryFlags trajectory;
  std::vector<double> sigma{0.0};
  std::uint64_t seed = 1;
  std::uint64_t trial = 0;
  SimOptions sim;
  std::string out;
  std::string jumps_out;
  std::string inputs;  // --inputs FILE (empty: the model file's input defaults)
};

std::filesystem::path SidecarPath(const std::filesystem::path& csv) {
  std::filesystem::path p = csv;
  return p.replace_extension(".json");
}

// Renames the closed trajectory and jump files onto their names and writes the sidecar; when one
// step fails, the files of this set already renamed are removed, so no partial set remains.
void PublishSet(CsvWriter& traj, CsvWriter* jumps, const std::filesystem::path& sidecar,
                const std::string& meta) {
  std::vector<std::filesystem::path> done;
  try {
    traj.Publish();
    done.push_back(traj.path());
    if (jumps) {
      jumps->Publish();
      done.push_back(jumps->path());
    }
    WriteFileAtomically(sidecar, meta);
  } catch (...) {
    std::error_code ec;
    for (const auto& p : done) std::filesystem::remove(p, ec);
    throw;
  }
}

// Whether the trajectory file can name its columns after the model's states: t, j, run (identify's
// run column), q (a model with modes), map (a model with jump maps), true_STATE and STATE all
// different names.
bool NamedColumns(const ModelSpec& spec) {
  std::set<std::string> names{"t", "j", "run", "q", "map"};
  for (const char* prefix : {"true_", ""}) {
    for (const std::string& s : spec.state_names) {
      if (!names.insert(prefix + s).second) return false;
    }
  }
  return true;
}

// `prefix` + each state name when `named`, else `prefix` + `generic` + i (i = 1..n).
std::vector<std::string> StateColumns(const ModelSpec& spec, bool named, const std::string& prefix,
                                      const std::string& generic) {
  std::vector<std::string> out;
  for (std::size_t i = 0; i < spec.state_names.size(); ++i)
    out.push_back(named ? prefix + spec.state_names[i] : fmt::format("{}{}{}", prefix, generic, i + 1));
  return out;
}

// t, j, q (the mode's index into the model's modes; only for a model with several), map (a model
// with jump maps: the index of the latest jump's map at or before the sample, −1 before the first;
// identify reads it as the ground truth of its event assignment), the noise-free
// state true_STATE.. and the measured state STATE.. (x1..xn and y1..yn when a state name would clash
// with another column), then the inputs by their names (so that identify reads them as they are).
std::vector<std::string> TrajectoryHeader(const ModelSpec& spec, bool named) {
  std::vector<std::string> header{"t", "j"};
  if (ModeCount(spec) > 1) header.emplace_back("q");
  if (!spec.jumps.empty()) header.emplace_back("map");
  for (const auto& [prefix, generic] : {std::pair{"true_", "x"}, std::pair{"", "y"}}) {
    for (std::string& c : StateColumns(spec, named, named ? prefix : "", generic))
      header.push_back(std::move(c));
  }
  for (const std::string& name : spec.inputs) {
    if (std::find(header.begin(), header.end(), name) != header.end()) {
      BadFlag(fmt::format("--model-file: the input '{}' has the name of a column simulate writes ({})", name,
                          fmt::join(header, ",")));
    }
    header.push_back(name);
  }
  return header;
}

// Writes and closes (not yet publishes) the trajectory file; u(t_k) in the input columns.
void WriteTrajectory(CsvWriter& csv, const Trajectory& traj, const Mat& y, const InputSignal& inputs,
                     bool maps) {
  const auto n = static_cast<int>(traj.x.rows());
  const int m = inputs.size();
  const bool modes = !traj.q.empty();
  const std::size_t at = 2 + (modes ? 1 : 0) + (maps ? 1 : 0);  // the first state column
  std::vector<double> row(at + static_cast<std::size_t>(2 * n + m));
  for (long k = 0; k < traj.size(); ++k) {
    const auto sample = static_cast<std::size_t>(k);
    row[0] = traj.t[sample];
    row[1] = traj.j[sample];
    if (modes) row[2] = traj.q[sample];
    if (maps) {
      const int j = traj.j[sample];
      row[at - 1] = j > 0 ? traj.jumps[static_cast<std::size_t>(j - 1)].map : -1;
    }
    for (int i = 0; i < n; ++i) {
      row[at + static_cast<std::size_t>(i)] = traj.x(i, k);
      row[at + static_cast<std::size_t>(n + i)] = y(i, k);
    }
    if (m > 0) inputs.At(row[0], &row[at + static_cast<std::size_t>(2 * n)]);
    csv.Row(row);
  }
  csv.Close();
}

// j, t_jump, (a model with explicit jump maps: map, the map's name, and q, the mode after the jump),
// the state before the jump pre_STATE.. and after it post_STATE.. (pre_x1.. with generic names).
std::vector<std::string> JumpsHeader(const ModelSpec& spec, bool named) {
  std::vector<std::string> header{"j", "t_jump"};
  if (IsAutomaton(spec)) {
    header.emplace_back("map");
    header.emplace_back("q");
  }
  for (const char* prefix : {"pre_", "post_"}) {
    for (std::string& c : StateColumns(spec, named, prefix, "x")) header.push_back(std::move(c));
  }
  return header;
}

// Writes and closes (not yet publishes) the jumps file.
void WriteJumps(CsvWriter& jumps, const Trajectory& traj, const ModelSpec& spec) {
  const auto n = static_cast<int>(traj.x.rows());
  if (IsAutomaton(spec)) {  // a text column: every cell as text, numbers in full precision
    std::vector<std::string> cells;
    for (const JumpRecord& jr : traj.jumps) {
      cells = {fmt::format("{}", jr.j), fmt::format("{:.17g}", jr.t), spec.jumps[std::size_t(jr.map)].name,
               fmt::format("{}", jr.mode)};
      for (const Vec* v : {&jr.pre, &jr.post}) {
        for (int i = 0; i < n; ++i) cells.push_back(fmt::format("{:.17g}", (*v)[i]));
      }
      jumps.TextRow(cells);
    }
    jumps.Close();
    return;
  }
  std::vector<double> jrow(static_cast<std::size_t>(2 + 2 * n));
  for (const JumpRecord& jr : traj.jumps) {
    jrow[0] = jr.j;
    jrow[1] = jr.t;
    for (int i = 0; i < n; ++i) {
      jrow[static_cast<std::size_t>(2 + i)] = jr.pre[i];
      jrow[static_cast<std::size_t>(2 + n + i)] = jr.post[i];
    }
    jumps.Row(jrow);
  }
  jumps.Close();
}

// FILE.json beside the trajectory: the run's inputs, the solver's tolerances and outcome.
std::string SidecarText(const SimulateArgs& args, const Model& model, const Vec& x0, const SampleGrid& grid,
                        const Vec& sigma, const Trajectory& traj, const std::vector<std::string>& columns) {
  const ModelSpec& spec = model.spec();
  nlohmann::json inputs = nlohmann::json::object();
  for (std::size_t i = 0; i < spec.inputs.size(); ++i) {
    const std::vector<std::string>& defaults = spec.input_defaults;
    inputs[spec.inputs[i]] = !args.inputs.empty()  ? "file " + args.inputs
                             : i < defaults.size() ? defaults[i]
                                                   : std::string();
  }
  nlohmann::json params;
  for (std::size_t i = 0; i < spec.alpha.size(); ++i)
    params[spec.alpha[i].name] = model.alpha()[Eigen::Index(i)];
  for (std::size_t i = 0; i < spec.beta.size(); ++i)
    params[spec.beta[i].name] = model.beta()[Eigen::Index(i)];
  for (std::size_t i = 0; i < spec.guard_params.size(); ++i)
    params[spec.guard_params[i].name] = model.gamma()[Eigen::Index(i)];
  nlohmann::json meta = {
      {"command", "simulate"},
      {"model", spec.name},
      {"parameters", params},
      {"x0", std::vector<double>(x0.begin(), x0.end())},
      {"t_end", grid.t_end},
      {"dt", grid.dt},
      {"sigma", std::vector<double>(sigma.begin(), sigma.end())},
      {"seed", args.seed},
      {"trial", args.trial},
      {"solver",
       {{"rtol", args.sim.rtol},
        {"atol", args.sim.atol},
        {"max_jumps", args.sim.max_jumps},
        {"steps", traj.stats.steps},
        {"rhs_evals", traj.stats.rhs_evals}}},
      {"status", ToString(traj.status.stop)},
      {"t_reached", traj.status.t_reached},
      {"message", traj.status.message},
      {"samples", traj.size()},
      {"jumps", traj.jumps.size()},
      {"outputs", {{"trajectory", args.out}, {"jumps", args.jumps_out}}},
      {"columns", columns},
      {"inputs", inputs},
      {"context", BuildContext()},
  };
  if (traj.status.stop == SimStop::kZeno) meta["zeno_time"] = traj.status.zeno_time;
  if (IsAutomaton(spec)) {  // the column q indexes modes; jump_maps names each jump's map, in order
    std::vector<std::string> maps;
    for (const JumpMap& m : spec.jumps) maps.push_back(m.name);
    std::vector<std::string> applied;
    for (const JumpRecord& jr : traj.jumps) applied.push_back(maps[std::size_t(jr.map)]);
    if (ModeCount(spec) > 1) meta["modes"] = spec.modes;
    meta["maps"] = maps;
    meta["jump_maps"] = applied;
  }
  return meta.dump(2) + "\n";
}

void RunSimulate(const SimulateArgs& args, const Environment& env) {
  const Model model = MakeModel(env, args.model);
  const ModelSpec& spec = model.spec();
  const SampleGrid grid = GridFlag(args.trajectory, model);
  const Vec sigma = CheckedSigma(args.sigma, model.state_size(), /*allow_zero=*/true, Spelling::kFlag,
                                 MeasuredIndices(model));
  CheckSimOptions(args.sim, Spelling::kFlag);
  // Outputs checked before the run; written as one set below.
  // The trajectory, its sidecar and the jumps file are three files, none of them the model file.
  std::vector<std::pair<std::string, std::filesystem::path>> outputs{
      {"--out", args.out}, {"--out (sidecar)", SidecarPath(args.out)}};
  if (!args.jumps_out.empty()) outputs.emplace_back("--jumps-out", args.jumps_out);
  InputFiles files;
  files.Add("--model-file", args.model.file);
  files.Add("--inputs", args.inputs);
  const bool named = NamedColumns(spec);
  const std::vector<std::string> header = TrajectoryHeader(spec, named);
  const InputSignal inputs = InputsFlag(args.inputs, spec, grid);
  Exogenous exo;
  if (!inputs.empty()) exo.inputs = &inputs;
  std::vector<double> u0(static_cast<std::size_t>(inputs.size()));
  if (!inputs.empty()) inputs.At(0.0, u0.data());
  const Vec x0 =
      InitialStateFlag(args.trajectory, model, {.t = 0.0, .u = inputs.empty() ? nullptr : u0.data()});
  CheckOutputPaths(outputs, files);  // last: it creates a missing output directory

  const Trajectory traj = Simulate(model, x0, grid, args.sim, exo);
  const NoiseKey key{.seed = args.seed, .stream = args.trial};
  CsvWriter csv(args.out, header);
  WriteTrajectory(csv, traj, AddMeasurementNoise(traj.x, sigma, key), inputs, !spec.jumps.empty());
  std::optional<CsvWriter> jumps;
  if (!args.jumps_out.empty()) {
    jumps.emplace(args.jumps_out, JumpsHeader(spec, named));
    WriteJumps(*jumps, traj, spec);
  }
  const std::filesystem::path meta_path = SidecarPath(args.out);
  PublishSet(csv, jumps ? &*jumps : nullptr, meta_path,
             SidecarText(args, model, x0, grid, sigma, traj, header));
  std::printf("model %s, seed %llu, %ld samples, %zu jumps\n", spec.name.c_str(),
              static_cast<unsigned long long>(args.seed), traj.size(), traj.jumps.size());
  std::printf("status: %s (t = %.17g): %s\n", ToString(traj.status.stop), traj.status.t_reached,
              traj.status.message.c_str());
  if (!named) {
    std::printf(
        "columns: x1..x%d (true state), y1..y%d (measured): a state name clashes with t, j, run or "
        "another column\n",
        model.state_size(), model.state_size());
  }
  std::printf("wrote %s, %s%s%s\n", args.out.c_str(), meta_path.c_str(), args.jumps_out.empty() ? "" : ", ",
              args.jumps_out.c_str());
  // A zeno stop is a finding about the model (the trajectory is valid up to it); others are failures.
  if (traj.status.stop != SimStop::kCompleted && traj.status.stop != SimStop::kZeno) {
    throw RunFailed(fmt::format("simulate: the run stopped with status {}: {}", ToString(traj.status.stop),
                                traj.status.message));
  }
}

}  // namespace

void AddSimulateCommand(CLI::App& app, Environment& env) {
  auto args = std::make_shared<SimulateArgs>();
  CLI::App* sub = app.add_subcommand("simulate", "simulate one trajectory of a model, measured with noise");
  AddModelFlags(*sub, args->model, "set a parameter, name=value (repeatable)");
  AddTrajectoryFlags(*sub, args->trajectory);
  AddSigmaOption(*sub, args->sigma,
                 "measurement noise standard deviation: one value, one per state, or one per measured "
                 "state (the model's `measured`; the others noise-free)")
      ->capture_default_str();
  sub->add_option("--seed", args->seed, "noise seed (0 to 2^64-1)")
      ->capture_default_str()
      ->transform(NonNegativeInteger);
  sub->add_option("--trial", args->trial, "trial index (selects an independent noise stream)")
      ->capture_default_str()
      ->transform(NonNegativeInteger);
  AddToleranceOptions(*sub, args->sim, "");
  sub->add_option("--max-jumps", args->sim.max_jumps, "jump budget (1 to 2147483647)")
      ->capture_default_str()
      ->check(CLI::Validator(
          [](std::string& text) {
            char* end = nullptr;
            errno = 0;
            const long long v = std::strtoll(text.c_str(), &end, 10);
            const bool integer = end != text.c_str() && *end == '\0';
            if (integer && errno == 0 && v >= std::numeric_limits<int>::min() &&
                v <= std::numeric_limits<int>::max())
              return std::string();  // below 1: CheckSimOptions says so
            return fmt::format("{}: {} (an integer from 1 to {})", Abbreviated(text, 40),
                               integer ? "out of range" : "not an integer", std::numeric_limits<int>::max());
          },
          "1..2147483647"));
  sub->add_option(
         "--out", args->out,
         "trajectory CSV: t,j,true_STATE..,STATE.. (noise-free and measured state, columns named after "
         "the model's states; a model with modes adds q, the mode's index, after j; + a .json sidecar)")
      ->required();
  sub->add_option("--jumps-out", args->jumps_out,
                  "jumps CSV: j,t_jump,pre_STATE..,post_STATE.. (a model with jump maps: j,t_jump,map,q,.. with "
                  "the map's name and the mode after the jump)");
  sub->add_option("--inputs", args->inputs,
                  "a model with inputs: CSV with a column t and one per input name (linear between rows; "
                  "default: the model file's input_defaults at the sample times)");
  sub->footer(
      "Samples t_k = k*dt with jump counter, true and measured state, and the inputs u(t_k) of a model\n"
      "with inputs (columns named as the inputs). Defaults are the model's (impact-msd: the paper's\n"
      "Sec. 5 values).");
  sub->callback([args, &env] { RunSimulate(*args, env); });
}

namespace {

// What a parameter belongs to: flow, jump (the jump map's name with several maps) or guard.
std::string ParameterKind(const ModelSpec& s, const std::vector<Parameter>* list, std::size_t i) {
  if (list == &s.alpha) return "flow";
  if (list != &s.beta) return "guard";
  for (const JumpMap& map : s.jumps) {
    if (int(i) >= map.beta_first && int(i) < map.beta_first + map.beta_count) return "jump " + map.name;
  }
  return "jump";
}

}  // namespace

void PrintModel(const Model& m, bool full) {
  const ModelSpec& s = m.spec();
  std::printf("%s: %s\n  states: %s\n", s.name.c_str(), s.description.c_str(),
              fmt::format("{}", fmt::join(s.state_names, ", ")).c_str());
  if (!s.modes.empty()) {
    std::printf("  modes: %s (default %s)\n", fmt::format("{}", fmt::join(s.modes, ", ")).c_str(),
                s.modes[std::size_t(s.default_mode)].c_str());
  }
  int width = 6;  // the kind column: flow, jump, guard, or "jump NAME"
  for (const JumpMap& map : s.jumps) width = std::max(width, 5 + static_cast<int>(map.name.size()));
  for (const auto* list : {&s.alpha, &s.beta, &s.guard_params}) {
    for (std::size_t i = 0; i < list->size(); ++i) {
      const Parameter& p = (*list)[i];
      const bool bounded = std::isfinite(p.lower) || std::isfinite(p.upper);
      std::printf("  %-12s %-*s = %-8g %s%s\n", p.name.c_str(), width, ParameterKind(s, list, i).c_str(), p.value,
                  p.known ? "(known constant)" : p.description.c_str(),
                  bounded ? fmt::format(" (bounds [{}, {}])", p.lower, p.upper).c_str() : "");
    }
  }
  if (!s.measured.empty()) {
    std::vector<std::string> measured;
    for (int i : s.measured) measured.push_back(s.state_names[std::size_t(i)]);
    std::printf("  measured: %s\n", fmt::format("{}", fmt::join(measured, ", ")).c_str());
  }
  for (std::size_t i = 0; i < s.inputs.size(); ++i) {
    const bool given = i < s.input_defaults.size() && !s.input_defaults[i].empty();
    std::printf("  input %s%s\n", s.inputs[i].c_str(),
                given ? fmt::format(" (default {})", s.input_defaults[i]).c_str() : "");
  }
  std::printf("  defaults: x0 = (%s), t_end = %g, dt = %g\n",
              fmt::format("{}", fmt::join(s.default_x0, ", ")).c_str(), s.default_t_end, s.default_dt);
  if (!full) return;
  auto names = [&](const std::vector<int>& rows) {
    std::vector<std::string> out;
    for (int r : rows) out.push_back(s.state_names[std::size_t(r)]);
    return fmt::format("{}", fmt::join(out, ", "));
  };
  std::printf("  identified rows: flow %s; jump %s\n", names(s.flow_rows).c_str(),
              names(s.jump_rows).c_str());
  std::printf("  flow Jacobian: %s; distance to D: %s\n",
              s.flow_jacobian_constant ? "constant" : "depends on the state",
              m.has_jump_set_distance() ? "given" : "not given (set metrics are NaN)");
  std::istringstream lines(s.equations);
  for (std::string line; std::getline(lines, line);) std::printf("  %s\n", line.c_str());
}

void AddModelsCommand(CLI::App& app, Environment& env) {
  CLI::App* sub = app.add_subcommand("models", "list the built-in models and their parameters");
  auto show = std::make_shared<std::string>();
  sub->add_option("--show", *show,
                  "one model's equations, sets and parameters: a registered name or a model file");
  sub->callback([&env, show] {
    if (show->empty()) {
      for (const std::string& name : env.models.names()) PrintModel(env.models.Make(name), false);
      return;
    }
    if (env.models.Contains(*show)) return PrintModel(env.models.Make(*show), true);
    if (!std::filesystem::exists(*show)) {
      BadFlag("--show: " + NeitherModelNorFile(*show, env.models.names()));
    }
    PrintModel(MakeModel(env, "", *show, {}), true);
  });
}

}  // namespace hysid::cli
