#pragma once

#include "common/petsc_handle.h"
#include "fem/terms/term.h"

#include <dolfinx/fem/DirichletBC.h>
#include <dolfinx/fem/Function.h>
#include <array>
#include <memory>
#include <petscmat.h>
#include <vector>

namespace muscle
{
class DisplacementConstraint;

/// The parameters of the generalized-alpha method (Chung & Hulbert 1993) from
/// the spectral radius at infinite frequency rho_inf in [0, 1]: second order,
/// unconditionally stable; rho_inf = 1 damps nothing, rho_inf = 0 annihilates
/// the highest frequencies in one step.
struct AlphaParameters
{
  double alpha_m, alpha_f, beta, gamma;
  explicit AlphaParameters(double rho_inf);
};

/// Structural dynamics M a + r(u, t) = 0 with the generalized-alpha method, as a
/// term of the Newton residual; r is the quasi-static residual (internal minus
/// external forces, contact included).  The forces are averaged between the
/// ends of a step ("TR-like" mid-point, Kuhl & Crisfield 1999), so no residual is
/// needed at an intermediate displacement, and every law, element, tie and
/// contact works unchanged:
///
///   (1 - alpha_f) r(u_{n+1}, t_{n+1}) + alpha_f r_n + M a_m = 0,
///   a_m = (1 - alpha_m) a_{n+1} + alpha_m a_n,
///   a_{n+1} = (u_{n+1} - u_n - h v_n) / (beta h^2) - (1 / (2 beta) - 1) a_n,
///   v_{n+1} = v_n + h ((1 - gamma) a_n + gamma a_{n+1}).
///
/// Newton solves that equation divided by (1 - alpha_f): this term adds
/// (M a_m + alpha_f r_n) / (1 - alpha_f) to the residual and
/// (1 - alpha_m) / ((1 - alpha_f) beta h^2) M to the tangent.  For a linear
/// problem the average is the same as Chung & Hulbert's.
class GeneralizedAlpha : public NonlinearTerm
{
public:
  /// `density` (kg/mm^3) per local cell (owned and ghost); the consistent mass
  /// is assembled once.  The fixed dofs `bcs` keep zero acceleration rows.
  GeneralizedAlpha(std::shared_ptr<dolfinx::fem::Function<double>> u,
                   const std::vector<double>& density,
                   std::vector<std::shared_ptr<const dolfinx::fem::DirichletBC<double>>> bcs,
                   double rho_inf);
  GeneralizedAlpha(const GeneralizedAlpha&) = delete;
  GeneralizedAlpha& operator=(const GeneralizedAlpha&) = delete;

  /// The start at rest or with the velocity of set_velocity(): the initial
  /// acceleration from M a_0 = -r_0, `r0` the nodal forces of the start (the
  /// quasi-static residual without this term; zero: a_0 = 0).  With a
  /// constraint u = T x the mass is reduced the same way.
  void start(const dolfinx::la::Vector<double>& r0,
             const DisplacementConstraint* constraint);

  /// Before start(): the velocity `v` (mm/s) at every free dof (zero at the
  /// fixed ones).
  void set_velocity(std::array<double, 3> v);

  /// Before the solve of a sub-step of length h (from u = u_n).
  void begin_step(double h);
  /// After the solve converged: velocity, acceleration and forces at the new u.
  void accept_step();
  /// After the solve failed: no step under way (the state is that of t_n).
  void reject_step() { _h = 0; }

  void add_residual(Vec F) override;
  void add_jacobian(Mat A) override;

  /// 1/2 v^T M v at the last accepted state (µJ = mN mm; collective).
  double kinetic_energy() const;

  const AlphaParameters& parameters() const { return _p; }
  /// The consistent mass with the fixed dofs' rows and columns empty.
  Mat mass() const { return _M_bc; }
  /// The state a checkpoint keeps next to u: velocity, acceleration, and the
  /// forces r_n of the last accepted step.
  std::vector<std::shared_ptr<dolfinx::fem::Function<double>>> state() const;
  /// After the state was read from a checkpoint: u is u_n.
  void restore();

private:
  /// w = c_u (u - u_n - h v_n) + c_a a_n
  void combine(double c_u, double c_a, Vec w) const;

  std::shared_ptr<dolfinx::fem::Function<double>> _u;
  std::shared_ptr<dolfinx::fem::Function<double>> _v, _a, _r; ///< at t_n
  AlphaParameters _p;
  double _h = 0;
  MatHandle _M;    ///< consistent mass, every row
  MatHandle _M_bc; ///< the same with the fixed dofs' rows and columns zero
  /// the same with the fixed dofs' rows zero, their columns kept: the tangent
  /// of the residual's M a_m in both Newton paths (lifting, F-bar's kept columns)
  MatHandle _M_rows;
  std::vector<char> _free; ///< per owned dof: no boundary condition (a row of mass)
  VecHandle _u_vec, _u_n, _v_vec, _a_vec, _r_vec;
  VecHandle _w, _Mw;
};

} // namespace muscle
