// CVODES wrapper: Adams integration of x' = f(t, x) with forward sensitivities to initial states.
#include "trim/ode.hpp"

#include <cmath>
#include <fmt/format.h>

#include <cvodes/cvodes.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunmatrix/sunmatrix_dense.h>

#include "core/errors.hpp"

namespace flapstab {

namespace {

struct UserData {
  const OdeRhs* f;
  Eigen::Index n;
  Eigen::VectorXd scale;
  Eigen::VectorXd x, dx, xp, xm, fp, fm;  // work space
  const OdeJacobian* jac = nullptr;
  // The last Jacobian and where it was formed: the staggered corrector evaluates the sensitivity right-hand
  // sides several times at the same (t, y).
  double jac_t = 0;
  Eigen::VectorXd jac_x;
  Eigen::MatrixXd J;
  long jacobian_evaluations = 0;
};

Eigen::Map<Eigen::VectorXd> view(N_Vector v, Eigen::Index n);

const Eigen::MatrixXd& jacobian_at(UserData* d, double t, N_Vector y) {
  const Eigen::Map<Eigen::VectorXd> x = view(y, d->n);
  if (d->jacobian_evaluations == 0 || t != d->jac_t || x != d->jac_x) {
    d->jac_x = x;
    d->jac_t = t;
    (*d->jac)(t, d->jac_x, d->J);
    ++d->jacobian_evaluations;
  }
  return d->J;
}

Eigen::Map<Eigen::VectorXd> view(N_Vector v, Eigen::Index n) { return {N_VGetArrayPointer(v), n}; }

int rhs(sunrealtype t, N_Vector y, N_Vector ydot, void* user) {
  auto* d = static_cast<UserData*>(user);
  try {
    d->x = view(y, d->n);
    (*d->f)(t, d->x, d->dx);
    view(ydot, d->n) = d->dx;
  } catch (...) {
    return -1;
  }
  return 0;
}

// s_j' = (df/dx) s_j by central directional differences along s_j, the perturbation at most 5e-6 of
// each state's scale (error ~ step^2 ~ 1e-11 relative).
int sens_rhs(int ns, sunrealtype t, N_Vector y, N_Vector, N_Vector* yS, N_Vector* ySdot, void* user, N_Vector,
             N_Vector) {
  auto* d = static_cast<UserData*>(user);
  try {
    if (d->jac) {
      const Eigen::MatrixXd& J = jacobian_at(d, t, y);
      for (int j = 0; j < ns; ++j) view(ySdot[j], d->n).noalias() = J * view(yS[j], d->n);
      return 0;
    }
    d->x = view(y, d->n);
    for (int j = 0; j < ns; ++j) {
      const Eigen::Map<Eigen::VectorXd> s = view(yS[j], d->n);
      const double size = (s.array().abs() / d->scale.array()).maxCoeff();
      if (size == 0) {
        view(ySdot[j], d->n).setZero();
        continue;
      }
      const double h = 5e-6 / size;
      d->xp = d->x + h * s;
      d->xm = d->x - h * s;
      (*d->f)(t, d->xp, d->fp);
      (*d->f)(t, d->xm, d->fm);
      view(ySdot[j], d->n) = (d->fp - d->fm) / (2 * h);
    }
  } catch (...) {
    return -1;
  }
  return 0;
}

// The Newton matrix's df/dx from the same Jacobian.
int dense_jacobian(sunrealtype t, N_Vector y, N_Vector, SUNMatrix A, void* user, N_Vector, N_Vector, N_Vector) {
  auto* d = static_cast<UserData*>(user);
  try {
    const Eigen::MatrixXd& J = jacobian_at(d, t, y);
    for (Eigen::Index j = 0; j < d->n; ++j)
      for (Eigen::Index i = 0; i < d->n; ++i) SM_ELEMENT_D(A, i, j) = J(i, j);
  } catch (...) {
    return -1;
  }
  return 0;
}

void check(int flag, const char* what) {
  if (flag < 0) throw SolveError(fmt::format("CVODES {} failed (flag {})", what, flag));
}

// Owns every SUNDIALS object of one integration.
struct Cvodes {
  SUNContext ctx = nullptr;
  N_Vector y = nullptr;
  N_Vector* yS = nullptr;
  int ns = 0;
  SUNMatrix A = nullptr;
  SUNLinearSolver LS = nullptr;
  void* mem = nullptr;
  Cvodes() {
#if SUNDIALS_VERSION_MAJOR >= 7
    if (SUNContext_Create(SUN_COMM_NULL, &ctx) != 0) throw SolveError("SUNContext_Create failed");
#else
    if (SUNContext_Create(nullptr, &ctx) != 0) throw SolveError("SUNContext_Create failed");
#endif
  }
  ~Cvodes() {
    if (mem) CVodeFree(&mem);
    if (LS) SUNLinSolFree(LS);
    if (A) SUNMatDestroy(A);
    if (yS) N_VDestroyVectorArray(yS, ns);
    if (y) N_VDestroy(y);
    SUNContext_Free(&ctx);
  }
  Cvodes(const Cvodes&) = delete;
  Cvodes& operator=(const Cvodes&) = delete;
};

}  // namespace

OdeSolution integrate_ode(const OdeRhs& f, const Eigen::VectorXd& x0, double t0, double t1,
                          const std::vector<int>& sens, const std::vector<double>& sample_times,
                          const OdeOptions& o) {
  const Eigen::Index n = x0.size();
  UserData data{&f, n, o.scale.size() == n ? o.scale : Eigen::VectorXd::Ones(n), {}, {}, {}, {}, {}, {}, nullptr, 0, {}, {}, 0};
  if (o.jacobian) data.jac = &o.jacobian;
  data.dx.resize(n);
  data.fp.resize(n);
  data.fm.resize(n);
  Cvodes cv;
  cv.y = N_VNew_Serial(sunindextype(n), cv.ctx);
  view(cv.y, n) = x0;
  cv.mem = CVodeCreate(CV_ADAMS, cv.ctx);
  check(CVodeInit(cv.mem, rhs, t0, cv.y), "init");
  N_Vector atol = N_VNew_Serial(sunindextype(n), cv.ctx);
  view(atol, n) = o.rtol * data.scale;
  const int tol_flag = CVodeSVtolerances(cv.mem, o.rtol, atol);
  N_VDestroy(atol);
  check(tol_flag, "tolerances");
  check(CVodeSetUserData(cv.mem, &data), "user data");
  check(CVodeSetMaxNumSteps(cv.mem, o.max_steps), "max steps");
  check(CVodeSetStopTime(cv.mem, t1), "stop time");
  cv.A = SUNDenseMatrix(sunindextype(n), sunindextype(n), cv.ctx);
  cv.LS = SUNLinSol_Dense(cv.y, cv.A, cv.ctx);
  check(CVodeSetLinearSolver(cv.mem, cv.LS, cv.A), "linear solver");
  if (data.jac) check(CVodeSetJacFn(cv.mem, dense_jacobian), "Jacobian");
  if (!sens.empty()) {
    cv.ns = int(sens.size());
    cv.yS = N_VCloneVectorArray(cv.ns, cv.y);
    for (int j = 0; j < cv.ns; ++j) {
      if (sens[std::size_t(j)] < 0 || sens[std::size_t(j)] >= n) throw SolveError("integrate_ode: bad sensitivity index");
      view(cv.yS[j], n).setZero();
      view(cv.yS[j], n)(sens[std::size_t(j)]) = 1;
    }
    check(CVodeSensInit(cv.mem, cv.ns, CV_STAGGERED, sens_rhs, cv.yS), "sensitivity init");
    check(CVodeSensEEtolerances(cv.mem), "sensitivity tolerances");
    check(CVodeSetSensErrCon(cv.mem, SUNTRUE), "sensitivity error control");
  }
  OdeSolution out;
  sunrealtype t = t0;
  for (double ts : sample_times) {
    if (ts < t0 || ts > t1) throw SolveError("integrate_ode: sample time outside [t0, t1]");
    if (ts > t) check(CVode(cv.mem, ts, cv.y, &t, CV_NORMAL), "integration");
    out.samples.push_back(view(cv.y, n));
  }
  if (t < t1) check(CVode(cv.mem, t1, cv.y, &t, CV_NORMAL), "integration");
  out.x = view(cv.y, n);
  if (!sens.empty()) {
    check(CVodeGetSens(cv.mem, &t, cv.yS), "sensitivity output");
    out.sensitivity.resize(n, cv.ns);
    for (int j = 0; j < cv.ns; ++j) out.sensitivity.col(j) = view(cv.yS[j], n);
  }
  CVodeGetNumSteps(cv.mem, &out.steps);
  CVodeGetNumRhsEvals(cv.mem, &out.rhs_evaluations);
  return out;
}

}  // namespace flapstab
