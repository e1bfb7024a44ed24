// The identification request/result layer (experiments/request): a request built in C++ gives the
// command line's estimates and --json report for the same data, its estimates lie near the simulated
// truth, and a refusal names the option as the front-end spells it (a flag or a Python keyword).
#include <cmath>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include "core/builtin/builtin.hpp"
#include "core/model/registry.hpp"
#include "experiments/cli/entry.hpp"
#include "experiments/request/outcome_json.hpp"
#include "experiments/request/request.hpp"
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
