// The direct read of CVODE's Nordsieck array (sim/nordsieck.hpp) against CVodeGetDky, bit for bit,
// on a damped oscillator integrated step by step with the simulator's settings (Adams, fixed-point
// iteration, fused vector operations, rtol = atol = 1e-12).
#include <catch2/catch.hpp>

#include <cstring>
#include <vector>

#include <cvodes/cvodes.h>
#include <nvector/nvector_serial.h>
#include <sunnonlinsol/sunnonlinsol_fixedpoint.h>

#include "sim/nordsieck.hpp"
#include "sim/sundials_ptr.hpp"

namespace hysid {
namespace {

int Oscillator(sunrealtype /*t*/, N_Vector y, N_Vector ydot, void* /*user_data*/) {
  const double* x = N_VGetArrayPointer_Serial(y);
  double* f = N_VGetArrayPointer_Serial(ydot);
  f[0] = x[1];
  f[1] = -5.0 * x[0] - 0.1 * x[1];
  return 0;
}

bool SameBits(const double* a, const double* b, long n) {
  return std::memcmp(a, b, static_cast<std::size_t>(n) * sizeof(double)) == 0;
}

TEST_CASE("Nordsieck history: Dky and DkyAtTn equal CVodeGetDky to the bit at every order", "[sim]") {
  SUNContext raw_ctx = nullptr;
  REQUIRE(SUNContext_Create(nullptr, &raw_ctx) == 0);
  const sundials_ptr::ContextPtr ctx(raw_ctx);
  const sundials_ptr::NVectorPtr y(N_VNew_Serial(2, ctx.get()));
  const sundials_ptr::NVectorPtr scratch(N_VNew_Serial(2, ctx.get()));
  N_VEnableFusedOps_Serial(y.get(), SUNTRUE);
  N_VEnableFusedOps_Serial(scratch.get(), SUNTRUE);
  N_VGetArrayPointer_Serial(y.get())[0] = 20.0;
  N_VGetArrayPointer_Serial(y.get())[1] = 0.0;
  const sundials_ptr::CvodePtr cvode(CVodeCreate(CV_ADAMS, ctx.get()));
  nordsieck::History history;
  {
    const nordsieck::CloneRecorder recorder(y.get());
    REQUIRE(CVodeInit(cvode.get(), Oscillator, 0.0, y.get()) == CV_SUCCESS);
    history.Locate(cvode.get(), recorder.clones(), 2);
  }
  REQUIRE(history.available());
  REQUIRE(CVodeSStolerances(cvode.get(), 1e-12, 1e-12) == CV_SUCCESS);
  const sundials_ptr::NonlinearSolverPtr nls(SUNNonlinSol_FixedPoint(y.get(), 0, ctx.get()));
  REQUIRE(CVodeSetNonlinearSolver(cvode.get(), nls.get()) == CV_SUCCESS);

  std::vector<double> direct(2);
  const double* cvode_value = N_VGetArrayPointer_Serial(scratch.get());
  int max_order = 0;
  long compared = 0;
  for (int step = 0; step < 400; ++step) {
    sunrealtype t = 0.0, tn = 0.0, h = 0.0;
    REQUIRE(CVode(cvode.get(), 10.0, y.get(), &t, CV_ONE_STEP) == CV_SUCCESS);
    int q = 0;
    CVodeGetLastOrder(cvode.get(), &q);
    CVodeGetCurrentTime(cvode.get(), &tn);
    CVodeGetLastStep(cvode.get(), &h);
    REQUIRE(history.Prepare(cvode.get(), q, tn, h, scratch.get()));
    max_order = std::max(max_order, q);
    for (int k = 0; k <= q; ++k) {
      REQUIRE(CVodeGetDky(cvode.get(), tn, k, scratch.get()) == CV_SUCCESS);
      history.DkyAtTn(k, direct.data());
      REQUIRE(SameBits(direct.data(), cvode_value, 2));
      for (const double f : {0.0, 0.1, 0.5, 0.999, 1.0}) {
        const double tk = tn - f * h;
        REQUIRE(CVodeGetDky(cvode.get(), tk, k, scratch.get()) == CV_SUCCESS);
        history.Dky(tk, k, direct.data());
        REQUIRE(SameBits(direct.data(), cvode_value, 2));
        ++compared;
      }
    }
  }
  CHECK(max_order >= 7);  // the high orders of the Adams method are exercised
  CHECK(compared > 2000);
}

TEST_CASE("Nordsieck history: unavailable without the clones of CVodeInit", "[sim]") {
  SUNContext raw_ctx = nullptr;
  REQUIRE(SUNContext_Create(nullptr, &raw_ctx) == 0);
  const sundials_ptr::ContextPtr ctx(raw_ctx);
  const sundials_ptr::NVectorPtr y(N_VNew_Serial(2, ctx.get()));
  N_VConst(1.0, y.get());
  const sundials_ptr::CvodePtr cvode(CVodeCreate(CV_ADAMS, ctx.get()));
  REQUIRE(CVodeInit(cvode.get(), Oscillator, 0.0, y.get()) == CV_SUCCESS);
  nordsieck::History history;
  history.Locate(cvode.get(), {}, 2);
  CHECK_FALSE(history.available());
  CHECK_FALSE(history.Prepare(cvode.get(), 1, 0.0, 1e-3, y.get()));
}

}  // namespace
}  // namespace hysid
