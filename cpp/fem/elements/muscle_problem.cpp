#include "fem/elements/muscle_problem.h"

#include "common/errors.h"
#include "forms/form_registry.h"
#include "material/material_point.h"

#include <basix/finite-element.h>
#include <basix/quadrature.h>
#include <cmath>
#include <dolfinx/fem/assembler.h>
#include <dolfinx/fem/utils.h>
#include <dolfinx/mesh/cell_types.h>
#include <set>
#include <xtensor/xtensor.hpp>

using namespace dolfinx;

namespace muscle
{
namespace
{
/// entries per quadrature point of the "post" expression (PostFields)
constexpr int post_size = 5;
std::int32_t num_local_cells(const mesh::Mesh& mesh, bool with_ghosts)
{
  auto map = mesh.topology().index_map(mesh.topology().dim());
  return map->size_local() + (with_ghosts ? map->num_ghosts() : 0);
}

using Kernel = CellKernel;

/// Positions in a form's packed array of the entries named `wanted`, each
/// name's entries [offsets[i], offsets[i + 1]) with i its place in `names`.
std::vector<int> gather_index(const std::vector<std::string>& names,
                              const std::vector<int>& offsets,
                              const std::vector<std::string>& wanted)
{
  std::vector<int> index;
  for (const std::string& name : wanted)
  {
    auto it = std::find(names.begin(), names.end(), name);
    if (it == names.end())
      throw std::logic_error("volumetric form uses " + name + ", the main form does not");
    const auto i = std::distance(names.begin(), it);
    for (int k = offsets[i]; k < offsets[i + 1]; ++k)
      index.push_back(k);
  }
  return index;
}

/// The cell kernel of `form` (built as `full`).  With `volumetric` (anti-locking
/// Q1) it also adds that form's element tensor, computed on its own quadrature
/// rule from the entries of the packed coefficients and constants it uses.
Kernel cell_kernel(const ufcx_form& form, const fem::Form<double>& full,
                   const ufcx_form* volumetric)
{
  if (form.num_integrals(cell) != 1)
    throw std::logic_error("expected one cell integral");
  Kernel main = form.integrals(cell)[0]->tabulate_tensor_float64;
  if (!volumetric)
    return main;
  if (volumetric->num_integrals(cell) != 1)
    throw std::logic_error("expected one cell integral in the volumetric form");
  Kernel vol = volumetric->integrals(cell)[0]->tabulate_tensor_float64;
  std::vector<int> constant_offsets = {0};
  for (const auto& c : full.constants())
    constant_offsets.push_back(constant_offsets.back() + c->value.size());
  const std::vector<int> w_index
      = gather_index(fem::get_coefficient_names(form), full.coefficient_offsets(),
                     fem::get_coefficient_names(*volumetric));
  const std::vector<int> c_index
      = gather_index(fem::get_constant_names(form), constant_offsets,
                     fem::get_constant_names(*volumetric));
  return [main, vol, w_index, c_index, wv = std::vector<double>(w_index.size()),
          cv = std::vector<double>(c_index.size())](
             double* A, const double* w, const double* c, const double* x, const int* e,
             const std::uint8_t* perm) mutable
  {
    main(A, w, c, x, e, perm);
    for (std::size_t i = 0; i < w_index.size(); ++i)
      wv[i] = w[w_index[i]];
    for (std::size_t i = 0; i < c_index.size(); ++i)
      cv[i] = c[c_index[i]];
    vol(A, wv.data(), cv.data(), x, e, perm); // FFCx kernels add into A
  };
}

/// `full` with its cell kernel replaced by `kernel`, on the cells tagged `value`
/// (all owned cells without tags).
std::shared_ptr<fem::Form<double>> with_kernel(Kernel kernel, const fem::Form<double>& full,
                                               const mesh::MeshTags<std::int32_t>* tags,
                                               int value)
{
  if (full.integral_types() != std::set<fem::IntegralType>{fem::IntegralType::cell})
    throw std::logic_error("with_kernel: only forms with cell integrals alone");
  std::map<fem::IntegralType,
           std::pair<std::vector<std::pair<int, Kernel>>, const mesh::MeshTags<int>*>>
      integrals;
  integrals[fem::IntegralType::cell] = {{{tags ? value : -1, kernel}}, tags};
  return std::make_shared<fem::Form<double>>(full.function_spaces(), integrals,
                                             full.coefficients(), full.constants(), false,
                                             full.mesh());
}
} // namespace

MuscleProblem::MuscleProblem(std::shared_ptr<mesh::Mesh> mesh,
                             const ParameterSet& parameters,
                             Discretisation discretisation, bool passive,
                             std::optional<CellRegion> region,
                             std::shared_ptr<fem::Function<double>> u)
    : _mesh(mesh), _parameters(parameters), _passive(passive),
      _kernels(passive ? parameters.model().law().passive : parameters.model().name()),
      _region(region)
{
  const std::string cell = mesh::to_string(mesh->topology().cell_type());
  _variant = &forms::find_fe_variant(_kernels, cell, discretisation.degree,
                                     discretisation.quadrature_degree,
                                     discretisation.volumetric_quadrature_degree,
                                     discretisation.fbar, discretisation.taylor_hood);
  const forms::FeVariant& v = *_variant;

  _V = std::make_shared<fem::FunctionSpace>(
      fem::create_functionspace(v.function_space, "u", mesh));
  if (u)
  {
    // a part of a body: the displacement of the whole body
    if (u->function_space()->dofmap()->index_map->size_global()
        != _V->dofmap()->index_map->size_global())
      throw std::logic_error("parts of a body must share one displacement element");
    _V = std::const_pointer_cast<fem::FunctionSpace>(u->function_space());
    _u = u;
  }
  else
  {
    _u = std::make_shared<fem::Function<double>>(_V);
    _u->name = "displacement";
  }
  const std::int32_t num_owned = num_local_cells(*mesh, false);
  if (region)
  {
    for (std::size_t i = 0; i < region->tags->indices().size(); ++i)
      if (region->tags->values()[i] == region->value)
        _cells.push_back(region->tags->indices()[i]);
  }
  else
  {
    _cells.resize(num_local_cells(*mesh, true));
    std::iota(_cells.begin(), _cells.end(), 0);
  }
  std::copy_if(_cells.begin(), _cells.end(), std::back_inserter(_owned_cells),
               [num_owned](std::int32_t c) { return c < num_owned; });
  _fibre = std::make_shared<fem::Function<double>>(cell_space(3));
  _fibre->name = "fibre";
  _scale = std::make_shared<fem::Function<double>>(cell_space(1));
  _scale->name = "activation_scale";
  std::fill(_scale->x()->mutable_array().begin(),
            _scale->x()->mutable_array().end(), 1.0);
  set_fibre({0, 0, 1});

  std::map<std::string, std::shared_ptr<const fem::Function<double>>> coefficients
      = {{"u", _u}, {"fibre", _fibre}, {"activation_scale", _scale}};
  if (v.fbar)
  {
    _fbar = std::make_shared<FbarElement>(*v.fbar);
    _fbar_J0 = std::make_shared<fem::Function<double>>(cell_space(1));
    _fbar_J0->name = "fbar_J0";
    std::fill(_fbar_J0->x()->mutable_array().begin(), _fbar_J0->x()->mutable_array().end(),
              1.0);
    coefficients["fbar_J0"] = _fbar_J0;
    _fbar_pressure = std::make_shared<fem::Function<double>>(cell_space(1));
    _fbar_pressure->name = "fbar_pressure";
    coefficients["fbar_pressure"] = _fbar_pressure;
  }
  if (v.taylor_hood)
  {
    if (region)
      throw InputError("Taylor-Hood elements are built for a body of one material (one "
                       "part); this body has several");
    auto Q = std::make_shared<fem::FunctionSpace>(
        fem::create_functionspace(v.function_space, "th_state", mesh));
    _th_state = std::make_shared<fem::Function<double>>(Q);
    _th_state->name = "theta_pressure";
    reset_th_state();
    coefficients["th_state"] = _th_state;
  }
  for (const std::string& name : fem::get_coefficient_names(*v.residual))
  {
    if (name.rfind("omega_a", 0) == 0 or name.rfind("domega_a", 0) == 0
        or name.rfind("d2omega_a", 0) == 0)
    {
      auto Q = std::make_shared<fem::FunctionSpace>(
          fem::create_functionspace(v.function_space, name, mesh));
      _taylor[name] = std::make_shared<fem::Function<double>>(Q);
      coefficients[name] = _taylor[name];
    }
  }

  std::map<std::string, std::shared_ptr<const fem::Constant<double>>> constants;
  for (const std::string& name : parameters.names())
  {
    _constants[name] = std::make_shared<fem::Constant<double>>(parameters[name]);
    constants[name] = _constants[name];
  }
  _constants["time_factor"] = std::make_shared<fem::Constant<double>>(0.0);
  constants["time_factor"] = _constants["time_factor"];

  _residual = std::make_shared<fem::Form<double>>(
      fem::create_form<double>(*v.residual, {_V}, coefficients, constants, {}));
  _jacobian = std::make_shared<fem::Form<double>>(
      fem::create_form<double>(*v.jacobian, {_V, _V}, coefficients, constants, {}));
  _volume = std::make_shared<fem::Form<double>>(
      fem::create_form<double>(*v.volume, {}, coefficients, constants, {}, mesh));
  _energy = std::make_shared<fem::Form<double>>(
      fem::create_form<double>(*v.energy, {}, coefficients, constants, {}, mesh));
  if (v.taylor_hood)
  {
    auto Q = _th_state->function_space();
    auto form = [&](const ufcx_form* f, std::vector<std::shared_ptr<const fem::FunctionSpace>> spaces)
    {
      return std::make_shared<const fem::Form<double>>(
          fem::create_form<double>(*f, spaces, coefficients, constants, {}));
    };
    _th_forms = {form(v.taylor_hood->residual, {Q}), form(v.taylor_hood->jacobian_uq, {_V, Q}),
                 form(v.taylor_hood->jacobian_qu, {Q, _V}),
                 form(v.taylor_hood->jacobian_qq, {Q, Q})};
  }
  _residual_kernel = _fbar ? _fbar->residual(*v.residual, *_residual)
                          : cell_kernel(*v.residual, *_residual, v.residual_volumetric);
  const Kernel jacobian_kernel
      = _fbar ? _fbar->jacobian(*v.jacobian, *_jacobian)
              : cell_kernel(*v.jacobian, *_jacobian, v.jacobian_volumetric);
  if (v.residual_volumetric or _fbar)
  {
    _residual = with_kernel(_residual_kernel, *_residual, nullptr, 0);
    _jacobian = with_kernel(jacobian_kernel, *_jacobian, nullptr, 0);
  }
  if (region)
  {
    _residual = with_kernel(_residual_kernel, *_residual, region->tags.get(), region->value);
    _jacobian = with_kernel(jacobian_kernel, *_jacobian, region->tags.get(), region->value);
    _volume = with_kernel(cell_kernel(*v.volume, *_volume, nullptr), *_volume,
                          region->tags.get(), region->value);
    _energy = with_kernel(cell_kernel(*v.energy, *_energy, nullptr), *_energy,
                          region->tags.get(), region->value);
  }
  if (v.fibre_stretch)
  {
    _stretch_expression = std::make_shared<fem::Expression<double>>(
        fem::create_expression<double>(*v.fibre_stretch, coefficients, constants,
                                       mesh));
  }
  _post_expression = std::make_shared<fem::Expression<double>>(
      fem::create_expression<double>(*v.post, coefficients, constants, mesh));
  if (_fbar)
  {
    _centre_dilatation = std::make_shared<fem::Expression<double>>(
        fem::create_expression<double>(*v.fbar->centre_dilatation, coefficients, constants,
                                       mesh));
  }

  const auto cell_type = mesh::cell_type_to_basix_type(mesh->topology().cell_type());
  _quadrature_weights = basix::quadrature::make_quadrature(
      cell_type, v.quadrature_degree)[1];
}

int MuscleProblem::quadrature_degree() const
{
  return _variant->quadrature_degree;
}

bool MuscleProblem::reduced_volumetric() const
{
  return _variant->volumetric_quadrature_degree != _variant->quadrature_degree;
}

std::shared_ptr<fem::FunctionSpace> MuscleProblem::cell_space(int block_size) const
{
  const auto cell_type = mesh::cell_type_to_basix_type(_mesh->topology().cell_type());
  const basix::FiniteElement e = basix::create_element(
      basix::element::family::P, cell_type, 0,
      basix::element::lagrange_variant::equispaced, true);
  return std::make_shared<fem::FunctionSpace>(
      fem::create_functionspace(_mesh, e, block_size));
}

void MuscleProblem::set_fibre(std::array<double, 3> d)
{
  const double n = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  if (!(n > 0))
    throw InputError("fibre direction must be a non-zero vector");
  std::span<double> x = _fibre->x()->mutable_array();
  for (std::size_t i = 0; i < x.size(); ++i)
    x[i] = d[i % 3] / n;
}

void MuscleProblem::set_fibre(const fem::Function<double>& fibre)
{
  std::span<const double> in = fibre.x()->array();
  std::span<double> out = _fibre->x()->mutable_array();
  if (in.size() != out.size())
    throw std::logic_error("set_fibre: fibre field on a different space");
  std::copy(in.begin(), in.end(), out.begin());
}

std::shared_ptr<fem::Form<double>> MuscleProblem::residual_on_cells(
    std::shared_ptr<const mesh::MeshTags<std::int32_t>> cells, int value) const
{
  return with_kernel(_residual_kernel, *_residual, cells.get(), value);
}

void MuscleProblem::set_time_factor(double factor)
{
  _time_factor = _passive ? 0.0 : factor;
  _constants.at("time_factor")->value = {_time_factor};
}

void MuscleProblem::reset_fbar_theta() const
{
  if (!_fbar)
    return;
  // owned and ghost cells: every rank evaluates its ghosts itself
  xt::xtensor<double, 2> J0({_cells.size(), 1});
  _centre_dilatation->eval(std::span<const std::int32_t>(_cells), J0);
  const auto& dofmap = *_fbar_J0->function_space()->dofmap();
  std::span<double> x = _fbar_J0->x()->mutable_array();
  for (std::size_t i = 0; i < _cells.size(); ++i)
    x[dofmap.cell_dofs(_cells[i])[0]] = J0(i, 0);
}

void MuscleProblem::reset_th_state()
{
  std::span<double> q = _th_state->x()->mutable_array();
  for (std::size_t i = 0; i < q.size(); ++i)
    q[i] = i % 2 == 0 ? 1.0 : 0.0;
}

void MuscleProblem::update_centre_dilatation() const
{
  if (!_hold_theta)
    reset_fbar_theta();
}

std::shared_ptr<fem::Form<double>>
MuscleProblem::fbar_three_field_form(bool jacobian, FbarElement::CellData& data) const
{
  if (!_fbar)
    throw std::logic_error("fbar_three_field_form: not an F-bar problem");
  const fem::Form<double>& carrier = jacobian ? *_jacobian : *_residual;
  const ufcx_form& ufcx = jacobian ? *_variant->jacobian : *_variant->residual;
  Kernel kernel = jacobian ? _fbar->three_field_jacobian(ufcx, carrier, data)
                           : _fbar->three_field_residual(ufcx, carrier, data);
  return with_kernel(kernel, carrier, _region ? _region->tags.get() : nullptr,
                     _region ? _region->value : 0);
}

KernelStatus MuscleProblem::update_activation()
{
  KernelStatus status;
  update_centre_dilatation();
  if (_taylor.empty())
    return status;

  // fibre stretch at the quadrature points of owned and ghost cells: every
  // rank evaluates its ghosts itself, so no communication is needed
  const std::vector<std::int32_t>& cells = _cells;
  const std::size_t nq = _quadrature_weights.size();
  xt::xtensor<double, 2> stretch({cells.size(), nq});
  _stretch_expression->eval(std::span<const std::int32_t>(cells), stretch);

  const Model& model = _parameters.model();
  const EhretParameters p = ehret_parameters(_parameters);
  const auto& dofmap = *_taylor.begin()->second->function_space()->dofmap();
  const auto& scale_dofmap = *_scale->function_space()->dofmap();
  std::span<const double> scale = _scale->x()->array();
  auto get = [&](const char* name) -> std::span<double>
  {
    auto it = _taylor.find(name);
    return it == _taylor.end() ? std::span<double>()
                               : it->second->x()->mutable_array();
  };
  std::span<double> lambda0 = get("omega_a_lambda"), w0 = get("omega_a"),
                    w1 = get("domega_a"), w2 = get("d2omega_a");

  for (std::size_t i = 0; i < cells.size(); ++i)
  {
    const std::int32_t c = cells[i];
    const double level = activation_level(
        _parameters, _time_factor, scale[scale_dofmap.cell_dofs(c)[0]]);
    auto dofs = dofmap.cell_dofs(c);
    for (std::size_t q = 0; q < nq; ++q)
    {
      const double l = stretch(i, q);
      const OmegaTaylor w = activation_kernel(model, l, level, p, _root_tolerance);
      if (!w.ok)
      {
        if (status.failures++ == 0)
        {
          status.worst_cell = c;
          status.stretch = l;
        }
      }
      const std::int32_t d = dofs[q];
      lambda0[d] = l;
      w0[d] = w.value;
      w1[d] = w.d1;
      if (!w2.empty())
        w2[d] = w.d2;
    }
  }
  return status;
}

double MuscleProblem::volume() const { return sum_over_ranks(*_volume); }

double MuscleProblem::strain_energy() const
{
  update_centre_dilatation();
  return sum_over_ranks(*_energy);
}

double MuscleProblem::sum_over_ranks(const fem::Form<double>& functional) const
{
  const double local = fem::assemble_scalar(functional);
  double total = 0;
  MPI_Allreduce(&local, &total, 1, MPI_DOUBLE, MPI_SUM, _mesh->comm());
  return total;
}

MuscleProblem::PostFields MuscleProblem::post_fields() const
{
  update_centre_dilatation();
  const std::vector<std::int32_t>& cells = _owned_cells;
  const std::size_t nq = _quadrature_weights.size();
  xt::xtensor<double, 2> values({cells.size(), post_size * nq});
  _post_expression->eval(std::span<const std::int32_t>(cells), values);

  PostFields out;
  const char* names[post_size]
      = {"fibre_stretch", "fibre_cauchy_stress", "von_mises_stress", "J", "von_mises_strain"};
  std::shared_ptr<fem::Function<double>>* fields[post_size]
      = {&out.fibre_stretch, &out.fibre_stress, &out.von_mises, &out.J, &out.von_mises_strain};
  const double weight_sum = std::accumulate(_quadrature_weights.begin(),
                                            _quadrature_weights.end(), 0.0);
  auto space = cell_space(1);
  for (int k = 0; k < post_size; ++k)
  {
    *fields[k] = std::make_shared<fem::Function<double>>(space);
    (*fields[k])->name = names[k];
    std::span<double> x = (*fields[k])->x()->mutable_array();
    for (std::size_t c = 0; c < cells.size(); ++c)
    {
      double average = 0;
      for (std::size_t q = 0; q < nq; ++q)
        average += _quadrature_weights[q] * values(c, post_size * q + k);
      x[space->dofmap()->cell_dofs(cells[c])[0]] = average / weight_sum;
    }
    (*fields[k])->x()->scatter_fwd();
  }
  return out;
}

std::pair<double, std::int32_t> MuscleProblem::min_jacobian_determinant() const
{
  update_centre_dilatation();
  const std::vector<std::int32_t>& cells = _owned_cells;
  const std::size_t nq = _quadrature_weights.size();
  xt::xtensor<double, 2> values({cells.size(), post_size * nq});
  _post_expression->eval(std::span<const std::int32_t>(cells), values);
  std::pair<double, std::int32_t> worst{std::numeric_limits<double>::infinity(), -1};
  for (std::size_t c = 0; c < cells.size(); ++c)
    for (std::size_t q = 0; q < nq; ++q)
    {
      const double J = values(c, post_size * q + 3);
      if (!(J >= worst.first)) // NaN counts as worst
        worst = {J, cells[c]};
    }
  return worst;
}

} // namespace muscle
