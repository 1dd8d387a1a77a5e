// The one place where the elements' formulations are told apart.
#include "fem/newton/displacement_formulation.h"
#include "fem/newton/displacement_system.h"
#include "fem/newton/fbar_formulation.h"
#include "fem/newton/taylor_hood_formulation.h"

#include <algorithm>

namespace muscle
{

std::unique_ptr<Formulation> make_formulation(DisplacementSystem& system,
                                              const NewtonOptions& options)
{
  const auto& parts = system.parts();
  if (options.fbar_cell_unknowns
      and std::all_of(parts.begin(), parts.end(), [](auto* p) { return p->fbar(); }))
    return std::make_unique<FbarFormulation>(system, options);
  if (system.problem().taylor_hood())
    return std::make_unique<TaylorHoodFormulation>(system, options);
  return std::make_unique<DisplacementFormulation>(system, options);
}

} // namespace muscle
