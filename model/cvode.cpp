#include "model/cvode.h"

#include "model/dop853.h"
#include "model/small_vector.h"

#include <arkode/arkode_erkstep.h>
#include <cvode/cvode.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sunnonlinsol/sunnonlinsol_fixedpoint.h>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <exception>
#include <stdexcept>
#include <string>

namespace rocklab::model::detail {
namespace {

void Check(int flag, const char* function) {
  if (flag < 0) {
    const bool ark = std::string(function).rfind("ERKStep", 0) == 0;
    char* name = ark ? ERKStepGetReturnFlagName(flag) : CVodeGetReturnFlagName(flag);
    const std::string text = name != nullptr ? name : "?";
    std::free(name);  // both allocate the name
    throw std::runtime_error(std::string(function) + " failed with flag " + std::to_string(flag) + " (" + text +
                             ")");
  }
}

// Check of the integrator's step call, its message naming where it stopped:
// the time reached, the time asked for and the state there.
void CheckEvolve(int flag, bool rk, double t_reached_s, double tout_s, const N_Vector y, int n) {
  if (flag >= 0) return;
  try {
    Check(flag, rk ? "ERKStepEvolve" : "CVode");
  } catch (const std::runtime_error& e) {
    char text[96];
    std::string msg = e.what();
    std::snprintf(text, sizeof text, " at t = %.17g s (asked for %.17g s), state [", t_reached_s, tout_s);
    msg += text;
    const double* v = N_VGetArrayPointer(y);
    for (int i = 0; i < n; ++i) {
      std::snprintf(text, sizeof text, "%s%.17g", i ? ", " : "", v[i]);
      msg += text;
    }
    throw IntegratorError(msg + "]");
  }
}

template <typename T>
T CheckPtr(T ptr, const char* function) {
  if (ptr == nullptr) throw std::runtime_error(std::string(function) + " returned null");
  return ptr;
}

}  // namespace

struct Cvode::Handles {
  SUNContext ctx{nullptr};
  N_Vector y{nullptr};
  N_Vector atol{nullptr};
  SUNNonlinearSolver nls{nullptr};
  void* mem{nullptr};
  bool rk{false};  // ARKODE's ERKStep instead of CVODE
  std::unique_ptr<EmbeddedRungeKutta> dp;  // or Dormand-Prince 8(5,3) or 5(4), without SUNDIALS
  OdeSystem* system{nullptr};
  std::exception_ptr error;

