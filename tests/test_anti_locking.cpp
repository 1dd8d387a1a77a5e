// The anti-locking Q1 element runs two FFCx kernels per cell (the energy on the
// full rule, the stiff volumetric part on one point).  Reference: the same two
// ufcx forms assembled separately by DOLFINx and added -- independent of the
// combined kernel's coefficient and constant gathering.
#include <fem/elements/muscle_problem.h>
#include <forms/form_registry.h>
#include <material/parameters.h>

#include <cmath>
#include <dolfinx/fem/assembler.h>
#include <dolfinx/fem/utils.h>
#include <dolfinx/mesh/generation.h>
#include <gtest/gtest.h>
#include <numeric>
#include <xtensor/xarray.hpp>
#include <xtensor/xbuilder.hpp>

using namespace muscle;
using namespace dolfinx;

namespace
{
struct Body
{
  std::shared_ptr<mesh::Mesh> mesh;
  std::unique_ptr<MuscleProblem> problem;
};

Body make(int volumetric_degree)
{
  Body s;
  s.mesh = std::make_shared<mesh::Mesh>(mesh::create_box(
      MPI_COMM_WORLD, {{{0, 0, 0}, {1, 1.2, 1.5}}}, {2, 2, 3}, mesh::CellType::hexahedron,
      mesh::GhostMode::shared_facet));
  s.problem = std::make_unique<MuscleProblem>(
      s.mesh, ParameterSet(Model("ble")), Discretisation{1, 2, volumetric_degree});
  s.problem->set_fibre({0.3, 0.1, 0.95});
  s.problem->set_time_factor(0.7);
  // a smooth non-homogeneous displacement: every quadrature point sees another F
  s.problem->u()->interpolate(
      [](const xt::xtensor<double, 2>& x) -> xt::xarray<double>
      {
        xt::xarray<double> v = xt::zeros<double>({std::size_t(3), x.shape(1)});
        for (std::size_t i = 0; i < x.shape(1); ++i)
        {
          const double X = x(0, i), Y = x(1, i), Z = x(2, i);
          v(0, i) = 0.05 * std::sin(2 * X + Z);
          v(1, i) = 0.04 * X * Y - 0.03 * Z * Z;
          v(2, i) = -0.08 * Z + 0.02 * std::cos(3 * Y);
        }
        return v;
      });
  s.problem->u()->x()->scatter_fwd();
  return s;
}

std::vector<double> assemble(const fem::Form<double>& form, std::size_t size)
{
  std::vector<double> b(size, 0.0);
  fem::assemble_vector<double>(b, form);
  return b;
}

/// The same ufcx form with the problem's coefficients and constants.
fem::Form<double> separate(const ufcx_form& form, const MuscleProblem& p)
{
  const fem::Form<double>& full = *p.residual();
  std::map<std::string, std::shared_ptr<const fem::Function<double>>> coefficients;
  const auto names = fem::get_coefficient_names(*forms::find_fe_variant(
                                                    "ble", "hexahedron", 1, 2, 1)
                                                    .residual);
  for (std::size_t i = 0; i < names.size(); ++i)
    coefficients[names[i]] = full.coefficients()[i];
  std::map<std::string, std::shared_ptr<const fem::Constant<double>>> constants;
  const auto cnames = fem::get_constant_names(
      *forms::find_fe_variant("ble", "hexahedron", 1, 2, 1).residual);
  for (std::size_t i = 0; i < cnames.size(); ++i)
    constants[cnames[i]] = full.constants()[i];
  return fem::create_form<double>(form, full.function_spaces(), coefficients, constants, {});
}
} // namespace

TEST(AntiLocking, CombinedKernelEqualsTheTwoFormsAddedUp)
{
  Body s = make(1);
  const forms::FeVariant& v = forms::find_fe_variant("ble", "hexahedron", 1, 2, 1);
  ASSERT_NE(v.residual_volumetric, nullptr);
  const auto map = s.problem->V()->dofmap()->index_map;
  const std::size_t n = (map->size_local() + map->num_ghosts()) * 3;

  const std::vector<double> combined = assemble(*s.problem->residual(), n);
  const std::vector<double> main = assemble(separate(*v.residual, *s.problem), n);
  const std::vector<double> vol = assemble(separate(*v.residual_volumetric, *s.problem), n);
  double diff = 0, norm = 0, vol_norm = 0;
  for (std::size_t i = 0; i < n; ++i)
  {
    diff = std::max(diff, std::abs(combined[i] - main[i] - vol[i]));
    norm = std::max(norm, std::abs(combined[i]));
    vol_norm = std::max(vol_norm, std::abs(vol[i]));
  }
  EXPECT_GT(vol_norm, 1e-3 * norm) << "the volumetric part must matter in this state";
  EXPECT_LT(diff, 1e-12 * norm);

  // residual_on_cells uses the combined kernel too: the two halves add up
  auto cells = std::make_shared<mesh::MeshTags<std::int32_t>>(
      [&]
      {
        const int tdim = s.mesh->topology().dim();
        const std::int32_t num = s.mesh->topology().index_map(tdim)->size_local()
                                 + s.mesh->topology().index_map(tdim)->num_ghosts();
        std::vector<std::int32_t> idx(num), val(num);
        std::iota(idx.begin(), idx.end(), 0);
        for (std::int32_t c = 0; c < num; ++c)
          val[c] = c % 2;
        return mesh::MeshTags<std::int32_t>(s.mesh, tdim, idx, val);
      }());
  const std::vector<double> even = assemble(*s.problem->residual_on_cells(cells, 0), n);
  const std::vector<double> odd = assemble(*s.problem->residual_on_cells(cells, 1), n);
  double split = 0;
  for (std::size_t i = 0; i < n; ++i)
    split = std::max(split, std::abs(even[i] + odd[i] - combined[i]));
  EXPECT_LT(split, 1e-12 * norm);
}

TEST(AntiLocking, DiffersFromTheFullRuleOnlyInTheVolumetricPart)
{
  // plain Q1 and anti-locking Q1 at the same state: they must differ (the rule
  // matters), but only by the volumetric term (the rest is the same kernel)
  Body plain = make(-1), reduced = make(1);
  const auto map = plain.problem->V()->dofmap()->index_map;
  const std::size_t n = (map->size_local() + map->num_ghosts()) * 3;
  const std::vector<double> a = assemble(*plain.problem->residual(), n);
  const std::vector<double> b = assemble(*reduced.problem->residual(), n);
  double diff = 0, norm = 0;
  for (std::size_t i = 0; i < n; ++i)
  {
    diff = std::max(diff, std::abs(a[i] - b[i]));
    norm = std::max(norm, std::abs(a[i]));
  }
  EXPECT_GT(diff, 1e-6 * norm);
  EXPECT_LT(diff, norm);
}
