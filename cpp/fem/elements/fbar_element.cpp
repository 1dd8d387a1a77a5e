#include "fem/elements/fbar_element.h"

#include "forms/form_registry.h"

#include <algorithm>
#include <cmath>
#include <dolfinx/fem/utils.h>
#include <stdexcept>

using namespace dolfinx;

namespace muscle
{
namespace
{
using UfcxKernel = void (*)(double*, const double*, const double*, const double*, const int*,
                            const std::uint8_t*);

UfcxKernel cell_kernel_of(const ufcx_form& form)
{
  if (form.num_integrals(cell) != 1)
    throw std::logic_error("F-bar: expected one cell integral");
  return form.integrals(cell)[0]->tabulate_tensor_float64;
}

/// Where a kernel's packed coefficients and constants come from in a carrier's
/// arrays; index -1 is the J0 slot of the mixed state (u, J0).
struct Gather
{
  std::vector<int> w, c;

  void apply(const double* w_in, const double* c_in, double J0, std::vector<double>& w_out,
             std::vector<double>& c_out) const
  {
    for (std::size_t i = 0; i < w.size(); ++i)
      w_out[i] = w[i] < 0 ? J0 : w_in[w[i]];
    for (std::size_t i = 0; i < c.size(); ++i)
      c_out[i] = c_in[c[i]];
  }
};

Gather make_gather(const ufcx_form& target, const ufcx_form& carrier,
                   const fem::Form<double>& form)
{
  const std::vector<std::string> names = fem::get_coefficient_names(carrier);
  const std::vector<int> offsets = form.coefficient_offsets();
  auto entries = [&](const std::string& name, std::vector<int>& out)
  {
    auto it = std::find(names.begin(), names.end(), name);
    if (it == names.end())
      throw std::logic_error("F-bar kernel reads " + name + ", its carrier form has none");
    const auto i = std::distance(names.begin(), it);
    for (int k = offsets[i]; k < offsets[i + 1]; ++k)
      out.push_back(k);
  };
  Gather g;
  for (const std::string& name : fem::get_coefficient_names(target))
  {
    if (name == "fbar_state")
    {
      entries("u", g.w);
      g.w.push_back(-1);
    }
    else
      entries(name, g.w);
  }
  const std::vector<std::string> cnames = fem::get_constant_names(carrier);
  std::vector<int> coffsets = {0};
  for (const auto& c : form.constants())
    coffsets.push_back(coffsets.back() + c->value.size());
  for (const std::string& name : fem::get_constant_names(target))
  {
    auto it = std::find(cnames.begin(), cnames.end(), name);
    if (it == cnames.end())
      throw std::logic_error("F-bar kernel reads constant " + name + ", its carrier has none");
    const auto i = std::distance(cnames.begin(), it);
    for (int k = coffsets[i]; k < coffsets[i + 1]; ++k)
      g.c.push_back(k);
  }
  return g;
}

/// One cell's F-bar quantities, evaluated on demand into reusable buffers.
class CellEvaluation
{
public:
  CellEvaluation(const forms::FbarForms& f, const ufcx_form& carrier,
                 const fem::Form<double>& form)
      : _centre(cell_kernel_of(*f.centre)), _gradient(cell_kernel_of(*f.gradient)),
        _hessian(cell_kernel_of(*f.hessian)), _residual(cell_kernel_of(*f.residual)),
        _jacobian(cell_kernel_of(*f.jacobian)), _r0(cell_kernel_of(*f.r0)),
        _u(make_gather(*f.centre, carrier, form)),
        _mixed(make_gather(*f.residual, carrier, form)),
        _mixed_jacobian(make_gather(*f.jacobian, carrier, form)),
        _mixed_r0(make_gather(*f.r0, carrier, form)),
        _width(form.coefficient_offsets().back())
  {
    const std::vector<std::string> names = fem::get_coefficient_names(carrier);
    const std::vector<int> offsets = form.coefficient_offsets();
    for (std::size_t i = 0; i < names.size(); ++i)
    {
      if (names[i] == "fbar_J0")
        _theta = offsets[i];
      if (names[i] == "fbar_pressure")
        _pressure = offsets[i];
    }
    n = _u.w.size();
    wu.resize(n);
    for (const Gather* g : {&_mixed, &_mixed_jacobian, &_mixed_r0})
    {
      wm.resize(std::max(wm.size(), g->w.size()));
      cm.resize(std::max(cm.size(), g->c.size()));
    }
    R.resize(n + 1);
    K.resize((n + 1) * (n + 1));
    g.resize(n);
    G.resize(n * n);
  }

