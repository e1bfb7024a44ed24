#include "experiments/sweep/trial.hpp"

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>

#include <fmt/format.h>

#include "core/identify/identifier.hpp"
#include "core/identify/metrics.hpp"
#include "core/sets/set_metrics.hpp"

namespace hysid {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Names of the unknown entries of α (or β) over all models, in first-seen order.
std::vector<std::string> UnknownNames(const std::vector<Model>& models, bool alpha) {
  std::vector<std::string> names;
  for (const Model& m : models) {
    for (const Parameter& p : alpha ? m.spec().alpha : m.spec().beta) {
      if (!p.known && std::find(names.begin(), names.end(), p.name) == names.end()) names.push_back(p.name);
    }
  }
  return names;
}

int MaxStates(const std::vector<Model>& models) {
  int n = 0;
  for (const Model& m : models) n = std::max(n, m.state_size());
  return n;
}

// No commas or line breaks in a free-text cell.
std::string Clean(std::string s) {
  for (char& ch : s) {
    if (ch == ',' || ch == '\n' || ch == '\r' || ch == '"') ch = ';';
  }
  return s;
}

}  // namespace

std::string FormatNumber(double v) { return std::isnan(v) ? std::string() : fmt::format("{}", v); }

const std::vector<std::string>& SummaryMetrics() {
  static const std::vector<std::string> metrics{
      "misclassification", "precision", "recall", "fp", "fn", "e_alpha", "e_beta", "rel_alpha", "rel_beta",
      "jump_hausdorff", "flow_outside_share"};
  return metrics;
}

std::vector<std::string> TrialHeader(const SweepConfig& config, const std::vector<Model>& models) {
  (void)config;
  std::vector<std::string> h{"unit", "cell", "trial", "model", "dt", "sigma", "r", "false_alarm", "estimator",
                             "detector"};
  for (int i = 0; i < MaxStates(models); ++i) h.push_back(fmt::format("x0_{}", i + 1));
  h.insert(h.end(), {"status", "message", "samples", "jumps_true", "jumps_detected", "tp", "fp", "fn", "tn",
                     "misclassification", "precision", "recall", "e_alpha", "e_beta", "rel_alpha",
                     "rel_beta", "flow_status", "jump_status", "jump_hausdorff", "flow_outside_share",
                     "flow_hull_vertices", "jump_hull_vertices"});
  for (const std::string& n : UnknownNames(models, true)) h.push_back("alpha_hat_" + n);
  for (const std::string& n : UnknownNames(models, false)) h.push_back("beta_hat_" + n);
  return h;
}

