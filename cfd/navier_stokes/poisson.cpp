// Flexible preconditioned conjugate gradients for the MAC pressure Poisson equation (see poisson.hpp).
#include "cfd/navier_stokes/poisson.hpp"
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include "cfd/navier_stokes/krylov.hpp"
#include "cfd/navier_stokes/poisson_hypre.hpp"

namespace flapstab::ns {

double PoissonStats::factor() const {
  if (cycles == 0 || initial_residual == 0) return 0;
  return std::pow(residual / initial_residual, 1.0 / cycles);
}

namespace {
ScalarBCs local_bcs(ScalarBCs bc, const Slab& s) {
  if (s.cut_lo) bc[std::size_t(face(2, 0))] = ScalarBC::interface;
  if (s.cut_hi) bc[std::size_t(face(2, 1))] = ScalarBC::interface;
  return bc;
}
}  // namespace

Poisson::Poisson(const Grid& g, const ScalarBCs& bc, std::shared_ptr<const Decomposition> dec)
    : dec_(dec ? std::move(dec) : std::make_shared<const Decomposition>()), slab_(Multigrid::rank_slab(g, *dec_)),
      bc_(local_bcs(bc, slab_)), L_(g.slice_z(slab_), bc_), mg_(g, bc, dec_), z_(L_.s), p_(L_.s), q_(L_.s),
      whole_nz_(g.axis[2].n), z_periodic_(g.axis[2].periodic) {
  singular_ = std::none_of(bc.begin(), bc.end(), [](ScalarBC b) { return b == ScalarBC::dirichlet; });
}

void Poisson::ghosts(Field& x) const {
  fill_ghosts(x, bc_);
  dec_->exchange(x, slab_);
}

Poisson::~Poisson() = default;
Poisson::Poisson(Poisson&&) noexcept = default;
Poisson& Poisson::operator=(Poisson&&) noexcept = default;

std::size_t Poisson::bytes() const {
  std::size_t b = 3 * L_.s.size() * sizeof(real);
  for (int l = 0; l < mg_.levels(); ++l) b += 3 * mg_.level_shape(l).size() * sizeof(float);
  return b;
}

// FCG(1) (Notay 2000, SIAM J Sci Comput 22:1444) in the volume-weighted inner product <u, w> = sum V u w, in
// which L is self-adjoint: z = M(r); beta = -<z, q>/<p, q>; p = z + beta p; q = L p; alpha = <p, r>/<p, q>;
// x += alpha p; r -= alpha q. The flexible form tolerates the V-cycle's slight asymmetry and single precision.
PoissonStats Poisson::solve(Field& x, Field& b, const PoissonOptions& opt, bool guess) {
  const Shape& s = L_.s;
  if (!(x.shape() == s) || !(b.shape() == s)) throw std::invalid_argument("poisson: field shape differs from the grid");
  double sum, vol, bmax;
  const Decomposition& D = *dec_;
  auto sum_and_max = [&] {
    krylov::sum_and_max(L_, b.data(), sum, vol, bmax);
    double sv[2] = {sum, vol};
    D.sum(sv, 2);
    sum = sv[0];
    vol = sv[1];
    bmax = D.max(bmax);
  };
  sum_and_max();
  // A singular problem needs a b of zero mean; remove what round-off or inconsistent boundary data left.
  if (singular_ && std::abs(sum / vol) > 1e-14 * bmax) {
    krylov::add_constant(L_, b.data(), -sum / vol);
    sum_and_max();
  }
  const double target = std::max(opt.rtol * bmax, opt.atol);
  PoissonStats st;
  st.target = target;
  st.residual = st.initial_residual = bmax;
  Field& r = b;
  if (guess) {  // r = b - L x
    ghosts(x);
    st.residual = st.initial_residual = D.max(krylov::residual(L_, x.data(), r.data()));
  }
  if (opt.backend == PoissonBackend::hypre) {
    // hypre's PCG stops on the 2-norm of the volume-weighted residual; the max-norm target is checked here, and
    // the solve repeated from its result with a tolerance ten times tighter while it is missed (at most twice).
    if (!hypre_)
      hypre_ = D.distributed() ? std::make_unique<HyprePoisson>(L_, &slab_, whole_nz_, z_periodic_, D.communicator())
                               : std::make_unique<HyprePoisson>(L_);
    if (!guess) x.fill(0);
    Field dx(s);
    double tol = opt.rtol;
    for (int attempt = 0; attempt < 3 && st.residual > target && st.cycles < opt.max_cycles; ++attempt, tol *= 0.1) {
      dx.fill(0);
      st.cycles += hypre_->solve(dx, r, tol, opt.max_cycles - st.cycles, false);
      ghosts(dx);
      st.residual = D.max(krylov::residual(L_, dx.data(), r.data()));  // r -= L dx
      for (std::size_t n = 0; n < s.size(); ++n) x.data()[n] += dx.data()[n];
    }
    st.converged = st.residual <= target;
    ghosts(x);
    return st;
  }
  // Plain multigrid iterations (x += M r, r -= L M r: one fused pass after the V-cycle) while each cuts the
  // residual at least `stationary_factor`-fold; from the first that does not, FCG takes over from (x, r).
  bool krylov = opt.stationary_factor <= 0;
  int fcg = 0;  // FCG iterations so far
  double pq = 1;
  while (st.residual > target && st.cycles < opt.max_cycles) {
    const bool first = st.cycles == 0 && !guess;
    mg_.vcycle(r, z_, opt.pre_sweeps, opt.post_sweeps);
    if (!krylov) {
      ghosts(z_);
      const double before = st.residual;
      st.residual = D.max(krylov::correct(L_, x.data(), r.data(), z_.data(), first));
      ++st.cycles;
      ++st.stationary;
      if (st.residual > opt.stationary_factor * before) krylov = true;
      continue;
    }
    if (fcg == 0)
      std::swap(p_, z_);
    else
      krylov::axpy_into(L_, z_.data(), -D.sum(krylov::inner(L_, z_.data(), q_.data())) / pq, p_.data());
    ghosts(p_);
    double pr;
    krylov::apply_and_dot(L_, p_.data(), q_.data(), r.data(), pq, pr);
    double dots[2] = {pq, pr};
    D.sum(dots, 2);
    pq = dots[0];
    pr = dots[1];
    const double alpha = pr / pq;
    if (!std::isfinite(alpha)) {  // breakdown (a zero or non-finite search direction): report, do not update
      st.breakdown = true;
      break;
    }
    st.residual = D.max(krylov::update(L_, x.data(), r.data(), p_.data(), q_.data(), alpha, first));
    ++st.cycles;
    ++fcg;
  }
  if (st.cycles == 0 && !guess) x.fill(0);
  st.converged = !st.breakdown && st.residual <= target;
  ghosts(x);
  return st;
}

void Poisson::apply(Field& x, Field& Lx) const {
  const Shape& s = L_.s;
  if (!(x.shape() == s) || !(Lx.shape() == s)) throw std::invalid_argument("poisson: field shape differs from the grid");
  ghosts(x);
  for (int k = 1; k <= s.nz; ++k)
    for (int j = 1; j <= s.ny; ++j) {
      const StencilRow<real> r(L_, x.data(), j, k);
      for (int i = 1; i <= s.nx; ++i) Lx(i, j, k) = r.apply(i);
    }
}

double Poisson::residual_norm(Field& x, const Field& b) const {
  Field Lx(x.shape());
  apply(x, Lx);
  double m = 0;
  const Shape& s = x.shape();
  for (int k = 1; k <= s.nz; ++k)
    for (int j = 1; j <= s.ny; ++j)
      for (int i = 1; i <= s.nx; ++i) m = std::max(m, std::abs(b(i, j, k) - Lx(i, j, k)));
  return dec_->max(m);
}

double mean(const Grid& g, const Field& f) {
  double sum = 0, vol = 0;
  const Shape s = g.shape();
  for (int k = 1; k <= s.nz; ++k)
    for (int j = 1; j <= s.ny; ++j)
      for (int i = 1; i <= s.nx; ++i) {
        const double v = g.volume(i, j, k);
        sum += v * f(i, j, k);
        vol += v;
      }
  return sum / vol;
}

}  // namespace flapstab::ns
