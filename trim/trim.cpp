// Hover trim: Ipopt (constrained NLP, finite-difference Jacobian, quasi-Newton Hessian) or NLopt.
#include "trim/trim.hpp"

#include <IpIpoptApplication.hpp>
#include <IpTNLP.hpp>
#include <cmath>
#include <fmt/format.h>
#include <mutex>
#include <nlopt.hpp>

#include "core/errors.hpp"
#include "trim/parameters.hpp"

namespace flapstab {

namespace {

// Ipopt 3.11 with MUMPS is not thread-safe (Debian 12's coinor-libipopt with MUMPS): every solve holds this lock.
std::mutex ipopt_mutex;

// Scaled residuals r(x) and objective f(x) of the trim problem, with a one-point cache.
class TrimProblem {
 public:
  TrimProblem(const Case& c, const AeroModel& model, const TrimParameterization& par, bool all_six)
      : case_(c), model_(model), par_(par), all_six_(all_six) {
    weight_ = c.insect.weight();
    length_ = c.insect.wing.length;
    // Fixed scale for the power objective: weight x the initial wing-tip speed scale.
    power_scale_ = weight_ * 2 * c.kinematics.stroke_amplitude() * c.kinematics.frequency_hz * length_;
    for (std::size_t i = 0; i < par.size(); ++i) {
      lo_.push_back(par.specs()[i].lower);
      hi_.push_back(par.specs()[i].upper);
    }
  }
  std::size_t n() const { return par_.size(); }
  std::size_t m() const { return all_six_ ? 6 : 3; }
  const std::vector<double>& lower() const { return lo_; }
  const std::vector<double>& upper() const { return hi_; }
  int runs() const { return runs_; }

  struct Eval {
    Eigen::VectorXd r;   // scaled residuals
    double power = 0;
    Wrench mean;
  };
  const Eval& eval(const double* x) {
    std::vector<double> v(x, x + n());
    if (v == cached_x_) return cached_;
    ++runs_;
    const Kinematics k = par_.apply(v);
    const WrenchHistory h = model_.run(case_.insect, k, BodyMotion{}, AeroRunOptions{});
    const WrenchSample s = h.mean_sample();
    Eval e;
    e.mean = s.total();
    e.power = s.power;
    const Vec3 f = (e.mean.force + Vec3(0, 0, weight_)) / weight_;
    const Vec3 mo = e.mean.moment / (weight_ * length_);
    e.r.resize(Eigen::Index(m()));
    if (all_six_) e.r << f, mo;
    else e.r << f.x(), f.z(), mo.y();
    cached_x_ = v;
    cached_ = e;
    return cached_;
  }
  // Objective: least change (bounds-normalised) or power / (weight x reference speed).
  double objective(const double* x) {
    if (case_.trim.objective == "min-power") return eval(x).power / power_scale_;
    double s = 0;
    for (std::size_t i = 0; i < n(); ++i) {
      const double d = (x[i] - par_.initial()[i]) / (hi_[i] - lo_[i]);
      s += d * d;
    }
    return s;
  }
  double step(std::size_t i) const { return 1e-6 * (hi_[i] - lo_[i]); }
  // Central-difference Jacobian of the residuals, m x n.
  Eigen::MatrixXd jacobian(const double* x) {
    Eigen::MatrixXd J(static_cast<Eigen::Index>(m()), static_cast<Eigen::Index>(n()));
    std::vector<double> xp(x, x + n());
    for (std::size_t j = 0; j < n(); ++j) {
      const double h = step(j), x0 = xp[j];
      xp[j] = x0 + h;
      const Eigen::VectorXd rp = eval(xp.data()).r;
      xp[j] = x0 - h;
      const Eigen::VectorXd rm = eval(xp.data()).r;
      xp[j] = x0;
      J.col(Eigen::Index(j)) = (rp - rm) / (2 * h);
    }
    return J;
  }
  void gradient(const double* x, double* g) {
    std::vector<double> xp(x, x + n());
    for (std::size_t j = 0; j < n(); ++j) {
      if (case_.trim.objective != "min-power") {
        g[j] = 2 * (x[j] - par_.initial()[j]) / ((hi_[j] - lo_[j]) * (hi_[j] - lo_[j]));
        continue;
      }
      const double h = step(j), x0 = xp[j];
      xp[j] = x0 + h;
      const double fp = objective(xp.data());
      xp[j] = x0 - h;
      const double fm = objective(xp.data());
      xp[j] = x0;
      g[j] = (fp - fm) / (2 * h);
    }
  }