std::vector<std::string> RunTrial(const SweepConfig& config, const std::vector<Model>& models,
                                  const SweepCell& cell, long unit, long trial, const TrialInputs& in) {
  const Vec& x0 = *in.x0;
  const Trajectory& truth = *in.truth;
  const std::string& sim_error = in.sim_error;
  const Model& model = models[static_cast<std::size_t>(cell.model)];
  const SweepModel& sm = config.models[static_cast<std::size_t>(cell.model)];
  std::vector<std::string> row{fmt::format("{}", unit), fmt::format("{}", cell.index), fmt::format("{}", trial),
                               sm.name, FormatNumber(cell.dt), FormatNumber(cell.sigma), FormatNumber(cell.r),
                               FormatNumber(cell.false_alarm), cell.estimator, cell.detector};
  const int nmax = MaxStates(models);
  for (int i = 0; i < nmax; ++i) row.push_back(i < x0.size() ? FormatNumber(x0[i]) : std::string());

  std::string status = kTrialOk, message;
  long samples = truth.size(), jumps_true = static_cast<long>(truth.jumps.size()), jumps_detected = -1;
  Confusion conf;
  ParameterErrors err{kNaN, kNaN, kNaN, kNaN};
  std::string flow_status, jump_status;
  SetMetrics sets;
  long flow_vertices = -1, jump_vertices = -1;
  Vec alpha_hat, beta_hat;
  bool have_estimates = false;

  if (!sim_error.empty()) {
    status = "error";
    message = sim_error;
  } else if (!truth.status.completed()) {
    status = ToString(truth.status.stop);
    message = truth.status.stop == SimStop::kZeno
                  ? fmt::format("Zeno: jumps accumulate at t = {:.6g} s before t_end = {} s; shorten t_end",
                                truth.status.zeno_time, sm.t_end)
                  : truth.status.message;
  } else {
    try {
      IdentifierSettings s = config.identifier;
      s.flow_estimator.name = s.jump_estimator.name = cell.estimator;
      s.detector.name = cell.detector;
      if (!std::isnan(cell.r)) s.detector.r = cell.r;
      if (!std::isnan(cell.false_alarm)) s.detector.false_alarm = cell.false_alarm;
      if (config.known_sigma) s.sigma = Vec::Constant(model.state_size(), cell.sigma);
      // The trajectories come from CVODE at these tolerances: the data's accuracy apart from σ.
      s.data_rtol = config.simulator.rtol;
      s.data_atol = config.simulator.atol;
      if (cell.sigma > 0) {
        if (in.normals == nullptr || in.normals->cols() != truth.x.cols() || in.noisy == nullptr) {
          throw std::logic_error("RunTrial: σ > 0 without the trial's standard normals");
        }
        in.noisy->noalias() = truth.x + cell.sigma * *in.normals;  // x(i, k) + σ·E(i, k)
      }
      const IdentifyResult res = Identify(model, cell.sigma > 0 ? *in.noisy : truth.x, truth.dt, s);
      alpha_hat = res.alpha_hat;
      beta_hat = res.beta_hat;
      have_estimates = true;
      jumps_detected = res.jumps_detected;
      flow_status = ToString(res.flow_status);
      jump_status = ToString(res.jump_status);
      conf = CompareJumps(truth.j, res.gamma);
      if (!alpha_hat.allFinite() || !beta_hat.allFinite()) {
        status = "non_finite_estimate";
        message = "an estimate is not finite";
      } else {
        err = CompareParameters(model, alpha_hat, beta_hat);
        if (s.sets) {
          sets = CompareSets(model, res.flow_hull, res.jump_hull);
          flow_vertices = static_cast<long>(res.flow_hull.cols());
          jump_vertices = static_cast<long>(res.jump_hull.cols());
        }
      }
    } catch (const std::exception& e) {
      status = "error";
      message = e.what();
      have_estimates = false;
    }
  }
  const bool ok = status == kTrialOk;
  const auto num = [&](double v) { return ok ? FormatNumber(v) : std::string(); };
  const auto count = [&](long v) { return ok ? fmt::format("{}", v) : std::string(); };
  row.insert(row.end(),
             {status, Clean(message), fmt::format("{}", samples), fmt::format("{}", jumps_true),
              count(jumps_detected), count(conf.tp), count(conf.fp), count(conf.fn), count(conf.tn),
              num(conf.misclassification()), num(conf.precision()), num(conf.recall()), num(err.e_alpha),
              num(err.e_beta), num(err.rel_alpha), num(err.rel_beta), flow_status, jump_status,
              num(sets.jump_hausdorff), num(sets.flow_outside_share),
              flow_vertices < 0 ? std::string() : count(flow_vertices),
              jump_vertices < 0 ? std::string() : count(jump_vertices)});
  for (bool alpha : {true, false}) {
    for (const std::string& name : UnknownNames(models, alpha)) {
      const auto& params = alpha ? model.spec().alpha : model.spec().beta;
      std::string cellv;
      for (std::size_t i = 0; i < params.size(); ++i) {
        if (params[i].name == name && !params[i].known && have_estimates) {
          cellv = FormatNumber((alpha ? alpha_hat : beta_hat)[static_cast<Eigen::Index>(i)]);
        }
      }
      row.push_back(cellv);
    }
  }
  return row;
}

}  // namespace hysid
