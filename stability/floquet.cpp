// Floquet analysis: periodic-spline A(t), CVODE integration of the monodromy, multipliers, exponents, modes.
#include "stability/floquet.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <memory>

#include <cvodes/cvodes.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sunnonlinsol/sunnonlinsol_fixedpoint.h>

#include "core/errors.hpp"

namespace flapstab {

namespace {
using cplx = std::complex<double>;
}

// Periodic cubic spline through (t_k, y_k): second derivatives m solve the cyclic system
// m_{k-1} + 4 m_k + m_{k+1} = 6 (y_{k+1} - 2 y_k + y_{k-1}) / h^2 (de Boor 1978, A Practical Guide to
// Splines, ch. IV), solved once for all entries with a dense LU of the N x N circulant matrix.
PeriodicMatrixSpline::PeriodicMatrixSpline(double period, std::vector<Eigen::MatrixXd> samples)
    : period_(period), y_(std::move(samples)) {
  const int n = static_cast<int>(y_.size());
  if (n < 3 || !(period > 0)) throw SolveError("PeriodicMatrixSpline: need at least 3 samples and a positive period");
  h_ = period / n;
  const Eigen::Index r = y_[0].rows(), c = y_[0].cols();
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(n, n);
  Eigen::MatrixXd rhs(n, r * c);
  for (int k = 0; k < n; ++k) {
    C(k, k) = 4;
    C(k, (k + 1) % n) += 1;
    C(k, (k + n - 1) % n) += 1;
    const Eigen::MatrixXd d2 = (y_[(k + 1) % n] - 2 * y_[k] + y_[(k + n - 1) % n]) * (6 / (h_ * h_));
    rhs.row(k) = Eigen::Map<const Eigen::RowVectorXd>(d2.data(), r * c);
  }
  const Eigen::MatrixXd m = C.partialPivLu().solve(rhs);
  m_.resize(n);
  for (int k = 0; k < n; ++k) m_[k] = Eigen::Map<const Eigen::MatrixXd>(m.row(k).eval().data(), r, c);
}

Eigen::MatrixXd PeriodicMatrixSpline::operator()(double t) const {
  const int n = static_cast<int>(y_.size());
  double s = std::fmod(t, period_);
  if (s < 0) s += period_;
  int k = static_cast<int>(std::floor(s / h_));
  k = std::clamp(k, 0, n - 1);
  const double a = (s - k * h_) / h_, b = 1 - a;  // local coordinate in [0, 1]
  const int k1 = (k + 1) % n;
  return b * y_[k] + a * y_[k1] + (h_ * h_ / 6) * ((b * b * b - b) * m_[k] + (a * a * a - a) * m_[k1]);
}

namespace {

struct LinearData {
  const std::function<Eigen::MatrixXd(double)>* A;
  Eigen::Index n;
};

// Phi' = A(t) Phi, Phi stored column-major in the CVODE vector.
int phi_rhs(sunrealtype t, N_Vector y, N_Vector ydot, void* user) {
  const auto* d = static_cast<const LinearData*>(user);
  try {
    const Eigen::Map<const Eigen::MatrixXd> Phi(N_VGetArrayPointer(y), d->n, d->n);
    Eigen::Map<Eigen::MatrixXd> dPhi(N_VGetArrayPointer(ydot), d->n, d->n);
    dPhi.noalias() = (*d->A)(t) * Phi;
  } catch (...) {
    return -1;  // unrecoverable: CVode returns CV_RHSFUNC_FAIL
  }
  return 0;
}

struct SundialsContext {
  SUNContext ctx = nullptr;
  SundialsContext() {
#if SUNDIALS_VERSION_MAJOR >= 7
    if (SUNContext_Create(SUN_COMM_NULL, &ctx) != 0) throw SolveError("SUNContext_Create failed");
#else
    if (SUNContext_Create(nullptr, &ctx) != 0) throw SolveError("SUNContext_Create failed");
#endif
  }
  ~SundialsContext() { SUNContext_Free(&ctx); }
  SundialsContext(const SundialsContext&) = delete;
  SundialsContext& operator=(const SundialsContext&) = delete;
};

void check(int flag, const char* what) {
  if (flag < 0) throw SolveError(fmt::format("CVODE {} failed (flag {})", what, flag));
}

}  // namespace

MonodromyResult monodromy(const std::function<Eigen::MatrixXd(double)>& A, Eigen::Index n, double period,
                          const MonodromyOptions& o) {
  if (n < 1 || !(period > 0)) throw SolveError("monodromy: need n >= 1 and a positive period");
  SundialsContext sc;
  const sunindextype len = static_cast<sunindextype>(n * n);
  N_Vector y = N_VNew_Serial(len, sc.ctx);
  Eigen::Map<Eigen::MatrixXd>(N_VGetArrayPointer(y), n, n).setIdentity();
  void* mem = CVodeCreate(CV_ADAMS, sc.ctx);
  // Adams-Moulton with fixed-point iteration: the hover systems are not stiff over one wingbeat.
  SUNNonlinearSolver nls = SUNNonlinSol_FixedPoint(y, 0, sc.ctx);
  LinearData data{&A, n};
  MonodromyResult out;
  try {
    check(CVodeInit(mem, phi_rhs, 0.0, y), "init");
    check(CVodeSStolerances(mem, o.rtol, o.atol), "tolerances");
    check(CVodeSetNonlinearSolver(mem, nls), "nonlinear solver");
    check(CVodeSetUserData(mem, &data), "user data");
    check(CVodeSetMaxNumSteps(mem, o.max_steps), "max steps");
    check(CVodeSetStopTime(mem, period), "stop time");
    sunrealtype t = 0;
    check(CVode(mem, period, y, &t, CV_NORMAL), "integration of Phi' = A(t) Phi");
    long steps = 0, evals = 0;
    CVodeGetNumSteps(mem, &steps);
    CVodeGetNumRhsEvals(mem, &evals);
    out.steps = steps;
    out.rhs_evaluations = evals;
    out.monodromy = Eigen::Map<const Eigen::MatrixXd>(N_VGetArrayPointer(y), n, n);
  } catch (...) {
    CVodeFree(&mem);
    SUNNonlinSolFree(nls);
    N_VDestroy(y);
    throw;
  }
  CVodeFree(&mem);
  SUNNonlinSolFree(nls);
  N_VDestroy(y);
  return out;
}

Eigen::VectorXd nondimensional_state_scale(const std::vector<std::string>& states, const ReferenceQuantities& ref) {
  Eigen::VectorXd s(static_cast<Eigen::Index>(states.size()));
  for (std::size_t i = 0; i < states.size(); ++i) {
    const std::string& n = states[i];
    if (n == "u" || n == "v" || n == "w") s(Eigen::Index(i)) = 1 / ref.U;
    else if (n == "p" || n == "q" || n == "r") s(Eigen::Index(i)) = ref.c / ref.U;
    else if (n == "phi" || n == "theta" || n == "psi") s(Eigen::Index(i)) = 1;
    else throw SolveError("nondimensional_state_scale: unknown state '" + n + "'");
  }
  return s;
}

FloquetAnalysis floquet_analysis(const std::string& name, const std::vector<std::string>& state_order,
                                 const Eigen::MatrixXd& M, double period, const Eigen::VectorXd& nd_scale,
                                 const ReferenceQuantities& ref, const ModeOptions& options) {
  const Eigen::Index n = M.rows();
  if (M.cols() != n || nd_scale.size() != n || Eigen::Index(state_order.size()) != n)
    throw SolveError("floquet_analysis: monodromy, scale and state order sizes differ");
  FloquetAnalysis f;
  f.name = name;
  f.state_order = state_order;
  f.period_s = period;
  f.monodromy_si = M;
  f.monodromy_nd = nd_scale.asDiagonal() * M * nd_scale.cwiseInverse().asDiagonal();

  Eigen::EigenSolver<Eigen::MatrixXd> es(f.monodromy_nd);
  if (es.info() != Eigen::Success) throw SolveError("floquet_analysis: eigen-decomposition of the monodromy failed");
  const Eigen::VectorXcd mu = es.eigenvalues();
  const Eigen::MatrixXcd V = es.eigenvectors();
  std::vector<Eigen::Index> order(static_cast<std::size_t>(n));
  for (Eigen::Index i = 0; i < n; ++i) order[std::size_t(i)] = i;
  std::sort(order.begin(), order.end(), [&](Eigen::Index a, Eigen::Index b) {
    if (std::abs(mu(a)) != std::abs(mu(b))) return std::abs(mu(a)) > std::abs(mu(b));
    return mu(a).imag() > mu(b).imag();
  });
  const double tc = ref.time_scale();
  const double period_nd = period / tc;
  Eigen::VectorXcd lam_nd(n);
  bool negative_real = false;
  for (Eigen::Index i = 0; i < n; ++i) {
    const cplx m = mu(i);
    if (std::abs(m) == 0) throw SolveError("floquet_analysis: zero multiplier (singular monodromy)");
    if (m.real() < 0 && std::abs(m.imag()) <= options.imaginary_tolerance * std::abs(m)) negative_real = true;
    lam_nd(i) = std::log(m) / period_nd;
  }
  for (Eigen::Index i : order) {
    f.multipliers.push_back(mu(i));
    f.exponents_nd.push_back(lam_nd(i));
    f.exponents_per_s.push_back(lam_nd(i) / tc);
    f.exponents_per_wingbeat.push_back(std::log(mu(i)));
  }
  if (negative_real) {
    f.notices.push_back("a multiplier lies on the negative real axis (a period-doubling, subharmonic mode): the "
                        "exponent matrix has no real logarithm, so modes are not labelled; multipliers and "
                        "exponents are reported");
    return f;
  }
  // B = V diag(lambda) V^-1: real (conjugate multipliers have conjugate principal logarithms).
  const Eigen::MatrixXcd Bc = V * lam_nd.asDiagonal() * V.inverse();
  const double scale = std::max(Bc.cwiseAbs().maxCoeff(), 1e-300);
  if (Bc.imag().cwiseAbs().maxCoeff() > 1e-8 * scale) {
    f.notices.push_back("the Floquet exponent matrix is not real to 1e-8 (defective monodromy?): modes not labelled");
    return f;
  }
  StateSpace sys{name + " Floquet exponent matrix", state_order, Bc.real(), {}, {}};
  f.modes = analyse_modes(sys, ref, options);
  return f;
}

}  // namespace flapstab
