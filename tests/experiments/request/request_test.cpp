// The identification request/result layer (experiments/request): a request built in C++ gives the
// command line's estimates and --json report for the same data, its estimates lie near the simulated
// truth, and a refusal names the option as the front-end spells it (a flag or a Python keyword); the
// settings table (settings.hpp) is what the command line registers and what the request defaults to.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include <catch2/catch.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "core/builtin/builtin.hpp"
#include "core/model/registry.hpp"
#include "experiments/cli/cli.hpp"
#include "experiments/cli/entry.hpp"
#include "experiments/request/outcome_json.hpp"
#include "experiments/request/request.hpp"
#include "experiments/request/settings.hpp"
#include "tests/testing/temp_dir.hpp"

namespace fs = std::filesystem;
using namespace hysid;

namespace {

ModelRegistry Builtins() {
  ModelRegistry r;
  RegisterBuiltinModels(r);
  return r;
}

int RunCli(std::vector<std::string> args) {
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  return cli::Main(static_cast<int>(argv.size()), argv.data(), Builtins());
}

// The message of the std::invalid_argument that f throws ("" when none).
template <class F>
std::string Refusal(F&& f) {
  try {
    f();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

IdentifyRequest ImpactRequest(Spelling spelling) {
  IdentifyRequest r(Builtins().Make("impact-msd"));
  r.spelling = spelling;
  return r;
}

}  // namespace

TEST_CASE("request: a request built in C++ gives the command line's estimates and report", "[request]") {
  const fs::path dir = testing::FreshTempDir("request");
  const std::string data = (dir / "d.csv").string(), json = (dir / "cli.json").string();
  REQUIRE(RunCli({"hysid", "simulate", "--model", "impact-msd", "--sigma", "1e-3", "--seed", "1", "--out", data}) == 0);
  fs::remove(dir / "d.json");  // no sidecar: neither reads a data accuracy or a truth from it
  REQUIRE(RunCli({"hysid", "identify", "--model", "impact-msd", "--data", data, "--json", json, "--progress",
                  "none"}) == 0);
  std::ifstream in(json);
  const nlohmann::json cli = nlohmann::json::parse(in);

  IdentifyRequest request = ImpactRequest(Spelling::kFlag);
  request.data = ReadSampleFiles({data}, request.model, {}, 0.0, Spelling::kFlag);
  const IdentifyOutcome outcome = RunIdentification(request);
  REQUIRE(outcome.ok());
  const nlohmann::json report = OutcomeJson(outcome);
  CHECK(report == cli);  // every key and every number, bit for bit

  // The fit against the simulation's truth (a = 5, b = 0.1, lambda = 0.99, mu = 0 for impact-msd):
  // within 6 of its own standard errors.
  const std::vector<std::string> names = report["names"];
  const std::vector<double> estimate = report["estimate"], se = report["standard_errors"];
  const std::vector<std::pair<std::string, double>> truth{{"a", 5.0}, {"b", 0.1}, {"lambda", 0.99}, {"mu", 0.0}};
  for (const auto& [name, value] : truth) {
    const auto i = static_cast<std::size_t>(std::find(names.begin(), names.end(), name) - names.begin());
    REQUIRE(i < names.size());
    CHECK(se[i] > 0.0);
    CHECK(std::abs(estimate[i] - value) < 6.0 * se[i]);
  }
}

TEST_CASE("request: a refusal names the option as the front-end spells it", "[request]") {
  for (const Spelling spelling : {Spelling::kFlag, Spelling::kKeyword}) {
    const bool flag = spelling == Spelling::kFlag;
    IdentifyRequest r = ImpactRequest(spelling);
    r.plugin_options = {{"r", "2"}};
    CHECK(Refusal([&] { CheckRequest(r); }) ==
          (flag ? "--r: the detector 'residual' does not read it (its options: --false-alarm)"
                : "r: the detector 'residual' does not read it (its options: false_alarm)"));
    r = ImpactRequest(spelling);
    r.plugin_options = {{"jump_forgetting", "2"}};
    CHECK(Refusal([&] { CheckRequest(r); }).starts_with(flag ? "--jump-forgetting: " : "jump_forgetting: "));
    r = ImpactRequest(spelling);
    r.sigma = {-1.0};
    CHECK(Refusal([&] { CheckRequest(r); }) == (flag ? "--sigma = -1: must be > 0" : "sigma = -1: must be > 0"));
    r = ImpactRequest(spelling);
    r.data_rtol = -1.0;
    CHECK(Refusal([&] { CheckRequest(r); }) ==
          (flag ? "--data-rtol = -1: must be finite and >= 0" : "data_rtol = -1: must be finite and >= 0"));
    r = ImpactRequest(spelling);
    r.estimator = "gtls";
    r.flow_noise_shape = Mat::Identity(2, 2);  // impact-msd's flow rows need (2 + 1)^2
    CHECK(Refusal([&] { CheckRequest(r); })
              .starts_with(flag ? "--estimator/--detector/--*-noise-shape: " : "estimator/detector/*_noise_shape: "));
    CHECK(Refusal([&] { NoiseShapeOf({1.0, 2.0}, "flow_noise_shape", spelling); }) ==
          (flag ? "--flow-noise-shape has 2 values: give a square matrix (parameters + 1)^2, row-major"
                : "flow_noise_shape has 2 values: give a square matrix (parameters + 1)^2, row-major"));
    r = ImpactRequest(spelling);
    r.x0 = {1.0, 0.0};  // without x0_known
    CHECK(Refusal([&] { CheckRequestData(r); }) ==
          (flag ? "--x0: the known initial state's values; give --x0-known too"
                : "x0: the known initial state's values; give x0_known too"));
    r.x0_known = "v,v";
    CHECK(Refusal([&] { CheckRequestData(r); }) ==
          (flag ? "--x0-known = v,v: 'v' named twice" : "x0_known = v,v: 'v' named twice"));
    CHECK(Refusal([&] { ApplyBounds({"k=1"}, spelling, &r.model); }) ==
          (flag ? "--param-bound k=1: must be NAME=LO,HI" : "param_bound k=1: must be NAME=LO,HI"));
  }
}

TEST_CASE("request: max_gap is one check, named as each front-end spells it", "[request]") {
  CHECK(Refusal([] { CheckMaxGap(0.0, "0", Spelling::kFlag); }) == "--max-gap = 0: must be a number > 0 (seconds)");
  CHECK(Refusal([] { CheckMaxGap(-1.5, "-1.5", Spelling::kKeyword); }) ==
        "max_gap = -1.5: must be a number > 0 (seconds)");
  CHECK(Refusal([] { CheckMaxGap(std::nan(""), "abc", Spelling::kFlag); }) ==
        "--max-gap = abc: must be a number > 0 (seconds)");
  CHECK(Refusal([] { CheckMaxGap(HUGE_VAL, "inf", Spelling::kKeyword); }) ==
        "max_gap = inf: must be a number > 0 (seconds)");
  CHECK(Refusal([] { CheckMaxGap(0.25, "0.25", Spelling::kFlag); }).empty());
}

TEST_CASE("request: a setting's help names other settings as the front-end spells them", "[request]") {
  for (const IdentifySetting& s : IdentifySettings()) {
    for (const Spelling spelling : {Spelling::kFlag, Spelling::kKeyword}) {
      INFO(s.name);
      CHECK(SettingHelp(s, spelling).find("${") == std::string::npos);
      CHECK(SettingHelp(s, spelling).find(s.help.substr(0, s.help.find("${"))) != std::string::npos);
    }
  }
  CHECK(SettingHelp(FindIdentifySetting("x0"), Spelling::kFlag).starts_with("with --x0-known: the initial state"));
  CHECK(SettingHelp(FindIdentifySetting("x0"), Spelling::kKeyword).starts_with("with x0_known: the initial state"));
  CHECK(SettingHelp(FindIdentifySetting("max_gap"), Spelling::kKeyword).ends_with("; None: 5 x the median step"));
}

TEST_CASE("request: the defaults the settings table shows are the request's", "[request]") {
  const IdentifyRequest r = ImpactRequest(Spelling::kKeyword);
  const auto text = [](const std::string& v) { return std::pair{v, "'" + v + "'"}; };
  const auto number = [](double v) { return std::pair{fmt::format("{}", v), fmt::format("{:.1f}", v)}; };
  const auto off = [](bool v) { return std::pair{std::string(), std::string(v ? "True" : "False")}; };
  const auto none = [](bool empty) { return std::pair{std::string(), std::string(empty ? "None" : "?")}; };
  // Each setting's (flag default, keyword default) from the request's own defaults.
  const std::map<std::string, std::pair<std::string, std::string>> expected{
      {"estimator", text(r.estimator)},
      {"detector", text(r.detector)},
      {"refine", text(r.refine)},
      {"data_rtol", number(r.data_rtol)},
      {"data_atol", number(r.data_atol)},
      {"localize", off(r.localize)},
      {"second_pass", off(r.second_pass)},
      {"keep_outliers", off(r.keep_outliers)},
      {"sigma", none(r.sigma.empty())},
      {"max_gap", none(true)},  // ReadSampleFiles' 0: 5 x the median step
      {"flow_noise_shape", none(r.flow_noise_shape.size() == 0)},
      {"jump_noise_shape", none(r.jump_noise_shape.size() == 0)},
      {"x0_known", none(!r.x0_known)},
      {"x0", none(r.x0.empty())},
      {"param_bound", none(true)},  // the model file's bounds
  };
  REQUIRE(expected.size() == IdentifySettings().size());
  for (const IdentifySetting& s : IdentifySettings()) {
    INFO(s.name);
    REQUIRE(expected.contains(s.name));
    CHECK(s.flag.default_text == expected.at(s.name).first);
    CHECK(s.keyword.default_text == expected.at(s.name).second);
  }
}

TEST_CASE("request: hysid identify registers every setting from the table", "[request]") {
  CLI::App app;
  cli::Environment env;
  cli::AddIdentifyCommand(app, env);
  const CLI::App* identify = app.get_subcommand("identify");
  std::map<std::string, const CLI::Option*> registered;
  for (const CLI::Option* o : identify->get_options()) {
    for (const std::string& name : o->get_lnames()) registered["--" + name] = o;
  }
  for (const IdentifySetting& s : IdentifySettings()) {
    const std::string flag = Spelled(s.name, Spelling::kFlag);
    INFO(flag);
    REQUIRE(registered.contains(flag));
    CHECK(registered.at(flag)->get_description() == SettingHelp(s, Spelling::kFlag));
    CHECK(registered.at(flag)->get_default_str() == s.flag.default_text);
  }
}

namespace {

// A forced impact oscillator: x' = v, v' = −k x − b v + G u, v⁺ = −λ v at x = 0.5, u measured.
const char* kDriven = R"toml(name = "driven-wall"
states = ["x", "v"]
inputs = ["u"]
input_defaults = { u = "1.5*sin(1.9*t) + 0.8*sin(3.1*t + 1)" }
alpha = [
  { name = "one", value = 1.0, known = true },
  { name = "k", value = 5.0, bounds = [0.0, 100.0] },
  { name = "b", value = 0.1, bounds = [0.0, 10.0] },
  { name = "G", value = 2.0, bounds = [0.0, 50.0] },
]
beta = [ { name = "one_x", value = 1.0, known = true }, { name = "lam", value = 0.8, bounds = [0.0, 1.0] } ]
[flow]
phi = [["v", 0, 0, 0], [0, "-x", "-v", "u"]]
rows = ["v"]
[jump]
psi = [["x", 0], [0, "-v"]]
rows = ["v"]
[[guard]]
h = "x - 0.5"
direction = "rising"
project = { x = "0.5" }
[sets]
C = "x < 0.5 || (x == 0.5 && v <= 0)"
D = "x == 0.5 && v >= 0"
[defaults]
x0 = [0.1, 3.0]
t_end = 10.0
dt = 0.02
)toml";

}  // namespace

TEST_CASE("request: a driven model is not run through a gap whose input the data do not hold", "[request]") {
  const fs::path dir = testing::FreshTempDir("request-driven-gap");
  const std::string model = (dir / "driven.toml").string(), sim = (dir / "sim.csv").string(),
                    data = (dir / "data.csv").string(), json = (dir / "fit.json").string();
  std::ofstream(model) << kDriven;
  REQUIRE(RunCli({"hysid", "simulate", "--model-file", model, "--sigma", "5e-3", "--seed", "33", "--out", sim}) == 0);
  // The rows in [4, 5) removed, u with them: the input in the gap is unknown.
  std::ifstream in(sim);
  std::ofstream out(data);
  std::string line;
  std::getline(in, line);  // t,j,true_x,true_v,x,v,u
  out << "t,x,v,u\n";
  while (std::getline(in, line)) {
    std::vector<std::string> cell;
    for (std::size_t at = 0, next; at <= line.size(); at = next + 1) {
      next = std::min(line.find(',', at), line.size());
      cell.push_back(line.substr(at, next - at));
    }
    const double t = std::stod(cell[0]);
    if (t < 4.0 || t >= 5.0) out << cell[0] << ',' << cell[4] << ',' << cell[5] << ',' << cell[6] << '\n';
  }
  out.close();
  RunCli({"hysid", "identify", "--model-file", model, "--data", data, "--json", json, "--progress", "none"});
  std::ifstream report_in(json);
  const nlohmann::json report = nlohmann::json::parse(report_in);
  CHECK(report["gaps_joined"] == 0);
  CHECK(report["status"] == "ok");
  const std::vector<std::string> names = report["names"];
  const std::vector<double> estimate = report["estimate"], se = report["standard_errors"];
  const std::vector<std::pair<std::string, double>> truth{{"k", 5.0}, {"b", 0.1}, {"G", 2.0}, {"lam", 0.8}};
  for (const auto& [name, value] : truth) {
    const auto i = static_cast<std::size_t>(std::find(names.begin(), names.end(), name) - names.begin());
    REQUIRE(i < names.size());
    CHECK(std::abs(estimate[i] - value) < 4.0 * se[i]);
  }
}

// The ball of tests/usersys (height at 120 Hz, σ = 2 mm, a 0.3 s dropout, every 20th row missing)
// from start values 1.5–2.5× off, with bad frames: a pair displaced by 8 and 9 cm in its first fall, a
// sample by 5 cm beside a missing row, one by 10 cm on equal steps. Each is left out before the fit,
// which is ok within 4 SE of the truth.
TEST_CASE("request: bad frames - a pair, one beside a missing row - are left out before the fit", "[request][outliers]") {
  const fs::path dir = testing::FreshTempDir("request-bad-frames");
  const std::string truth = std::string(HYSID_SOURCE_DIR) + "/tests/usersys/ball.toml";
  const std::string sim = (dir / "sim.csv").string(), data = (dir / "data.csv").string(),
                    start = (dir / "start.toml").string(), json = (dir / "fit.json").string();
  REQUIRE(RunCli({"hysid", "simulate", "--model-file", truth, "--sigma", "2e-3", "--seed", "7", "--out", sim}) == 0);
  std::ifstream in(sim);
  std::ofstream out(data);
  std::string line;
  std::getline(in, line);  // t,j,true_h,true_v,h,v
  out << "t,h\n";
  const std::map<int, double> displaced = {{30, 0.08}, {31, 0.09}, {41, -0.05}, {330, 0.1}};
  for (int k = 0; std::getline(in, line); ++k) {
    std::vector<std::string> cell;
    for (std::size_t at = 0, next; at <= line.size(); at = next + 1) {
      next = std::min(line.find(',', at), line.size());
      cell.push_back(line.substr(at, next - at));
    }
    const double t = std::stod(cell[0]);
    if (t >= 1.95 && t < 2.25) continue;
    double h = std::stod(cell[4]);
    if (const auto it = displaced.find(k); it != displaced.end()) h += it->second;
    out << cell[0] << ',' << (k >= 20 && k % 20 == 0 ? std::string("nan") : fmt::format("{:.17g}", h)) << '\n';
  }
  out.close();
  std::ifstream model_in(truth);
  std::string model((std::istreambuf_iterator<char>(model_in)), std::istreambuf_iterator<char>());
  for (const auto& [from, to] : std::vector<std::pair<std::string, std::string>>{
           {"value = 9.81", "value = 15.0"}, {"value = 0.08", "value = 0.2"}, {"value = 0.82", "value = 0.5"}}) {
    REQUIRE(model.find(from) != std::string::npos);
    model.replace(model.find(from), from.size(), to);
  }
  std::ofstream(start) << model;
  RunCli({"hysid", "identify", "--model-file", start, "--data", data, "--json", json, "--progress", "none"});
  std::ifstream report_in(json);
  const nlohmann::json report = nlohmann::json::parse(report_in);
  std::vector<long> lines;
  for (const auto& o : report["data"]["outliers"]) lines.push_back(o["line"].get<long>());
  // Sample k on line k + 2 of the file before the dropout, 36 rows fewer after it.
  CHECK(lines == std::vector<long>{32, 33, 43, 296});
  CHECK(report["status"] == "ok");
  const std::vector<std::string> names = report["names"];
  const std::vector<double> estimate = report["estimate"], se = report["standard_errors"];
  for (const auto& [name, value] : std::vector<std::pair<std::string, double>>{{"g", 9.81}, {"k", 0.08}, {"e", 0.82}}) {
    const auto i = static_cast<std::size_t>(std::find(names.begin(), names.end(), name) - names.begin());
    REQUIRE(i < names.size());
    CHECK(std::abs(estimate[i] - value) < 4.0 * se[i]);
  }
}

TEST_CASE("request: FitOutliers takes samples and pairs alone off the fit, not runs or samples beside others",
          "[request][outliers]") {
  // One measured state, 1000 samples in two chains (the second from sample 60); residuals
  // 1e-3 sin(1.7 k): robust sd 1.4826 × median |sin| × 1e-3, about 1.05e-3.
  const Eigen::Index K = 1000;
  SampleData data;
  data.y = Mat::Zero(1, K);
  data.chain_start.assign(std::size_t(K), 0);
  data.chain_start[60] = 1;
  FittedOutputs fit;
  fit.matched = Mat::Zero(1, K);
  for (Eigen::Index k = 0; k < K; ++k) {
    data.t.push_back(0.1 * double(k));
    data.run.push_back(0);
    data.line.push_back(long(k) + 2);
    fit.matched(0, k) = std::cos(0.05 * double(k));
    data.y(0, k) = fit.matched(0, k) + 1e-3 * std::sin(1.7 * double(k));
  }
  auto off = [&](Eigen::Index k, double by) { data.y(0, k) = fit.matched(0, k) + by; };
  off(30, 0.05);                                   // alone: taken
  off(60, -0.04);                                  // a chain's first sample, its neighbour clean: taken
  off(100, 0.03), off(101, 0.03);                  // a pair: taken
  off(140, 0.03), off(141, 0.03), off(142, 0.03);  // three in a row: kept
  off(170, 0.02), off(171, 0.0055);  // beside a sample at about 5 sd (more than 3 and a tenth): kept
  off(K - 1, 0.05);                  // the last sample: taken
  std::vector<Eigen::Index> at;
  const std::vector<OutlierSample> found = FitOutliers(data, {0}, fit, &at);
  CHECK(at == std::vector<Eigen::Index>{30, 60, 100, 101, K - 1});
  REQUIRE(found.size() == at.size());
  for (std::size_t i = 0; i < found.size(); ++i) {
    CHECK(found[i].line == long(at[i]) + 2);
    CHECK(found[i].t == Approx(0.1 * double(at[i])));
    CHECK(found[i].row == 0);
    CHECK(found[i].value == data.y(0, at[i]));
    CHECK(found[i].sds > kOutlierSds);
  }
  CHECK(found[0].sds == Approx(0.05 / (1.4826 * 1e-3 * std::sqrt(0.5))).epsilon(0.1));
  // A sample at a chain's end (59, before the chain at 60 starts) is judged within its chain: its
  // neighbour 58 clean, 60 in another chain.
  off(60, 0.0);
  off(59, 0.05);
  at.clear();
  CHECK(FitOutliers(data, {0}, fit, &at).size() == 5);
  CHECK(at[1] == 59);
  // More than 1 % of the samples off alone: a model error, none taken.
  for (const Eigen::Index k : {200, 210, 220, 230, 240, 250}) off(k, 0.05);
  at.clear();
  CHECK(FitOutliers(data, {0}, fit, &at).empty());
  CHECK(at.empty());
}
