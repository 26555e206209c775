// LTI hover systems (longitudinal, lateral, coupled 6DoF) built from a derivative table.
#include "stability/lti.hpp"

#include <stdexcept>

namespace flapstab {

namespace {

// Force rows (X Y Z) and moment rows (L M N) of the nd table, in the column order u v w p q r.
enum Row { X = 0, Y = 1, Z = 2, L = 3, M = 4, N = 5 };
enum Col { u = 0, v = 1, w = 2, p = 3, q = 4, r = 5 };

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument(what);
}

// Roll and yaw rows of [p', r'] = J^-1 [L, N], J = [[Ixx, -Ixz], [-Ixz, Izz]] (Etkin's body-axis
// moment equations), for derivative column c; with Ixz = 0 exactly L/Ixx and N/Izz.
double roll_row(const Eigen::Matrix<double, 6, 6>& D, const NonDimensionalParameters& nd, int c) {
  if (nd.Ixz == 0) return D(L, c) / nd.Ixx;
  return (nd.Izz * D(L, c) + nd.Ixz * D(N, c)) / (nd.Ixx * nd.Izz - nd.Ixz * nd.Ixz);
}
double yaw_row(const Eigen::Matrix<double, 6, 6>& D, const NonDimensionalParameters& nd, int c) {
  if (nd.Ixz == 0) return D(N, c) / nd.Izz;
  return (nd.Ixz * D(L, c) + nd.Ixx * D(N, c)) / (nd.Ixx * nd.Izz - nd.Ixz * nd.Ixz);
}

}  // namespace

NonDimensionalParameters nondimensional_parameters(const DerivativeTable& t) {
  const auto& ref = t.reference;
  require(ref.U > 0 && ref.c > 0 && ref.S_t > 0 && ref.rho > 0, "reference U, c, S_t and rho must be positive");
  const double mass_scale = 0.5 * ref.rho * ref.S_t * ref.c;      // kg
  const double inertia_scale = mass_scale * ref.c * ref.c;         // kg m^2
  NonDimensionalParameters nd;
  nd.m = t.mass.m / mass_scale;
  nd.Ixx = t.mass.Ixx / inertia_scale;
  nd.Iyy = t.mass.Iyy / inertia_scale;
  nd.Izz = t.mass.Izz / inertia_scale;
  nd.Ixz = t.mass.Ixz / inertia_scale;
  nd.g = ref.g * ref.c / (ref.U * ref.U);
  nd.time_scale_s = ref.time_scale();
  return nd;
}

StateSpace longitudinal_system(const DerivativeTable& t) {
  const auto nd = nondimensional_parameters(t);
  require(nd.m > 0 && nd.Iyy > 0, "longitudinal system needs m > 0 and Iyy > 0");
  const auto& D = t.nd;
  Eigen::MatrixXd A(4, 4);
  A << D(X, u) / nd.m,   D(X, w) / nd.m,   D(X, q) / nd.m,   -nd.g,
       D(Z, u) / nd.m,   D(Z, w) / nd.m,   D(Z, q) / nd.m,   0,
       D(M, u) / nd.Iyy, D(M, w) / nd.Iyy, D(M, q) / nd.Iyy, 0,
       0,                0,                1,                0;
  StateSpace s{"longitudinal", {"u", "w", "q", "theta"}, A, Eigen::MatrixXd::Zero(4, Eigen::Index(t.control.size())), {}};
  for (std::size_t k = 0; k < t.control.size(); ++k) {
    const auto& c = t.control[k].nd;
    s.B.col(Eigen::Index(k)) << c(X) / nd.m, c(Z) / nd.m, c(M) / nd.Iyy, 0;
    s.input_order.push_back(t.control[k].parameter);
  }
  return s;
}

StateSpace lateral_system(const DerivativeTable& t) {
  const auto nd = nondimensional_parameters(t);
  const double det = nd.Ixx * nd.Izz - nd.Ixz * nd.Ixz;
  require(nd.m > 0 && nd.Ixx > 0 && nd.Izz > 0 && det > 0,
          "lateral system needs m > 0 and a positive definite roll-yaw inertia (Ixx, Izz > 0, Ixz^2 < Ixx Izz)");
  const auto& D = t.nd;
  Eigen::MatrixXd A(4, 4);
  A << D(Y, v) / nd.m,     D(Y, p) / nd.m,     D(Y, r) / nd.m,     nd.g,
       roll_row(D, nd, v), roll_row(D, nd, p), roll_row(D, nd, r), 0,
       yaw_row(D, nd, v),  yaw_row(D, nd, p),  yaw_row(D, nd, r),  0,
       0,                  1,                  0,                  0;
  StateSpace s{"lateral", {"v", "p", "r", "phi"}, A, Eigen::MatrixXd::Zero(4, Eigen::Index(t.control.size())), {}};
  for (std::size_t k = 0; k < t.control.size(); ++k) {
    Eigen::Matrix<double, 6, 6> Dc = Eigen::Matrix<double, 6, 6>::Zero();
    Dc.col(0) = t.control[k].nd;
    s.B.col(Eigen::Index(k)) << Dc(Y, 0) / nd.m, roll_row(Dc, nd, 0), yaw_row(Dc, nd, 0), 0;
    s.input_order.push_back(t.control[k].parameter);
  }
  return s;
}

StateSpace coupled_system(const DerivativeTable& t) {
  const auto nd = nondimensional_parameters(t);
  const double det = nd.Ixx * nd.Izz - nd.Ixz * nd.Ixz;
  require(nd.m > 0 && nd.Iyy > 0 && nd.Ixx > 0 && nd.Izz > 0 && det > 0,
          "6DoF system needs m > 0 and a positive definite inertia matrix");
  const auto& D = t.nd;
  // States 0..5 are u v w p q r (the table's column order), then phi (6) and theta (7).
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(8, 8);
  for (int c = 0; c < 6; ++c) {
    A(0, c) = D(X, c) / nd.m;
    A(1, c) = D(Y, c) / nd.m;
    A(2, c) = D(Z, c) / nd.m;
    A(3, c) = roll_row(D, nd, c);
    A(4, c) = D(M, c) / nd.Iyy;
    A(5, c) = yaw_row(D, nd, c);
  }
  A(0, 7) = -nd.g;  // u' = ... - g+ theta
  A(1, 6) = nd.g;   // v' = ... + g+ phi
  A(6, 3) = 1;      // phi' = p
  A(7, 4) = 1;      // theta' = q
  StateSpace s{"6dof", {"u", "v", "w", "p", "q", "r", "phi", "theta"}, A,
               Eigen::MatrixXd::Zero(8, Eigen::Index(t.control.size())), {}};
  for (std::size_t k = 0; k < t.control.size(); ++k) {
    Eigen::Matrix<double, 6, 6> Dc = Eigen::Matrix<double, 6, 6>::Zero();
    Dc.col(0) = t.control[k].nd;
    s.B.col(Eigen::Index(k)) << Dc(X, 0) / nd.m, Dc(Y, 0) / nd.m, Dc(Z, 0) / nd.m, roll_row(Dc, nd, 0),
        Dc(M, 0) / nd.Iyy, yaw_row(Dc, nd, 0), 0, 0;
    s.input_order.push_back(t.control[k].parameter);
  }
  return s;
}

}  // namespace flapstab