 private:
  const Case& case_;
  const AeroModel& model_;
  const TrimParameterization& par_;
  bool all_six_;
  double weight_ = 0, length_ = 0, power_scale_ = 1;
  std::vector<double> lo_, hi_;
  std::vector<double> cached_x_;
  Eval cached_;
  int runs_ = 0;
};

class IpoptTrim : public Ipopt::TNLP {
 public:
  IpoptTrim(TrimProblem& p, std::vector<double> x0) : p_(p), x_(std::move(x0)) {}
  bool get_nlp_info(Ipopt::Index& n, Ipopt::Index& m, Ipopt::Index& nnz_jac, Ipopt::Index& nnz_h,
                    IndexStyleEnum& style) override {
    n = Ipopt::Index(p_.n());
    m = Ipopt::Index(p_.m());
    nnz_jac = n * m;
    nnz_h = 0;
    style = C_STYLE;
    return true;
  }
  bool get_bounds_info(Ipopt::Index n, Ipopt::Number* xl, Ipopt::Number* xu, Ipopt::Index m, Ipopt::Number* gl,
                       Ipopt::Number* gu) override {
    for (Ipopt::Index i = 0; i < n; ++i) xl[i] = p_.lower()[std::size_t(i)], xu[i] = p_.upper()[std::size_t(i)];
    for (Ipopt::Index i = 0; i < m; ++i) gl[i] = gu[i] = 0;
    return true;
  }
  bool get_starting_point(Ipopt::Index n, bool, Ipopt::Number* x, bool, Ipopt::Number*, Ipopt::Number*,
                          Ipopt::Index, bool, Ipopt::Number*) override {
    for (Ipopt::Index i = 0; i < n; ++i) x[i] = x_[std::size_t(i)];
    return true;
  }
  bool eval_f(Ipopt::Index, const Ipopt::Number* x, bool, Ipopt::Number& f) override {
    f = p_.objective(x);
    return std::isfinite(f);
  }
  bool eval_grad_f(Ipopt::Index, const Ipopt::Number* x, bool, Ipopt::Number* g) override {
    p_.gradient(x, g);
    return true;
  }
  bool eval_g(Ipopt::Index, const Ipopt::Number* x, bool, Ipopt::Index m, Ipopt::Number* g) override {
    const auto& r = p_.eval(x).r;
    for (Ipopt::Index i = 0; i < m; ++i) g[i] = r(i);
    return r.allFinite();
  }
  bool eval_jac_g(Ipopt::Index n, const Ipopt::Number* x, bool, Ipopt::Index m, Ipopt::Index, Ipopt::Index* iRow,
                  Ipopt::Index* jCol, Ipopt::Number* values) override {
    if (!values) {
      for (Ipopt::Index i = 0, k = 0; i < m; ++i)
        for (Ipopt::Index j = 0; j < n; ++j, ++k) iRow[k] = i, jCol[k] = j;
      return true;
    }
    const Eigen::MatrixXd J = p_.jacobian(x);
    for (Ipopt::Index i = 0, k = 0; i < m; ++i)
      for (Ipopt::Index j = 0; j < n; ++j, ++k) values[k] = J(i, j);
    return J.allFinite();
  }
  bool intermediate_callback(Ipopt::AlgorithmMode, Ipopt::Index iter, Ipopt::Number, Ipopt::Number, Ipopt::Number,
                             Ipopt::Number, Ipopt::Number, Ipopt::Number, Ipopt::Number, Ipopt::Number,
                             Ipopt::Index, const Ipopt::IpoptData*, Ipopt::IpoptCalculatedQuantities*) override {
    iterations = int(iter);
    return true;
  }
  void finalize_solution(Ipopt::SolverReturn, Ipopt::Index n, const Ipopt::Number* x, const Ipopt::Number*,
                         const Ipopt::Number*, Ipopt::Index, const Ipopt::Number*, const Ipopt::Number*,
                         Ipopt::Number, const Ipopt::IpoptData*, Ipopt::IpoptCalculatedQuantities*) override {
    x_.assign(x, x + n);
  }
  const std::vector<double>& solution() const { return x_; }
  int iterations = 0;

