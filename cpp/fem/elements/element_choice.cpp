#include "fem/elements/element_choice.h"

#include "common/errors.h"

namespace muscle
{

bool use_fbar(std::optional<bool> fbar, const std::string& cell, int degree,
              bool anti_locking)
{
  const bool hexahedron = cell == "hex" or cell == "hexahedron";
  if (!fbar)
    return hexahedron and degree == 1 and !anti_locking;
  if (*fbar)
  {
    check_fbar_request(degree, anti_locking);
    if (!hexahedron)
      throw InputError("the F-bar element is the locking-free Q1 hexahedron: on tetrahedra "
                       "the centre value is the whole P1 field, found " + cell);
  }
  return *fbar;
}

void check_fbar_request(int degree, bool anti_locking)
{
  if (degree != 1)
    throw InputError("the F-bar element is the locking-free Q1 hexahedron: it needs degree 1 "
                     "(Q2 does not lock), found degree " + std::to_string(degree));
  if (anti_locking)
    throw InputError("F-bar and a volumetric quadrature degree of its own are two anti-locking "
                     "elements; choose one");
}

std::string locking_warning(const std::string& cell, int degree, bool fbar, bool anti_locking,
                            const ParameterSet& parameters)
{
  if (degree != 1 or fbar or anti_locking or !parameters.has("kappa")
      or parameters["kappa"] < 100)
    return "";
  return "plain linear " + cell + " elements lock under the nearly incompressible "
         + to_string(parameters.model())
         + " law: on the fusiform muscle (n = 1) plain Q1 is +6.1 % in force and -7.3 % in "
           "free shortening against Q2, F-bar +1.5 % and +1.7 % (BENCHMARKS.md); use F-bar "
           "(the default on hexahedra) or degree 2";
}

} // namespace muscle
