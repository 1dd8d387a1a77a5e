#pragma once

#include "common/petsc_handle.h"
#include "fem/constraints/boundary.h"
#include "fem/elements/muscle_problem.h"
#include "fem/terms/term.h"

#include <dolfinx/fem/DirichletBC.h>
#include <dolfinx/la/Vector.h>
#include <functional>
#include <memory>
#include <span>
#include <vector>

namespace muscle
{
class DisplacementConstraint;

/// The displacement part of every Newton system: a body of parts sharing one
/// displacement, its Dirichlet conditions, the loads (forms of their own) and
/// the terms that are no form (contact, inertia), and a linear constraint
/// u = T x (uniform-axial, tie).  It assembles the displacement residual b and
/// tangent A in the full layout and forms T^T A T; each formulation
/// (formulation.h) builds its unknowns and its Newton system from these.
class DisplacementSystem
{
public:
  DisplacementSystem(std::vector<MuscleProblem*> parts, DirichletBCs bcs,
                     std::shared_ptr<const DisplacementConstraint> constraint);
  DisplacementSystem(const DisplacementSystem&) = delete;
  DisplacementSystem& operator=(const DisplacementSystem&) = delete;

  const std::vector<MuscleProblem*>& parts() const { return _parts; }
  /// The first part: the displacement, its space and mesh.
  MuscleProblem& problem() const { return *_parts.front(); }
  const DirichletBCs& bcs() const { return _bcs; }
  const DisplacementConstraint* constraint() const { return _constraint.get(); }
  MPI_Comm comm() const;

  /// Forms added to every residual and Jacobian (external loads, terms/loads.h).
  void add_forms(std::vector<std::shared_ptr<const dolfinx::fem::Form<double>>> residuals,
                 std::vector<std::shared_ptr<const dolfinx::fem::Form<double>>> jacobians);
  /// A term added to every residual and Jacobian (contact, inertia).
  void add_term(std::shared_ptr<NonlinearTerm> term);
  const std::vector<std::shared_ptr<NonlinearTerm>>& terms() const { return _terms; }

  /// b = the displacement residual at u: every part, the loads and terms,
  /// lifted, Dirichlet rows u - g (owned entries complete).
  void residual();
  /// The same without lifting, the parts' share added by `add_parts` into b
  /// (unrolled, owned and ghost entries, not scattered): a Newton matrix that
  /// keeps its Dirichlet columns (F-bar's cell unknowns).
  void unlifted_residual(const std::function<void(std::span<double>)>& add_parts);
  /// The residual b (full layout, ghosts).
  const dolfinx::la::Vector<double>& b() const { return _b; }
  /// F = T^T b or b's owned part: the residual of the unknowns Newton solves for.
  void restrict_residual(Vec F) const;

  /// A vector of the displacement unknowns Newton solves for: u's owned dofs, or
  /// under the constraint the reduced x.
  VecHandle create_unknowns() const;
  /// x = the current u's unknowns.
  void get_unknowns(Vec x) const;
  /// u = T x, or x itself (ghosts updated).
  void set_unknowns(Vec x);

  /// A = the displacement tangent: the parts' Jacobians, then close_jacobian().
  void assemble_jacobian();
  /// A (its entries zeroed before the formulation adds the parts' share).
  Mat A() const { return _A; }
  /// A += the loads' and the terms' tangents, identity rows of the Dirichlet
  /// dofs, final assembly; matrix_norm() from it.
  void close_jacobian();
  /// Infinity norm of the last A, NaN when an entry is not finite (a
  /// formulation marks its own blocks' overflow with set_matrix_norm(NaN)).
  double matrix_norm() const { return _matrix_norm; }
  void set_matrix_norm(double norm) { _matrix_norm = norm; }

  /// T^T A T (null before the first reduce or without a constraint).
  Mat reduced() const { return _A_red; }
  /// reduced() = T^T A T: made at the first call, then recomputed in place, or
  /// made anew when A gained nonzeros (contact couples new dofs).
  void reduce();
  /// Forget T^T A T (the penalty split forms it only on request).
  void drop_reduced();
  /// Block size of T^T A T (GAMG: 3 where its unknowns are whole nodes).
  void set_reduced_block_size(int bs) { _reduced_bs = bs; }
  /// y = T^T A w (w full layout, T x already in it): the reduced product without T^T A T.
  void multiply_reduced(const dolfinx::la::Vector<double>& w, Vec y);

  /// The residual without boundary conditions into `b` (owned + ghost entries,
  /// ghosts accumulated): nodal forces, e.g. reactions.
  void assemble_nodal_forces(dolfinx::la::Vector<double>& b) const;
  /// Activation kernels of every part at the current displacement (the failures
  /// summed over the ranks).
  KernelStatus update_activation();
  /// Smallest J over the quadrature points of every part's local cells.
  std::pair<double, std::int32_t> min_jacobian_determinant() const;
  /// Largest |g - u| over the Dirichlet dofs (all ranks): whether boundary values moved.
  double boundary_change() const;

private:
  void add_term_residuals(std::span<double> b) const;

  std::vector<MuscleProblem*> _parts;
  DirichletBCs _bcs;
  std::shared_ptr<const DisplacementConstraint> _constraint;
  std::vector<std::shared_ptr<const dolfinx::fem::Form<double>>> _extra_residuals,
      _extra_jacobians;
  std::vector<std::shared_ptr<NonlinearTerm>> _terms;
  dolfinx::la::Vector<double> _b;
  MatHandle _A;
  MatHandle _A_red;  ///< T^T A T
  MatHandle _ptap;   ///< T^T A T made anew after A gained nonzeros, copied into J
  VecHandle _b_petsc; ///< wraps _b
  VecHandle _u_petsc; ///< wraps u's owned part
  VecHandle _F_full;  ///< owned part of _b as a plain vector (for T^T b)
  VecHandle _term_F;
  VecHandle _full_tmp; ///< A w of multiply_reduced
  PetscObjectState _reduced_state = -1;
  int _reduced_bs = 1;
  double _matrix_norm = 0;
};

} // namespace muscle