  /// J0 and g of the cell (every kernel needs them).
  void centre(const double* w, const double* x, const int* e, const std::uint8_t* p)
  {
    std::vector<double> none;
    _u.apply(w, nullptr, 0, wu, none);
    J0 = 0;
    _centre(&J0, wu.data(), nullptr, x, e, p);
    std::fill(g.begin(), g.end(), 0.0);
    _gradient(g.data(), wu.data(), nullptr, x, e, p);
  }
  void hessian(const double* x, const int* e, const std::uint8_t* p)
  {
    std::fill(G.begin(), G.end(), 0.0);
    _hessian(G.data(), wu.data(), nullptr, x, e, p);
  }
  /// theta, p and the cell's position from the (widened) packed coefficients
  double theta(const double* w) const { return w[_theta]; }
  double pressure(const double* w) const { return w[_pressure]; }
  std::size_t position(const double* w) const { return static_cast<std::size_t>(w[_width]); }

  /// The mixed kernels at (u, theta): theta is J0 for the displacement form.
  void residual(const double* w, const double* c, const double* x, const int* e,
                const std::uint8_t* p)
  {
    residual_at(J0, w, c, x, e, p);
  }
  void residual_at(double theta, const double* w, const double* c, const double* x,
                   const int* e, const std::uint8_t* p)
  {
    _mixed.apply(w, c, theta, wm, cm);
    std::fill(R.begin(), R.end(), 0.0);
    _residual(R.data(), wm.data(), cm.data(), x, e, p);
  }
  /// r_0 alone at (u, theta), for the Jacobian kernels (the whole R costs more; BENCHMARKS.md, "Assembly against Neo-Hooke")
  double r0_at(double theta, const double* w, const double* c, const double* x, const int* e,
               const std::uint8_t* p)
  {
    _mixed_r0.apply(w, c, theta, wm, cm);
    double r0 = 0;
    _r0(&r0, wm.data(), cm.data(), x, e, p);
    return r0;
  }
  void jacobian(const double* w, const double* c, const double* x, const int* e,
                const std::uint8_t* p)
  {
    jacobian_at(J0, w, c, x, e, p);
  }
  void jacobian_at(double theta, const double* w, const double* c, const double* x,
                   const int* e, const std::uint8_t* p)
  {
    _mixed_jacobian.apply(w, c, theta, wm, cm);
    std::fill(K.begin(), K.end(), 0.0);
    _jacobian(K.data(), wm.data(), cm.data(), x, e, p);
  }
  /// A += the condensed tangent; `r0` multiplies G (r_0 itself, or p)
  void add_tangent(double* A, double r0) const
  {
    const std::size_t m = n + 1;
    const double K00 = K[n * m + n];
    for (std::size_t i = 0; i < n; ++i)
    {
      const double Ki0 = K[i * m + n];
      for (std::size_t j = 0; j < n; ++j)
        A[i * n + j] += K[i * m + j] + Ki0 * g[j] + g[i] * (K[n * m + j] + K00 * g[j])
                        + r0 * G[i * n + j];
    }
  }

