#pragma once

#include <petscpc.h>
#include <span>

namespace muscle
{

/// The name of the PETSc preconditioner type "stars": additive relaxation on
/// overlapping patches, y = sum_i R_i^T A_i^-1 R_i x with A_i = R_i A R_i^T, each
/// A_i inverted densely.  It is what PCASM computes with PC_ASM_BASIC and an exact
/// solve per block, with one scatter for all patches instead of one per block and
/// the inverses in one array: on p-multigrid's Q2 level of the fusiform muscle
/// PCASM's per-block vectors, scatters and solvers took longer than the
/// relaxation's arithmetic (BENCHMARKS.md, "Preconditioners against kappa").
/// The inverses are computed in double, then kept and applied in single
/// precision unless -pc_stars_double is given: a smoother's precision, half the
/// bytes read and twice the SIMD width.
inline constexpr const char* PCSTARS = "stars";

/// Makes "stars" a PETSc preconditioner type (-*_pc_type stars).  Idempotent.
void register_star_relaxation();

/// Gives a "stars" preconditioner its patches: index sets of global (unrolled)
/// row numbers of its operator, as vertex_star_patches returns them; copied, the
/// caller keeps them.  Before its set-up; without patches the set-up fails with
/// a message.  Not collective.
void set_star_patches(PC pc, std::span<const IS> patches);

} // namespace muscle
