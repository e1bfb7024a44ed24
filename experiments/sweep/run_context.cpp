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

nlohmann::json ResolvedModelJson(const Model& model, const std::vector<double>& x0,
                                 const std::vector<double>& dt, double t_end) {
  const auto params = [](const std::vector<Parameter>& ps) {
    nlohmann::json out = nlohmann::json::array();
    for (const Parameter& p : ps) out.push_back({{"name", p.name}, {"value", p.value}, {"known", p.known}});
    return out;
  };
  return {{"name", model.name()},
          {"states", model.spec().state_names},
          {"alpha", params(model.spec().alpha)},
          {"beta", params(model.spec().beta)},
          {"x0", x0},
          {"dt", dt},
          {"t_end", t_end}};
}

}  // namespace hysid