  std::size_t n = 0; ///< displacement dofs of the cell
  double J0 = 0;
  std::vector<double> wu, wm, cm, R, K, g, G;

private:
  UfcxKernel _centre, _gradient, _hessian, _residual, _jacobian, _r0;
  Gather _u, _mixed, _mixed_jacobian, _mixed_r0;
  int _width, _theta = -1, _pressure = -1;
};

} // namespace

FbarElement::FbarElement(const forms::FbarForms& forms) : _forms(&forms) {}

CellKernel FbarElement::residual(const ufcx_form& carrier,
                                 const fem::Form<double>& form) const
{
  auto cell = std::make_shared<CellEvaluation>(*_forms, carrier, form);
  return [cell](double* A, const double* w, const double* c, const double* x, const int* e,
                const std::uint8_t* p)
  {
    cell->centre(w, x, e, p);
    cell->residual(w, c, x, e, p);
    const std::size_t n = cell->n;
    const double r0 = cell->R[n];
    for (std::size_t i = 0; i < n; ++i)
      A[i] += cell->R[i] + r0 * cell->g[i];
  };
}

CellKernel FbarElement::jacobian(const ufcx_form& carrier,
                                 const fem::Form<double>& form) const
{
  auto cell = std::make_shared<CellEvaluation>(*_forms, carrier, form);
  return [cell](double* A, const double* w, const double* c, const double* x, const int* e,
                const std::uint8_t* p)
  {
    cell->centre(w, x, e, p);
    cell->hessian(x, e, p);
    const double r0 = cell->r0_at(cell->J0, w, c, x, e, p);
    cell->jacobian(w, c, x, e, p);
    cell->add_tangent(A, r0);
  };
}

void FbarElement::CellData::resize(std::size_t cells, std::size_t dofs)
{
  n = dofs;
  for (std::vector<double>* v : {&R_theta, &R_p, &K00})
    v->assign(cells, 0.0);
  for (std::vector<double>* v : {&g, &K_u0, &K_0u})
    v->assign(cells * dofs, 0.0);
}

CellKernel FbarElement::three_field_residual(const ufcx_form& carrier,
                                             const fem::Form<double>& form,
                                             CellData& data) const
{
  auto cell = std::make_shared<CellEvaluation>(*_forms, carrier, form);
  return [cell, &data](double* A, const double* w, const double* c, const double* x,
                       const int* e, const std::uint8_t* p)
  {
    const double theta = cell->theta(w), pressure = cell->pressure(w);
    cell->centre(w, x, e, p);
    cell->residual_at(theta, w, c, x, e, p);
    const std::size_t n = cell->n, k = cell->position(w);
    for (std::size_t i = 0; i < n; ++i)
      A[i] += cell->R[i] + pressure * cell->g[i];
    data.R_theta[k] = cell->R[n] - pressure;
    data.R_p[k] = cell->J0 - theta;
  };
}

CellKernel FbarElement::three_field_jacobian(const ufcx_form& carrier,
                                             const fem::Form<double>& form,
                                             CellData& data) const
{
  auto cell = std::make_shared<CellEvaluation>(*_forms, carrier, form);
  return [cell, &data](double* A, const double* w, const double* c, const double* x,
                       const int* e, const std::uint8_t* p)
  {
    const double theta = cell->theta(w), pressure = cell->pressure(w);
    cell->centre(w, x, e, p);
    cell->hessian(x, e, p);
    const double r0 = cell->r0_at(theta, w, c, x, e, p);
    cell->jacobian_at(theta, w, c, x, e, p);
    cell->add_tangent(A, pressure);
    const std::size_t n = cell->n, m = n + 1, k = cell->position(w);
    data.R_theta[k] = r0 - pressure;
    data.R_p[k] = cell->J0 - theta;
    data.K00[k] = cell->K[n * m + n];
    for (std::size_t i = 0; i < n; ++i)
    {
      data.g[k * n + i] = cell->g[i];
      data.K_u0[k * n + i] = cell->K[i * m + n];
      data.K_0u[k * n + i] = cell->K[n * m + i];
    }
  };
}

} // namespace muscle
