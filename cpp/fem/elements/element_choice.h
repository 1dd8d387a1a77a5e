#pragma once

#include "material/parameters.h"

#include <optional>
#include <string>

namespace muscle
{

/// The element a run gets when it does not say: the F-bar hexahedron on
/// degree-1 hexahedra (plain Q1 locks under the nearly incompressible muscle
/// laws), else what was asked for.  `fbar` is the explicit choice, if any.
/// InputError when F-bar is asked for where it does not exist.
bool use_fbar(std::optional<bool> fbar, const std::string& cell, int degree,
              bool anti_locking);

/// The part of use_fbar's check that needs no mesh (a scene checks it when it
/// is read): F-bar asked for with degree 2 or with the anti-locking element.
void check_fbar_request(int degree, bool anti_locking);

/// One line warning of the locking error of plain linear elements (Q1 without
/// F-bar or anti-locking, P1) under a nearly incompressible law (kappa >= 100),
/// with the error measured in BENCHMARKS.md ("F-bar Q1: the paper's
/// element, and the n = 4 run"); "" when it does not apply.
std::string locking_warning(const std::string& cell, int degree, bool fbar, bool anti_locking,
                            const ParameterSet& parameters);

} // namespace muscle
