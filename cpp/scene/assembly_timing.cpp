#include "scene/assembly_timing.h"

#include "common/application.h"
#include "common/errors.h"
#include "scene/clock.h"
#include "scene/scene_model.h"

#include <algorithm>
#include <cstdio>
#include <dolfinx/fem/assembler.h>
#include <dolfinx/fem/petsc.h>
#include <dolfinx/la/petsc.h>

using namespace dolfinx;

namespace muscle
{
namespace
{
/// Time `count` residual and Jacobian assemblies of a problem's forms.
nlohmann::json time_assembly(MuscleProblem& problem, int count)
{
  Mat A = fem::petsc::create_matrix(*problem.jacobian(), "aij");
  la::Vector<double> b(problem.V()->dofmap()->index_map, problem.V()->dofmap()->index_map_bs());
  auto median = [](std::vector<double> v)
  {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  std::vector<double> residual, jacobian, kernel;
  for (int k = 0; k < count; ++k)
  {
    auto t0 = Clock::now();
    problem.update_activation();
    kernel.push_back(seconds_since(t0));
    t0 = Clock::now();
    std::fill(b.mutable_array().begin(), b.mutable_array().end(), 0.0);
    fem::assemble_vector<double>(b.mutable_array(), *problem.residual());
    residual.push_back(seconds_since(t0));
    t0 = Clock::now();
    MatZeroEntries(A);
    fem::assemble_matrix(la::petsc::Matrix::set_block_fn(A, ADD_VALUES), *problem.jacobian(),
                         {});
    MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY);
    MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY);
    jacobian.push_back(seconds_since(t0));
  }
  MatDestroy(&A);
  return {{"forms", problem.kernel_name()},
          {"activation_kernel_s", problem.has_activation_kernel() ? median(kernel) : 0.0},
          {"residual_s", median(residual)},
          {"jacobian_s", median(jacobian)}};
}
} // namespace

nlohmann::json time_assemblies(const Scene& scene, SceneModel& model, int count)
{
  nlohmann::json assembly;
  if (count > 0 and model.body.size() > 1)
    throw InputError("--measure-assembly compares one part's forms with the plain passive "
                     "forms; this scene has " + std::to_string(model.body.size()) + " parts");
  if (count <= 0)
    return assembly;
  // the (first) part's forms against the plain passive forms of the same model
  const Part& part = scene.parts[0];
  MuscleProblem& problem = model.problem();
  problem.set_time_factor(part.active ? 1.0 : 0.0);
  assembly["scene"] = time_assembly(problem, count);
  MuscleProblem plain(model.gm.mesh, part.parameters, model.element, true);
  assembly["plain_passive"] = time_assembly(plain, count);
  problem.set_time_factor(0);
  if (is_root())
    for (const char* k : {"scene", "plain_passive"})
      std::printf("assembly (%s, %s): residual %.4f s, Jacobian %.4f s, activation kernel "
                  "%.4f s (median of %d)\n",
                  k, assembly[k]["forms"].get<std::string>().c_str(),
                  assembly[k]["residual_s"].get<double>(), assembly[k]["jacobian_s"].get<double>(),
                  assembly[k]["activation_kernel_s"].get<double>(), count);
  return assembly;
}

} // namespace muscle