  ~Handles() {
    // Destruction order: solver memory first, then what it refers to.
    if (mem != nullptr) {
      if (rk) {
        ERKStepFree(&mem);
      } else {
        CVodeFree(&mem);
      }
    }
    if (nls != nullptr) SUNNonlinSolFree(nls);
    if (atol != nullptr) N_VDestroy(atol);
    if (y != nullptr) N_VDestroy(y);
    if (ctx != nullptr) SUNContext_Free(&ctx);
  }
};

// Exceptions must not cross the C library: the thunks keep the first one and
// Advance rethrows it after CVode has returned its failure flag.
// Every vector the integrators hand them is serial (h_->y made by
// N_VNew_Serial, the rest its clones), so its data is read directly:
// N_VGetArrayPointer's two indirect calls were 4 % of the model node's CPU
// (docs/performance.md, "Per-sample cost of the model node").
int Cvode::RhsThunk(double t, N_Vector y, N_Vector ydot, void* user) {
  auto* h = static_cast<Handles*>(user);
  try {
    return h->system->Rhs(t, NV_DATA_S(y), NV_DATA_S(ydot));
  } catch (...) {
    if (!h->error) h->error = std::current_exception();
    return -1;
  }
}

int Cvode::RootThunk(double t, N_Vector y, double* g, void* user) {
  auto* h = static_cast<Handles*>(user);
  try {
    return h->system->Roots(t, NV_DATA_S(y), g);
  } catch (...) {
    if (!h->error) h->error = std::current_exception();
    return -1;
  }
}

Cvode::Cvode(int n, OdeSystem& system, double rtol, const double* atol, double max_step_s, Method method, int roots)
    : h_(std::make_unique<Handles>()), n_(n), roots_(roots) {
  if (n < 1 || n > kMaxEquations) throw std::invalid_argument("Cvode: n must be 1.." + std::to_string(kMaxEquations));
  if (roots < 1 || roots > kMaxRoots) throw std::invalid_argument("Cvode: roots must be 1.." + std::to_string(kMaxRoots));
  h_->system = &system;
  if (method == Method::kDormandPrince853) {
    h_->dp = std::make_unique<Dop853>(n, system, rtol, atol, max_step_s, roots);
    return;
  }
  if (method == Method::kDormandPrince5) {
    h_->dp = std::make_unique<Dopri5>(n, system, rtol, atol, max_step_s, roots);
    return;
  }
  h_->rk = method == Method::kRungeKutta;
  Check(SUNContext_Create(nullptr, &h_->ctx), "SUNContext_Create");
  h_->y = CheckPtr(N_VNew_Serial(n, h_->ctx), "N_VNew_Serial");
  h_->atol = CheckPtr(N_VNew_Serial(n, h_->ctx), "N_VNew_Serial");
  // Fixed-length vector operations (model/small_vector.h), fused ones
  // included: CVODE's Nordsieck updates and Adams corrections are one
  // N_VLinearCombination / N_VScaleAddMulti call over all the history
  // vectors instead of one N_VLinearSum per vector. On a 2-4 element state
  // the per-call overhead is the cost (docs/performance.md). The
  // integrators clone their vectors from y, which carries the operations.
  if (UseSmallVectorOps(h_->y)) {
    UseSmallVectorOps(h_->atol);
  } else if (n <= 4) {
    throw std::logic_error("Cvode: no fixed-length vector operations for n");
  }
  double* y = N_VGetArrayPointer(h_->y);
  double* a = N_VGetArrayPointer(h_->atol);
  for (int i = 0; i < n; ++i) {
    y[i] = 0.0;
    a[i] = atol[i];
  }
  if (h_->rk) {
    h_->mem = CheckPtr(ERKStepCreate(RhsThunk, 0.0, h_->y, h_->ctx), "ERKStepCreate");
    Check(ERKStepSetUserData(h_->mem, h_.get()), "ERKStepSetUserData");
    Check(ERKStepSVtolerances(h_->mem, rtol, h_->atol), "ERKStepSVtolerances");
    Check(ERKStepSetOrder(h_->mem, kRungeKuttaOrder), "ERKStepSetOrder");
    // A cubic Hermite interpolant: ARKODE's default (degree 5) takes two
    // more right-hand sides per step wherever it is evaluated, and it is
    // evaluated at every stop time (the model node stops at every sample,
    // where the cubic equals the step's end exactly); between stops it
    // places the roots (docs/performance.md, "Per-sample cost").
    Check(ERKStepSetInterpolantDegree(h_->mem, kRungeKuttaInterpolantDegree), "ERKStepSetInterpolantDegree");
    Check(ERKStepSetMaxStep(h_->mem, max_step_s), "ERKStepSetMaxStep");
    Check(ERKStepSetMaxNumSteps(h_->mem, 1000000), "ERKStepSetMaxNumSteps");
    Check(ERKStepRootInit(h_->mem, roots_, RootThunk), "ERKStepRootInit");
    Check(ERKStepSetNoInactiveRootWarn(h_->mem), "ERKStepSetNoInactiveRootWarn");
    Check(ERKStepSetErrFile(h_->mem, nullptr), "ERKStepSetErrFile");
    return;
  }
  h_->mem = CheckPtr(CVodeCreate(CV_ADAMS, h_->ctx), "CVodeCreate");
  Check(CVodeInit(h_->mem, RhsThunk, 0.0, h_->y), "CVodeInit");
  Check(CVodeSetUserData(h_->mem, h_.get()), "CVodeSetUserData");
  Check(CVodeSVtolerances(h_->mem, rtol, h_->atol), "CVodeSVtolerances");
  h_->nls = CheckPtr(SUNNonlinSol_FixedPoint(h_->y, 0, h_->ctx), "SUNNonlinSol_FixedPoint");
  Check(CVodeSetNonlinearSolver(h_->mem, h_->nls), "CVodeSetNonlinearSolver");
  Check(CVodeSetMaxStep(h_->mem, max_step_s), "CVodeSetMaxStep");
  Check(CVodeSetMaxNumSteps(h_->mem, 1000000), "CVodeSetMaxNumSteps");
  Check(CVodeRootInit(h_->mem, roots_, RootThunk), "CVodeRootInit");
  Check(CVodeSetNoInactiveRootWarn(h_->mem), "CVodeSetNoInactiveRootWarn");
  // No messages on stderr: a failure throws with the flag's name, a
  // recovered one is counted (Stats::recoveries).
  Check(CVodeSetErrFile(h_->mem, nullptr), "CVodeSetErrFile");
}

Cvode::~Cvode() = default;

void Cvode::ReInit(double t0_s, const double* y0) {
  AddCounters();
  if (h_->dp) {
    h_->dp->ReInit(t0_s, y0);
    t_ = t0_s;
    return;
  }
  double* y = N_VGetArrayPointer(h_->y);
  for (int i = 0; i < n_; ++i) y[i] = y0[i];
  if (h_->rk) {
    Check(ERKStepReInit(h_->mem, RhsThunk, t0_s, h_->y), "ERKStepReInit");
  } else {
    Check(CVodeReInit(h_->mem, t0_s, h_->y), "CVodeReInit");
  }
  t_ = t0_s;
}

void Cvode::SetTolerances(double rtol, const double* atol) {
  if (h_->dp) {
    h_->dp->SetTolerances(rtol, atol);
    return;
  }
  double* a = N_VGetArrayPointer(h_->atol);
  for (int i = 0; i < n_; ++i) a[i] = atol[i];
  if (h_->rk) {
    Check(ERKStepSVtolerances(h_->mem, rtol, h_->atol), "ERKStepSVtolerances");
  } else {
    Check(CVodeSVtolerances(h_->mem, rtol, h_->atol), "CVodeSVtolerances");
  }
}

void Cvode::SetMaxStep(double max_step_s) {
  if (h_->dp) {
    h_->dp->SetMaxStep(max_step_s);
    return;
  }
  if (h_->rk) {
    Check(ERKStepSetMaxStep(h_->mem, max_step_s), "ERKStepSetMaxStep");
  } else {
    Check(CVodeSetMaxStep(h_->mem, max_step_s), "CVodeSetMaxStep");
  }
}

void Cvode::SetRootDirection(std::array<int, kRoots> direction) {
  if (roots_ != kRoots) throw std::logic_error("Cvode: SetRootDirection of three roots on " + std::to_string(roots_));
  SetRootDirection(direction.data());
}

void Cvode::SetRootDirection(const int* direction) {
  // SUNDIALS takes a non-const array and copies it.
  std::array<int, kMaxRoots> copy{};
  std::copy(direction, direction + roots_, copy.begin());
  if (h_->dp) {
    h_->dp->SetRootDirection(copy.data());
    return;
  }
  if (h_->rk) {
    Check(ERKStepSetRootDirection(h_->mem, copy.data()), "ERKStepSetRootDirection");
  } else {
    Check(CVodeSetRootDirection(h_->mem, copy.data()), "CVodeSetRootDirection");
  }
}

Cvode::Result Cvode::Advance(double tout_s, double tstop_s) {
  // SUNDIALS 6.4 has no CVodeClearStopTime: "no bound" is the largest double.
  const double tstop = std::min(tstop_s, DBL_MAX);
  if (h_->dp) {
    while (true) {
      try {
        const EmbeddedRungeKutta::Result r = h_->dp->Advance(tout_s, tstop);
        t_ = h_->dp->t_s();
        return r == EmbeddedRungeKutta::Result::kRoot ? Result::kRoot : Result::kReached;
      } catch (const StepFailure&) {
        // As CVODE's and ARKODE's failures below: from the last step's end
        // (every root before it is found), with the starting-step estimate;
        // the second time there, past the jump that the steps could not
        // approach closer than their smallest (twice that: 8.9e-16 s at t < 1
        // s, 3.2e-13 s at 358 s).
        const double t_done = h_->dp->t_step_end();
        double t_restart = 0.0;
        if (!RecoveryTime(t_done, tstop, 2 * EmbeddedRungeKutta::SmallestStep(t_done), &t_restart) ||
            t_restart > tout_s) {
          throw;
        }
        ++done_.recoveries;
        std::array<double, kMaxEquations> y0{};
        for (int i = 0; i < n_; ++i) y0[static_cast<std::size_t>(i)] = h_->dp->y_step_end()[i];
        AddCounters();
        h_->dp->ReInit(t_restart, y0.data(), false);
        t_ = t_restart;
      }
    }
  }
  const bool rk = h_->rk;
  while (true) {
    // The stop time is cleared once reached: set it for every call.
    realtype t = t_;
    int flag = 0;
    if (rk) {
      Check(ERKStepSetStopTime(h_->mem, tstop), "ERKStepSetStopTime");
      flag = ERKStepEvolve(h_->mem, tout_s, h_->y, &t, ARK_NORMAL);
    } else {
      Check(CVodeSetStopTime(h_->mem, tstop), "CVodeSetStopTime");
      flag = CVode(h_->mem, tout_s, h_->y, &t, CV_NORMAL);
    }
    if (h_->error) {
      std::exception_ptr error = h_->error;
      h_->error = nullptr;
      std::rethrow_exception(error);
    }
    if (rk ? flag == ARK_ERR_FAILURE : (flag == CV_ERR_FAILURE || flag == CV_CONV_FAILURE)) {
      // A kink or jump of the right-hand side that nobody declared: restart
      // from the last completed step with a fresh (first-order) history,
      // which steps over a jump at the cost of a few small steps.
      // When the fresh restart fails again at the same time, the jump is at
      // that very time (its value there the one before it): restart 16 ulp
      // later with the same state (an error of 16 ulp times the rate, e.g.
      // 4e-15 rad at 1 rad/s and t = 1 s). A third failure there is final.
      realtype t_done = t_;
      if (rk) {
        Check(ERKStepGetCurrentTime(h_->mem, &t_done), "ERKStepGetCurrentTime");
        Check(ERKStepGetDky(h_->mem, t_done, 0, h_->y), "ERKStepGetDky");
      } else {
        Check(CVodeGetCurrentTime(h_->mem, &t_done), "CVodeGetCurrentTime");
        Check(CVodeGetDky(h_->mem, t_done, 0, h_->y), "CVodeGetDky");
      }
      double t_restart = t_done;
      if (!RecoveryTime(t_done, tstop, 0.0, &t_restart)) CheckEvolve(flag, rk, t_done, tout_s, h_->y, n_);
      ++done_.recoveries;
      std::array<double, kMaxEquations> y0{};
      const double* y = N_VGetArrayPointer(h_->y);
      for (int i = 0; i < n_; ++i) y0[static_cast<std::size_t>(i)] = y[i];
      ReInit(t_restart, y0.data());
      continue;
    }
    CheckEvolve(flag, rk, t, tout_s, h_->y, n_);
    t_ = t;
    return flag == (rk ? ARK_ROOT_RETURN : CV_ROOT_RETURN) ? Result::kRoot : Result::kReached;
  }
}

bool Cvode::RecoveryTime(double t_done_s, double tstop_s, double nudge_s, double* t_restart_s) {
  double t = t_done_s;
  if (t_done_s == last_failure_t_) {
    if (nudged_) return false;
    if (nudge_s > 0.0) {
      t = std::min(t + nudge_s, tstop_s);
    } else {
      for (int k = 0; k < 16; ++k) t = std::nextafter(t, tstop_s);
    }
    nudged_ = true;
  } else {
    nudged_ = false;
  }
  last_failure_t_ = t;
  *t_restart_s = t;
  return true;
}

Cvode::Stats Cvode::Counters() const {
  long steps = 0, rhs = 0, fails = 0;
  if (h_->dp) {
    steps = h_->dp->steps();
    rhs = h_->dp->rhs_evals();
    fails = h_->dp->error_test_fails();
  } else if (h_->rk) {
    Check(ERKStepGetNumSteps(h_->mem, &steps), "ERKStepGetNumSteps");
    Check(ERKStepGetNumRhsEvals(h_->mem, &rhs), "ERKStepGetNumRhsEvals");
    Check(ERKStepGetNumErrTestFails(h_->mem, &fails), "ERKStepGetNumErrTestFails");
  } else {
    Check(CVodeGetNumSteps(h_->mem, &steps), "CVodeGetNumSteps");
    Check(CVodeGetNumRhsEvals(h_->mem, &rhs), "CVodeGetNumRhsEvals");
    Check(CVodeGetNumErrTestFails(h_->mem, &fails), "CVodeGetNumErrTestFails");
  }
  Stats s;
  s.steps = steps;
  s.rhs_evals = rhs;
  s.error_test_fails = fails;
  return s;
}

void Cvode::AddCounters() {
  const Stats now = Counters();
  done_.steps += now.steps;
  done_.rhs_evals += now.rhs_evals;
  done_.error_test_fails += now.error_test_fails;
}

Cvode::Stats Cvode::stats() const {
  const Stats now = Counters();
  Stats s = done_;
  s.steps += now.steps;
  s.rhs_evals += now.rhs_evals;
  s.error_test_fails += now.error_test_fails;
  return s;
}

std::array<int, Cvode::kRoots> Cvode::RootsFound() {
  if (roots_ != kRoots) throw std::logic_error("Cvode: RootsFound of three roots on " + std::to_string(roots_));
  std::array<int, kRoots> found{};
  RootsFound(found.data());
  return found;
}

void Cvode::RootsFound(int* found) {
  if (h_->dp) {
    h_->dp->RootsFound(found);
  } else if (h_->rk) {
    Check(ERKStepGetRootInfo(h_->mem, found), "ERKStepGetRootInfo");
  } else {
    Check(CVodeGetRootInfo(h_->mem, found), "CVodeGetRootInfo");
  }
}

const double* Cvode::y() const { return h_->dp ? h_->dp->y() : N_VGetArrayPointer(h_->y); }
double* Cvode::y_mut() { return h_->dp ? h_->dp->y_mut() : N_VGetArrayPointer(h_->y); }

}  // namespace rocklab::model::detail
