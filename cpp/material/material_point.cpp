#include "material/material_point.h"

#include "common/errors.h"
#include "forms/form_registry.h"

#include <stdexcept>
#include <ufcx.h>

namespace muscle
{

double activation_level(const ParameterSet& p, double time_factor, double scale)
{
  return p["P_opt"] * time_factor * scale;
}

EhretParameters ehret_parameters(const ParameterSet& p)
{
  return {p["alpha"],   p["beta"],       p["gamma"],
          p["omega_0"], p["lambda_min"], p["lambda_opt"]};
}

OmegaKernel omega_kernel_of(const Model& model)
{
  return find_omega_kernel(model.law().omega_kernel,
                           "law " + model.name() + " (" + model.law().source + ")");
}

OmegaTaylor activation_kernel(const Model& model, double stretch, double level,
                              const EhretParameters& p, double root_tolerance)
{
  // called per quadrature point: the lookup once per law and thread
  thread_local const forms::LawInfo* law = nullptr;
  thread_local OmegaKernel kernel = nullptr;
  if (law != &model.law())
  {
    kernel = omega_kernel_of(model);
    law = &model.law();
  }
  return kernel(stretch, level, p, root_tolerance);
}

namespace
{
const forms::MaterialPointVariant& variant_of(const void* v)
{
  return *static_cast<const forms::MaterialPointVariant*>(v);
}
} // namespace

MaterialPointModel::MaterialPointModel(const ParameterSet& parameters,
                                       std::string kernels)
    : _parameters(parameters),
      _kernels(kernels.empty() ? to_string(parameters.model()) : kernels),
      _variant(&forms::find_material_point_variant(_kernels))
{
}

bool MaterialPointModel::has_activation_kernel() const
{
  // a law's passive counterpart has no omega_a
  return _kernels == _parameters.model().name() and _parameters.model().has_activation_kernel();
}

std::vector<double> MaterialPointModel::evaluate(const ufcx_expression& e,
                                                 const MaterialPoint& x,
                                                 const OmegaTaylor& omega) const
{
  std::vector<double> w;
  for (int i = 0; i < e.num_coefficients; ++i)
  {
    const std::string name = e.coefficient_names[i];
    if (name == "H")
      w.insert(w.end(), x.H.begin(), x.H.end());
    else if (name == "fibre")
      w.insert(w.end(), x.fibre.begin(), x.fibre.end());
    else if (name == "activation_scale")
      w.push_back(x.activation_scale);
    else if (name == "omega_a_lambda")
      w.push_back(fibre_stretch(x));
    else if (name == "omega_a")
      w.push_back(omega.value);
    else if (name == "domega_a")
      w.push_back(omega.d1);
    else if (name == "d2omega_a")
      w.push_back(omega.d2);
    else
      throw std::logic_error("material point: unexpected coefficient " + name);
  }
  std::vector<double> c;
  for (int i = 0; i < e.num_constants; ++i)
  {
    const std::string name = e.constant_names[i];
    c.push_back(name == "time_factor" ? _time_factor : _parameters[name]);
  }
  std::size_t size = 1;
  for (int i = 0; i < e.num_components; ++i)
    size *= e.value_shape[i];
  std::vector<double> values(size * e.num_points, 0.0);
  // the material-point kernels do not depend on the geometry: any cell will do
  static const std::array<double, 24> unit_hexahedron
      = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0, 0, 0, 1, 1, 0, 1, 0, 1, 1, 1, 1, 1};
  e.tabulate_tensor_float64(values.data(), w.data(), c.data(),
                            unit_hexahedron.data(), nullptr, nullptr);
  return values;
}

double MaterialPointModel::fibre_stretch(const MaterialPoint& x) const
{
  // fibre stretch needs no omega_a: evaluate it with a zero Taylor polynomial
  const ufcx_expression& e = *variant_of(_variant).fibre_stretch;
  std::vector<double> w(x.H.begin(), x.H.end());
  w.insert(w.end(), x.fibre.begin(), x.fibre.end());
  if (e.num_coefficients != 2)
    throw std::logic_error("fibre_stretch expression: expected H and fibre");
  double value = 0;
  static const std::array<double, 24> coords{};
  e.tabulate_tensor_float64(&value, w.data(), nullptr, coords.data(), nullptr,
                            nullptr);
  return value;
}

OmegaTaylor MaterialPointModel::activation(const MaterialPoint& x) const
{
  if (!has_activation_kernel())
    return {};
  const double level
      = activation_level(_parameters, _time_factor, x.activation_scale);
  return activation_kernel(_parameters.model(), fibre_stretch(x), level,
                           ehret_parameters(_parameters));
}

double MaterialPointModel::energy(const MaterialPoint& x) const
{
  return energy(x, activation(x));
}

double MaterialPointModel::energy(const MaterialPoint& x,
                                  const OmegaTaylor& omega) const
{
  return evaluate(*variant_of(_variant).energy, x, omega)[0];
}

Matrix3 MaterialPointModel::stress(const MaterialPoint& x) const
{
  return stress(x, activation(x));
}

Matrix3 MaterialPointModel::stress(const MaterialPoint& x,
                                   const OmegaTaylor& omega) const
{
  const std::vector<double> v = evaluate(*variant_of(_variant).stress, x, omega);
  Matrix3 P;
  std::copy(v.begin(), v.end(), P.begin());
  return P;
}

Tangent3 MaterialPointModel::tangent(const MaterialPoint& x) const
{
  const std::vector<double> v
      = evaluate(*variant_of(_variant).tangent, x, activation(x));
  Tangent3 A;
  std::copy(v.begin(), v.end(), A.begin());
  return A;
}

MaterialPoint point_at(const Matrix3& F)
{
  MaterialPoint x;
  for (int i = 0; i < 9; ++i)
    x.H[i] = F[i] - (i % 4 == 0 ? 1.0 : 0.0);
  return x;
}

} // namespace muscle
