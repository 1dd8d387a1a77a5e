#pragma once

#include "fem/constraints/boundary.h"
#include "fem/linear/linear_solver.h"

#include <memory>
#include <string>
#include <vector>

namespace muscle
{
class AugmentedLagrangian;
class DegreeOneCoarsening;
class ParameterSet;

/// The blocks of the Taylor-Hood Newton system [[A, A_uq], [A_qu, A_qq]] on
/// the unknowns Newton solves for ([u | q], u reduced under a constraint), as
/// the formulation assembles them: the objects stay, their values change.
struct TaylorHoodBlocks
{
  Mat uu = nullptr; ///< A or T^T A T (A_gamma there under the augmented Lagrangian)
  Mat uq = nullptr; ///< A_uq or T^T A_uq
  Mat qu = nullptr; ///< A_qu or A_qu T
  Mat qq = nullptr; ///< A_qq
  Vec iterate = nullptr; ///< a vector [u | q] (the layout)
  PetscInt nu = 0;       ///< local entries of its u part
};

/// linear: gmres-schur (and gmres-stars) on the Taylor-Hood system: GMRES
/// preconditioned by the upper block factorisation with the q block's Schur
/// complement approximated from A_qq and the pressure mass matrix over the law's
/// shear modulus at rest.  PCFIELDSPLIT with GAMG (or BoomerAMG) on u, or -- with
/// -fieldsplit_u_pc_type mg or -al_gamma -- the same factorisation applied here
/// (a shell): p-multigrid (p_multigrid.h) on u, relaxed on vertex stars with
/// -fieldsplit_u_mg_levels_pc_type stars, or the augmented-Lagrangian block.
class TaylorHoodSplit : public LinearSolver
{
public:
  /// `parameters`, `kernels`: the law (its shear modulus at rest scales the Schur
  /// approximation).  `al_gamma`: the augmented Lagrangian's penalty over that
  /// modulus unless -al_gamma gives it (0: none).  Reads p-multigrid's own options.
  TaylorHoodSplit(const LinearSettings& settings, DisplacementSpace space, DirichletBCs bcs,
                  const ParameterSet& parameters, const std::string& kernels,
                  double al_gamma = 0);
  ~TaylorHoodSplit();
  TaylorHoodSplit(const TaylorHoodSplit&) = delete;
  TaylorHoodSplit& operator=(const TaylorHoodSplit&) = delete;

  /// The augmented Lagrangian (-al_gamma) the Jacobian's assembly feeds, or null.
  AugmentedLagrangian* augmented() const { return _augmented.get(); }
  /// Sets `ksp` up on the blocks (after their first assembly).
  void configure(KSP ksp, const TaylorHoodBlocks& blocks);
  /// After each Jacobian: the Schur approximation and the shell's operators.
  void update();
  std::vector<KSP> nested() const override { return {_u_ksp, _q_ksp}; }
  void start_solve() override;

  /// linear: gmres-stars: this split's options of the best measured
  /// preconditioner (p-multigrid relaxing Q2 on vertex stars, BoomerAMG on Q1,
  /// Chebyshev on q), each option the user gave kept; with the augmented
  /// Lagrangian at stars_al_gamma.
  static void set_stars_defaults();
  static constexpr double stars_al_gamma = 1;

private:
  void configure_field_split(PC pc);
  void configure_shell(PC pc);
  void update_schur_preconditioner();
  /// the displacement block's operator (and, with `coarse`, p-multigrid's Galerkin
  /// level) from the current A
  void update_shell(bool coarse = true);
  void use_vertex_star_smoother(PC u_pc);
  /// the vertex stars on T^T A T's rows (under a constraint)
  std::vector<IS> reduced_star_patches() const;
  static PetscErrorCode shell_apply(PC pc, Vec r, Vec z);

  LinearSettings _settings;
  DisplacementSpace _space;
  DirichletBCs _bcs;
  TaylorHoodBlocks _blocks;
  double _al_gamma = 0;      ///< -al_gamma: the penalty over mu at rest; 0: off
  double _shear_modulus = 0; ///< of the law at rest (the Schur approximation's scale)
  std::unique_ptr<AugmentedLagrangian> _augmented;
  std::unique_ptr<DegreeOneCoarsening> _coarsening;
  NullSpaceHandle _modes;
  MatHandle _schur_pre;
  KSPHandle _u_ksp; ///< the displacement block's solver (-fieldsplit_u_ options)
  KSPHandle _q_ksp; ///< the Schur approximation factored (-fieldsplit_q_ options)
  VecHandle _u_in, _u_out; ///< u parts of [u | q] (no own array)
  VecHandle _q_in, _q_out; ///< q parts (no own array)
  VecHandle _u_rhs;
};

/// InputError for the Taylor-Hood split's own options (-al_gamma, p-multigrid's
/// -fieldsplit_u_mg_coarse_lag and -fieldsplit_u_mg_levels_pc_stars_double) in a
/// run whose element and linear solver do not read them: PETSc's unused-option
/// warning is off in our runs, and the user would believe the option acted.
void refuse_taylor_hood_split_options(bool taylor_hood, const std::string& linear_solver);

} // namespace muscle
