#include "fem/elements/fibres.h"

#include "common/application.h"

#include "common/errors.h"
#include "forms/form_registry.h"

#include <cmath>
#include <dolfinx/fem/DirichletBC.h>
#include <dolfinx/fem/assembler.h>
#include <dolfinx/fem/petsc.h>
#include <dolfinx/fem/utils.h>
#include <dolfinx/la/petsc.h>
#include <dolfinx/mesh/cell_types.h>
#include <petscksp.h>
#include <xtensor/xtensor.hpp>

using namespace dolfinx;

namespace muscle
{
namespace
{
/// `form` (compiled as `compiled`) integrated over the cells tagged 1 only.
std::shared_ptr<fem::Form<double>> over_cells(const fem::Form<double>& form,
                                              const ufcx_form& compiled,
                                              std::shared_ptr<mesh::MeshTags<std::int32_t>> cells)
{
  using Kernel = std::function<void(double*, const double*, const double*, const double*,
                                    const int*, const std::uint8_t*)>;
  const Kernel kernel = compiled.integrals(ufcx_integral_type::cell)[0]->tabulate_tensor_float64;
  std::map<fem::IntegralType,
           std::pair<std::vector<std::pair<int, Kernel>>, const mesh::MeshTags<int>*>>
      integrals;
  integrals[fem::IntegralType::cell] = {{{1, kernel}}, cells.get()};
  // (the form keeps only the cell lists, not the tags)
  return std::make_shared<fem::Form<double>>(form.function_spaces(), integrals,
                                             form.coefficients(), form.constants(), false,
                                             form.mesh());
}

/// The local dofs of V (owned and ghost) on no cell of `cells` on any rank.
std::vector<std::int32_t> dofs_outside(const fem::FunctionSpace& V,
                                       const std::vector<std::int32_t>& cells)
{
  const auto& dofmap = *V.dofmap();
  la::Vector<double> marker(dofmap.index_map, 1);
  std::span<double> m = marker.mutable_array();
  for (std::int32_t c : cells)
    for (std::int32_t d : dofmap.cell_dofs(c))
      m[d] = 1;
  marker.scatter_rev(std::plus<double>());
  marker.scatter_fwd();
  std::vector<std::int32_t> outside;
  for (std::size_t d = 0; d < m.size(); ++d)
    if (m[d] == 0)
      outside.push_back(d);
  return outside;
}
} // namespace


LaplaceFibres laplace_fibres(std::shared_ptr<mesh::Mesh> mesh,
                             const mesh::MeshTags<std::int32_t>& facet_tags,
                             int from_tag, int to_tag,
                             std::shared_ptr<const fem::FunctionSpace> fibre_space,
                             const std::vector<std::int32_t>* only)
{
  const std::string cell = mesh::to_string(mesh->topology().cell_type());
  const forms::FibreVariant* variant = nullptr;
  for (const auto& v : forms::fibre_variants())
    if (cell == v.cell)
      variant = &v;
  if (!variant)
    throw InputError("no fibre kernels for cell type " + cell + "."
                     + forms::element_not_compiled(cell, 1));

  auto V = std::make_shared<fem::FunctionSpace>(
      fem::create_functionspace(variant->function_space, "q", mesh));
  auto source = std::make_shared<fem::Constant<double>>(0.0);
  using Coefficients = std::map<std::string, std::shared_ptr<const fem::Function<double>>>;
  using Constants = std::map<std::string, std::shared_ptr<const fem::Constant<double>>>;
  const auto a_all = std::make_shared<fem::Form<double>>(
      fem::create_form<double>(*variant->laplace, {V, V}, Coefficients{}, Constants{}, {}));
  auto a = a_all;
  auto L = std::make_shared<fem::Form<double>>(fem::create_form<double>(
      *variant->rhs, {V}, Coefficients{}, Constants{{"source", source}}, {}));

  mesh->topology_mutable().create_connectivity(2, 3);
  std::vector<std::shared_ptr<const fem::DirichletBC<double>>> bcs;
  if (only)
  {
    // the potential of this part alone: its cells' Laplacian, and zero at
    // every other dof (another body's dofs would make a singular block, on
    // which MUMPS fails now and then on two ranks)
    auto cells = std::make_shared<mesh::MeshTags<std::int32_t>>(
        mesh, 3, *only, std::vector<std::int32_t>(only->size(), 1));
    a = over_cells(*a, *variant->laplace, cells);
    bcs.push_back(std::make_shared<fem::DirichletBC<double>>(
        std::make_shared<fem::Constant<double>>(0.0), dofs_outside(*V, *only), V));
  }
  for (auto [tag, value] : {std::pair{from_tag, 0.0}, {to_tag, 1.0}})
  {
    const std::vector<std::int32_t> facets = facet_tags.find(tag);
    bcs.push_back(std::make_shared<fem::DirichletBC<double>>(
        std::make_shared<fem::Constant<double>>(value),
        fem::locate_dofs_topological(*V, 2, facets), V));
  }

  // (the whole mesh's pattern: the unit rows of the other dofs go in too)
  la::petsc::Matrix A(fem::petsc::create_matrix(*a_all), false);
  MatZeroEntries(A.mat());
  fem::assemble_matrix(la::petsc::Matrix::set_block_fn(A.mat(), ADD_VALUES), *a, bcs);
  MatAssemblyBegin(A.mat(), MAT_FLUSH_ASSEMBLY);
  MatAssemblyEnd(A.mat(), MAT_FLUSH_ASSEMBLY);
  fem::set_diagonal<double>(la::petsc::Matrix::set_fn(A.mat(), INSERT_VALUES), *V, bcs);
  MatAssemblyBegin(A.mat(), MAT_FINAL_ASSEMBLY);
  MatAssemblyEnd(A.mat(), MAT_FINAL_ASSEMBLY);

  la::Vector<double> b(V->dofmap()->index_map, 1);
  fem::assemble_vector<double>(b.mutable_array(), *L);
  fem::apply_lifting<double>(b.mutable_array(), {a}, {bcs}, std::vector<std::span<const double>>{},
                             1.0);
  b.scatter_rev(std::plus<double>());
  fem::set_bc<double>(b.mutable_array(), bcs);

  LaplaceFibres out;
  out.potential = std::make_shared<fem::Function<double>>(V);
  out.potential->name = "fibre_potential";
  la::petsc::Vector x(la::petsc::create_vector_wrap(*out.potential->x()), false);
  la::petsc::Vector rhs(la::petsc::create_vector_wrap(b), false);
  KSP ksp;
  KSPCreate(mesh->comm(), &ksp);
  KSPSetOperators(ksp, A.mat(), A.mat());
  KSPSetType(ksp, KSPPREONLY);
  PC pc;
  KSPGetPC(ksp, &pc);
  PCSetType(pc, PCLU);
  PCFactorSetMatSolverType(pc, MATSOLVERMUMPS);
  KSPSetOptionsPrefix(ksp, "fibre_");
  KSPSetFromOptions(ksp);
  KSPSolve(ksp, rhs.vec(), x.vec());
  KSPDestroy(&ksp);
  out.potential->x()->scatter_fwd();

  // normalised gradient at the midpoint of every local cell
  auto expression = fem::create_expression<double>(
      *variant->gradient, {{"potential", out.potential}}, {}, mesh);
  const std::int32_t num_cells = mesh->topology().index_map(3)->size_local()
                                 + mesh->topology().index_map(3)->num_ghosts();
  std::vector<std::int32_t> cells(num_cells);
  std::iota(cells.begin(), cells.end(), 0);
  xt::xtensor<double, 2> gradient({cells.size(), 3});
  expression.eval(std::span<const std::int32_t>(cells), gradient);

  out.fibre = std::make_shared<fem::Function<double>>(
      std::const_pointer_cast<fem::FunctionSpace>(fibre_space));
  out.fibre->name = "fibre";
  std::span<double> m = out.fibre->x()->mutable_array();
  const auto& dofmap = *fibre_space->dofmap();
  std::vector<char> wanted(num_cells, only == nullptr);
  if (only)
    for (std::int32_t c : *only)
      wanted[c] = 1;
  std::string error;
  for (std::int32_t c = 0; c < num_cells; ++c)
  {
    if (!wanted[c])
      continue;
    const double n = std::sqrt(gradient(c, 0) * gradient(c, 0) + gradient(c, 1) * gradient(c, 1)
                               + gradient(c, 2) * gradient(c, 2));
    if (!(n > 0))
    {
      error = "fibre potential has zero gradient in a cell: are the two surfaces tagged, "
              "distinct, and do they bound this part?";
      break;
    }
    const std::int32_t dof = dofmap.cell_dofs(c)[0];
    for (int k = 0; k < 3; ++k)
      m[3 * dof + k] = gradient(c, k) / n;
  }
  throw_if_any(mesh->comm(), error);
  return out;
}

} // namespace muscle
