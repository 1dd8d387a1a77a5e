#pragma once

#include <cstdint>
#include <dolfinx/la/Vector.h>
#include <petscmat.h>
#include <vector>

namespace muscle
{

/// A linear constraint on the displacement, enforced exactly by elimination:
/// u = T x with x the reduced unknowns, the Newton system T^T J T.  Implemented
/// by the uniform-axial constraint (uniform_constraint.h) and the tie of
/// non-matching meshes (tie_constraint.h).
class DisplacementConstraint
{
public:
  virtual ~DisplacementConstraint() = default;

  /// Prolongation full <- reduced (rows: owned full dofs).
  virtual Mat T() const = 0;

  /// x from u: each reduced unknown's value in u (for a u that satisfies the
  /// constraint, T x = u); also the restriction of the rigid-body modes.
  virtual void restrict_to(const dolfinx::la::Vector<double>& u, Vec x) const = 0;

  /// A new reduced vector (caller destroys it).
  Vec create_reduced_vector() const;

  /// u = T x (owned part), then ghost update.
  void prolong(Vec x, dolfinx::la::Vector<double>& u) const;

  /// Number of reduced unknowns over all ranks.
  std::int64_t reduced_size() const;

  /// Per owned full (unrolled) dof, the global number of the reduced unknown that
  /// is that dof itself, or -1 where the constraint sets the dof (uniform-axial's
  /// tied dofs, a tie's slaves): the numbering under which the vertex-star
  /// patches of the full space become patches of T^T A T.
  std::vector<std::int64_t> reduced_numbers() const;

  /// R = diag(T^T T)^-1 T^T, reduced <- full (caller destroys it): a left inverse
  /// of T where T^T T is diagonal (uniform-axial: the tied dofs' mean), its diagonal
  /// approximation for a tie.  It carries p-multigrid's prolongation, made on the
  /// full space, onto the reduced unknowns (R P).
  Mat restriction() const;

  /// Whether the reduced unknowns are whole nodes, three components in a row on
  /// every rank (then T^T J T carries block size 3, as J does).
  virtual bool keeps_whole_nodes() const { return false; }

protected:
  /// x[reduced_index[i]] = u[i] for the owned dofs that are reduced unknowns.
  void copy_free_dofs(const dolfinx::la::Vector<double>& u, PetscScalar* x) const;

  std::vector<std::int32_t> _reduced_index; ///< owned unrolled dof -> local reduced or -1
};

/// The unknowns a Newton system solves for are u's owned dofs or, under a
/// constraint, the reduced x.  w = T du (or du itself), ghosts updated.
void to_full(const DisplacementConstraint* constraint, Vec du, dolfinx::la::Vector<double>& w);

/// x += T^T w over w's owned entries (or x += w's owned entries).
void add_restricted(const DisplacementConstraint* constraint, const dolfinx::la::Vector<double>& w,
                    Vec x);

/// A PETSc vector over w's owned entries, sharing w's array (read only; destroy it after).
Vec owned_part(const dolfinx::la::Vector<double>& w);

} // namespace muscle
