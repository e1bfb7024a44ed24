#include "experiments/sweep/run_context.hpp"

#include <CGAL/version_macros.h>
#include <Eigen/Core>
#include <fmt/format.h>
#include <oneapi/tbb/version.h>
#include <sundials/sundials_config.h>

#include "hysid_git_revision.h"  // generated at build time (cmake/git_revision.cmake)
#ifndef HYSID_BUILD_TYPE
#define HYSID_BUILD_TYPE "unknown"
#endif
#ifndef HYSID_VERSION
#define HYSID_VERSION "unknown"
#endif

namespace hysid {

nlohmann::json BuildContext() {
  return {
      {"hysid_version", HYSID_VERSION},
      {"git_revision", HYSID_GIT_REVISION},
      {"build_type", HYSID_BUILD_TYPE},
      {"compiler", fmt::format("g++ {}.{}.{}", __GNUC__, __GNUC_MINOR__, __GNUC_PATCHLEVEL__)},
      {"libraries",
       {{"sundials", SUNDIALS_VERSION},
        {"eigen", fmt::format("{}.{}.{}", EIGEN_WORLD_VERSION, EIGEN_MAJOR_VERSION, EIGEN_MINOR_VERSION)},
        {"cgal", CGAL_VERSION_STR},
        {"tbb", TBB_VERSION_STRING},
        {"fmt", fmt::format("{}.{}.{}", FMT_VERSION / 10000, FMT_VERSION / 100 % 100, FMT_VERSION % 100)}}},
  };
}

namespace {

nlohmann::json ParametersJson(const std::vector<Parameter>& ps) {
  nlohmann::json out = nlohmann::json::array();
  for (const Parameter& p : ps) out.push_back({{"name", p.name}, {"value", p.value}, {"known", p.known}});
  return out;
}

}  // namespace

nlohmann::json ModelDefinitionJson(const Model& model) {
  const ModelSpec& s = model.spec();
  return {{"name", s.name},
          {"states", s.state_names},
          {"alpha", ParametersJson(s.alpha)},
          {"beta", ParametersJson(s.beta)},
          {"flow_rows", s.flow_rows},
          {"jump_rows", s.jump_rows},
          {"flow_jacobian_constant", s.flow_jacobian_constant},
          {"equations", s.equations},
          {"default_x0", s.default_x0},
          {"default_t_end", s.default_t_end},
          {"default_dt", s.default_dt}};
}

nlohmann::json ResolvedModelJson(const Model& model, const std::vector<double>& x0,
                                 const std::vector<double>& dt, double t_end) {
  return {{"name", model.name()},
          {"states", model.spec().state_names},
          {"alpha", ParametersJson(model.spec().alpha)},
          {"beta", ParametersJson(model.spec().beta)},
          {"x0", x0},
          {"dt", dt},
          {"t_end", t_end}};
}

}  // namespace hysid
