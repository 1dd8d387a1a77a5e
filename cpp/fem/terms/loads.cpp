#include "fem/terms/loads.h"

#include "common/errors.h"

#include <algorithm>
#include <basix/finite-element.h>
#include <dolfinx/fem/assembler.h>
#include <dolfinx/fem/utils.h>
#include <dolfinx/mesh/cell_types.h>
#include <numeric>

using namespace dolfinx;

namespace muscle
{
namespace
{
const forms::LoadVariant& variant_for(const fem::FunctionSpace& V)
{
  const std::string cell = mesh::to_string(V.mesh()->topology().cell_type());
  const int degree = V.element()->basix_element().degree();
  for (const forms::LoadVariant& v : forms::load_variants())
    if (cell == v.cell and degree == v.degree)
      return v;
  throw InputError("loads: no compiled load forms for " + cell + " of degree "
                   + std::to_string(degree) + "." + forms::element_not_compiled(cell, degree));
}
} // namespace

Loads::Loads(std::shared_ptr<fem::Function<double>> u)
    : _u(std::move(u)), _variant(&variant_for(*_u->function_space()))
{
}

std::map<fem::IntegralType, const mesh::MeshTags<int>*>
Loads::on_surface(Load& l, const std::vector<std::int32_t>& facets) const
{
  auto mesh = _u->function_space()->mesh();
  std::vector<std::int32_t> sorted = facets;
  std::sort(sorted.begin(), sorted.end());
  sorted.erase(std::unique(sorted.begin(), sorted.end()), sorted.end());
  l.tags = std::make_shared<mesh::MeshTags<std::int32_t>>(
      mesh, mesh->topology().dim() - 1, sorted, std::vector<std::int32_t>(sorted.size(), 1));
  const std::map<fem::IntegralType, const mesh::MeshTags<int>*> subdomains
      = {{fem::IntegralType::exterior_facet, l.tags.get()}};
  l.area = std::make_shared<fem::Form<double>>(
      fem::create_form<double>(*_variant->area, {}, {{"u", _u}}, {}, subdomains, mesh));
  return subdomains;
}

void Loads::add_pressure(const std::string& name, const std::vector<std::int32_t>& facets,
                         std::function<double(double)> value)
{
  Load l;
  l.name = name;
  l.kind = "pressure";
  l.value = std::move(value);
  l.constant = std::make_shared<fem::Constant<double>>(0.0);
  const auto subdomains = on_surface(l, facets);
  auto V = _u->function_space();
  l.residual = std::make_shared<fem::Form<double>>(fem::create_form<double>(
      *_variant->pressure_residual, {V}, {{"u", _u}}, {{"pressure", l.constant}}, subdomains));
  l.jacobian = std::make_shared<fem::Form<double>>(fem::create_form<double>(
      *_variant->pressure_jacobian, {V, V}, {{"u", _u}}, {{"pressure", l.constant}},
      subdomains));
  _loads.push_back(std::move(l));
}

void Loads::add_traction(const std::string& name, const std::vector<std::int32_t>& facets,
                         std::array<double, 3> direction, std::function<double(double)> value)
{
  Load l;
  l.name = name;
  l.kind = "traction";
  l.value = std::move(value);
  l.direction = direction;
  l.constant = std::make_shared<fem::Constant<double>>(std::vector<double>{0, 0, 0},
                                                       std::vector<std::size_t>{3});
  const auto subdomains = on_surface(l, facets);
  l.residual = std::make_shared<fem::Form<double>>(fem::create_form<double>(
      *_variant->traction_residual, {_u->function_space()}, {}, {{"traction", l.constant}},
      subdomains));
  _loads.push_back(std::move(l));
}

void Loads::add_gravity(std::array<double, 3> g, std::function<double(double)> value,
                        const std::vector<double>& density)
{
  Load l;
  l.name = l.kind = "gravity";
  l.value = std::move(value);
  l.direction = g;
  l.constant = std::make_shared<fem::Constant<double>>(std::vector<double>{0, 0, 0},
                                                       std::vector<std::size_t>{3});
  auto V = _u->function_space();
  auto rho = density_function(V->mesh(), density);
  const std::map<std::string, std::shared_ptr<const fem::Function<double>>> coefficients
      = {{"density", rho}};
  const std::map<std::string, std::shared_ptr<const fem::Constant<double>>> constants
      = {{"gravity", l.constant}};
  l.residual = std::make_shared<fem::Form<double>>(fem::create_form<double>(
      *_variant->gravity_residual, {V}, coefficients, constants, {}));
  _loads.push_back(std::move(l));
}

std::shared_ptr<fem::Function<double>>
density_function(std::shared_ptr<const mesh::Mesh> mesh, const std::vector<double>& density)
{
  auto shared = std::const_pointer_cast<mesh::Mesh>(mesh);
  const basix::FiniteElement dg0 = basix::create_element(
      basix::element::family::P, mesh::cell_type_to_basix_type(mesh->topology().cell_type()),
      0, basix::element::lagrange_variant::equispaced, true);
  auto rho = std::make_shared<fem::Function<double>>(
      std::make_shared<fem::FunctionSpace>(fem::create_functionspace(shared, dg0, 1)));
  const auto& dofmap = *rho->function_space()->dofmap();
  std::span<double> x = rho->x()->mutable_array();
  for (std::size_t c = 0; c < density.size(); ++c)
    x[dofmap.cell_dofs(c)[0]] = density[c];
  return rho;
}

std::shared_ptr<fem::Form<double>>
mass_form(std::shared_ptr<const fem::FunctionSpace> V,
          std::shared_ptr<const fem::Function<double>> density)
{
  return std::make_shared<fem::Form<double>>(fem::create_form<double>(
      *variant_for(*V).mass, {V, V}, {{"density", density}}, {}, {}));
}

void Loads::set_time(double t)
{
  for (Load& l : _loads)
  {
    const double f = l.value(t);
    if (l.kind == "pressure")
      l.constant->value = {f};
    else
      l.constant->value = {f * l.direction[0], f * l.direction[1], f * l.direction[2]};
  }
}

std::vector<std::shared_ptr<const fem::Form<double>>> Loads::residuals() const
{
  std::vector<std::shared_ptr<const fem::Form<double>>> out;
  for (const Load& l : _loads)
    out.push_back(l.residual);
  return out;
}

std::vector<std::shared_ptr<const fem::Form<double>>> Loads::jacobians() const
{
  std::vector<std::shared_ptr<const fem::Form<double>>> out;
  for (const Load& l : _loads)
    if (l.jacobian)
      out.push_back(l.jacobian);
  return out;
}

double Loads::current_area(const std::string& name) const
{
  for (const Load& l : _loads)
  {
    if (l.name != name or !l.area)
      continue;
    const double local = fem::assemble_scalar(*l.area);
    double total = 0;
    MPI_Allreduce(&local, &total, 1, MPI_DOUBLE, MPI_SUM, _u->function_space()->mesh()->comm());
    return total;
  }
  throw std::logic_error("no surface load named " + name);
}

std::vector<std::string> Loads::describe() const
{
  std::vector<std::string> out;
  for (const Load& l : _loads)
    out.push_back(l.kind == "gravity" ? std::string("gravity") : l.kind + " on " + l.name);
  return out;
}

} // namespace muscle
