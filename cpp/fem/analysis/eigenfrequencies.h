#pragma once

#include <petscmat.h>
#include <slepceps.h>
#include <vector>

namespace muscle
{
class DisplacementConstraint;

/// The `count` lowest natural angular frequencies (rad/s) of K x = omega^2 M x
/// (SLEPc, shift-and-invert about 0 with MUMPS): K the tangent and M the mass,
/// both full-layout with the fixed dofs' rows and columns empty (K: a unit
/// diagonal there), reduced by `constraint` (u = T x) if given.  The fixed dofs
/// are left out.  Collective; fewer values if fewer converged; a negative value
/// is -sqrt(-lambda) of a negative eigenvalue (an unstable state).
std::vector<double> natural_frequencies(Mat K, Mat M, const DisplacementConstraint* constraint,
                                        int count);

/// SLEPc started once (PETSc runs already).
void initialise_slepc();

/// `eps` looks for the eigenvalues nearest 0: shift-and-invert with a MUMPS
/// factorisation.
void nearest_zero(EPS eps);

} // namespace muscle