 private:
  TrimProblem& p_;
  std::vector<double> x_;
};

std::vector<double> solve_ipopt(TrimProblem& p, const std::vector<double>& x0, const TrimSettings& s, int& iterations,
                                std::string& message) {
  std::lock_guard<std::mutex> lock(ipopt_mutex);
  Ipopt::SmartPtr<IpoptTrim> nlp = new IpoptTrim(p, x0);
  Ipopt::SmartPtr<Ipopt::IpoptApplication> app = IpoptApplicationFactory();
  app->Options()->SetIntegerValue("print_level", 0);
  app->Options()->SetStringValue("sb", "yes");
  app->Options()->SetStringValue("hessian_approximation", "limited-memory");
  // The equations (constraints) are held tighter than the acceptance test in trim_hover; optimality
  // of the objective only to 1e-8, the level finite-difference gradients can resolve.
  app->Options()->SetNumericValue("tol", 1e-8);
  app->Options()->SetNumericValue("dual_inf_tol", 1e-8);
  app->Options()->SetNumericValue("constr_viol_tol", 0.1 * s.tolerance);
  app->Options()->SetNumericValue("acceptable_tol", 1e-6);
  app->Options()->SetNumericValue("acceptable_constr_viol_tol", 0.1 * s.tolerance);
  app->Options()->SetStringValue("nlp_scaling_method", "none");
  app->Options()->SetNumericValue("bound_relax_factor", 0.0);
  app->Options()->SetIntegerValue("max_iter", s.max_iterations);
  if (app->Initialize() != Ipopt::Solve_Succeeded) throw SolveError("Ipopt failed to initialise");
  const Ipopt::ApplicationReturnStatus st = app->OptimizeTNLP(Ipopt::GetRawPtr(nlp));
  iterations = nlp->iterations;
  switch (st) {
    case Ipopt::Solve_Succeeded: message = "Ipopt: optimal solution found"; break;
    case Ipopt::Solved_To_Acceptable_Level: message = "Ipopt: solved to acceptable level"; break;
    case Ipopt::Infeasible_Problem_Detected: message = "Ipopt: the trim is infeasible within the parameter bounds"; break;
    case Ipopt::Maximum_Iterations_Exceeded: message = "Ipopt: maximum iterations exceeded"; break;
    default: message = fmt::format("Ipopt: failed with status {}", int(st));
  }
  return nlp->solution();
}

std::vector<double> solve_nlopt(TrimProblem& p, const std::vector<double>& x0, const TrimSettings& s, int& iterations,
                                std::string& message) {
  const unsigned n = unsigned(p.n());
  const bool square = p.n() == p.m();
  // Square systems: minimise |r|^2 with BOBYQA (quadratic models, no derivatives). Otherwise COBYLA
  // with the residuals as equality constraints.
  nlopt::opt opt(square ? nlopt::LN_BOBYQA : nlopt::LN_COBYLA, n);
  opt.set_lower_bounds(p.lower());
  opt.set_upper_bounds(p.upper());
  std::vector<double> step(n);
  for (unsigned i = 0; i < n; ++i) step[i] = 0.05 * (p.upper()[i] - p.lower()[i]);
  opt.set_initial_step(step);
  int evals = 0;
  struct Ctx { TrimProblem* p; int* evals; std::size_t k; };
  Ctx ctx{&p, &evals, 0};
  if (square) {
    opt.set_min_objective([](const std::vector<double>& x, std::vector<double>&, void* d) {
      auto* c = static_cast<Ctx*>(d);
      ++*c->evals;
      return c->p->eval(x.data()).r.squaredNorm();
    }, &ctx);
    opt.set_stopval(0.01 * s.tolerance * s.tolerance);
  } else {
    opt.set_min_objective([](const std::vector<double>& x, std::vector<double>&, void* d) {
      auto* c = static_cast<Ctx*>(d);
      ++*c->evals;
      return c->p->objective(x.data());
    }, &ctx);
    std::vector<Ctx> cons(p.m(), ctx);
    for (std::size_t k = 0; k < p.m(); ++k) {
      cons[k].k = k;
    }
    static thread_local std::vector<Ctx> keep;
    keep = cons;
    for (auto& c : keep)
      opt.add_equality_constraint([](const std::vector<double>& x, std::vector<double>&, void* d) {
        auto* c = static_cast<Ctx*>(d);
        return c->p->eval(x.data()).r(Eigen::Index(c->k));
      }, &c, s.tolerance);
  }
  opt.set_xtol_rel(1e-15);
  opt.set_ftol_abs(0);
  opt.set_maxeval(std::max(50 * s.max_iterations, 2000));
  std::vector<double> x = x0;
  double f = 0;
  try {
    const nlopt::result r = opt.optimize(x, f);
    message = fmt::format("NLopt {}: result code {}", opt.get_algorithm_name(), int(r));
  } catch (const std::exception& e) {
    message = fmt::format("NLopt {}: {}", opt.get_algorithm_name(), e.what());
  }
  iterations = evals;
  return x;
}

}  // namespace

std::vector<std::string> TrimResult::active_bounds() const {
  std::vector<std::string> out;
  for (std::size_t i = 0; i < parameters.size(); ++i) {
    const auto& p = parameters[i];
    const double tol = 1e-6 * std::max(1.0, p.upper - p.lower);
    if (p.value <= p.lower + tol || p.value >= p.upper - tol)
      out.push_back(fmt::format("trim.parameter[{}] ({}) at its {} bound {:g} {}", i, p.name,
                                p.value <= p.lower + tol ? "lower" : "upper", p.value <= p.lower + tol ? p.lower : p.upper,
                                p.unit));
  }
  return out;
}

TrimResult trim_hover(const Case& c, const AeroModel& model) {
  const auto& specs = c.trim.parameters;
  if (specs.empty())
    throw InputError(c.path, "trim.parameter", "no trim parameters given",
                     "[[trim.parameter]] entries naming the free parameters");
  const TrimParameterization par(c.kinematics, specs, c.path);
  const bool all_six = par.one_sided() || !c.kinematics.symmetric();
  TrimProblem problem(c, model, par, all_six);
  if (problem.n() < problem.m())
    throw InputError(c.path, "trim.parameter",
                     fmt::format("{} free parameter(s) cannot balance {} equations", problem.n(), problem.m()),
                     fmt::format("at least {} parameters", problem.m()));
  std::vector<double> x0 = par.initial();
  for (std::size_t i = 0; i < x0.size(); ++i) {
    if (x0[i] < specs[i].lower || x0[i] > specs[i].upper)
      throw InputError(c.path, fmt::format("trim.parameter[{}]", i),
                       fmt::format("the case's own value of {} ({:.6g}) lies outside [lower, upper]", specs[i].name,
                                   x0[i]),
                       "bounds that contain the starting kinematics");
  }
  TrimResult res;
  res.solver = c.trim.solver;
  res.objective = c.trim.objective;
  res.weight = c.insect.weight();
  res.equations = all_six ? std::vector<std::string>{"X", "Y", "Z", "L", "M", "N"}
                          : std::vector<std::string>{"X", "Z", "M"};
  const std::vector<double> x = c.trim.solver == "nlopt" ? solve_nlopt(problem, x0, c.trim, res.iterations, res.message)
                                                         : solve_ipopt(problem, x0, c.trim, res.iterations, res.message);
  const auto& e = problem.eval(x.data());
  res.kinematics = par.apply(x);
  res.force_residual = e.mean.force + Vec3(0, 0, res.weight);
  res.moment_residual = e.mean.moment;
  res.relative_force_residual = res.force_residual.norm() / res.weight;
  res.relative_moment_residual = res.moment_residual.norm() / (res.weight * c.insect.wing.length);
  res.mean_power = e.power;
  res.model_runs = problem.runs();
  // Converged means the equations hold to the requested tolerance, whatever the solver says.
  res.converged = res.relative_force_residual <= c.trim.tolerance &&
                  res.relative_moment_residual <= c.trim.tolerance;
  for (std::size_t i = 0; i < specs.size(); ++i)
    res.parameters.push_back({specs[i].name, specs[i].label(), TrimParameterization::unit(specs[i].name), x[i],
                              x0[i], specs[i].lower, specs[i].upper});
  return res;
}

TrimResult evaluate_at_case_kinematics(const Case& c, const AeroModel& model) {
  TrimResult res;
  res.solved = false;
  res.solver = "none";
  res.objective = "none";
  res.message = "not trimmed (--no-trim): the case's kinematics as given";
  res.weight = c.insect.weight();
  res.equations = c.kinematics.symmetric() ? std::vector<std::string>{"X", "Z", "M"}
                                           : std::vector<std::string>{"X", "Y", "Z", "L", "M", "N"};
  res.kinematics = c.kinematics;
  // The same mean loads as the trim's residuals (TrimProblem::eval): one cycle with the body at rest.
  const WrenchSample s = model.run(c.insect, c.kinematics, BodyMotion{}, AeroRunOptions{}).mean_sample();
  res.model_runs = 1;
  res.force_residual = s.total().force + Vec3(0, 0, res.weight);
  res.moment_residual = s.total().moment;
  res.relative_force_residual = res.force_residual.norm() / res.weight;
  res.relative_moment_residual = res.moment_residual.norm() / (res.weight * c.insect.wing.length);
  res.mean_power = s.power;
  res.converged = res.relative_force_residual <= c.trim.tolerance && res.relative_moment_residual <= c.trim.tolerance;
  return res;
}

}  // namespace flapstab
