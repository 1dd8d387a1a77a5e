#include "fem/elements/fbar_unknowns.h"

#include "fem/elements/muscle_problem.h"

#include <cmath>
#include <dolfinx/fem/assembler.h>
#include <dolfinx/fem/petsc.h>
#include <dolfinx/la/petsc.h>

using namespace dolfinx;

namespace muscle
{
namespace
{
int cell_integral_id(const fem::Form<double>& form)
{
  const std::vector<int> ids = form.integral_ids(fem::IntegralType::cell);
  if (ids.size() != 1)
    throw std::logic_error("three-field F-bar: expected one cell integral");
  return ids.front();
}
} // namespace

FbarCellUnknowns::FbarCellUnknowns(
    MuscleProblem& part, const std::vector<std::shared_ptr<const fem::DirichletBC<double>>>& bcs)
    : _part(part), _bcs(bcs)
{
  _residual = part.fbar_three_field_form(false, _data);
  _jacobian = part.fbar_three_field_form(true, _data);
  _cells = _residual->cell_domains(cell_integral_id(*_residual));

  const auto& dofmap = *part.V()->dofmap();
  const int bs = dofmap.bs();
  const std::size_t n = dofmap.cell_dofs(0).size() * bs;
  _data.resize(_cells.size(), n);
  for (std::int32_t c : _cells)
    for (std::int32_t d : dofmap.cell_dofs(c))
      for (int k = 0; k < bs; ++k)
        _cell_dofs.push_back(bs * d + k);
  const auto& theta_dofmap = *part.fbar_theta()->function_space()->dofmap();
  for (std::int32_t c : _cells)
    _theta_dofs.push_back(theta_dofmap.cell_dofs(c)[0]);

  const auto map = dofmap.index_map;
  _fixed.assign((map->size_local() + map->num_ghosts()) * bs, 0);
  for (const auto& bc : bcs)
  {
    auto [dofs, owned] = bc->dof_indices();
    for (std::int32_t d : dofs)
      _fixed[d] = 1;
  }
}

std::vector<double> FbarCellUnknowns::widened_coefficients(const fem::Form<double>& form) const
{
  const int id = cell_integral_id(form);
  const int width = form.coefficient_offsets().back();
  std::vector<double> w(_cells.size() * (width + 1));
  fem::pack_coefficients(form, fem::IntegralType::cell, id, std::span<double>(w), width + 1);
  for (std::size_t i = 0; i < _cells.size(); ++i)
    w[i * (width + 1) + width] = static_cast<double>(i);
  return w;
}

void FbarCellUnknowns::initialise()
{
  _part.reset_fbar_theta();
  auto p = _part.fbar_pressure()->x();
  std::fill(p->mutable_array().begin(), p->mutable_array().end(), 0.0);
  _part.update_activation(); // omega_a at the new theta (WKM, GIANT)
  const auto map = _part.V()->dofmap()->index_map;
  std::vector<double> b((map->size_local() + map->num_ghosts()) * _part.V()->dofmap()->bs());
  std::vector<double> r(size());
  residual(b, r);
  std::span<double> pressure = p->mutable_array();
  for (std::size_t i = 0; i < _cells.size(); ++i)
    pressure[_theta_dofs[i]] = r[2 * i]; // R_theta = r_0 - 0
  p->scatter_fwd();
}

void FbarCellUnknowns::set(std::span<const double> x)
{
  std::span<double> theta = _part.fbar_theta()->x()->mutable_array();
  std::span<double> p = _part.fbar_pressure()->x()->mutable_array();
  for (std::size_t i = 0; i < _cells.size(); ++i)
  {
    theta[_theta_dofs[i]] = x[2 * i];
    p[_theta_dofs[i]] = x[2 * i + 1];
  }
  _part.fbar_theta()->x()->scatter_fwd();
  _part.fbar_pressure()->x()->scatter_fwd();
}

void FbarCellUnknowns::get(std::span<double> x) const
{
  std::span<const double> theta = _part.fbar_theta()->x()->array();
  std::span<const double> p = _part.fbar_pressure()->x()->array();
  for (std::size_t i = 0; i < _cells.size(); ++i)
  {
    x[2 * i] = theta[_theta_dofs[i]];
    x[2 * i + 1] = p[_theta_dofs[i]];
  }
}

double FbarCellUnknowns::residual(std::span<double> b, std::span<double> r)
{
  const std::vector<double> w = widened_coefficients(*_residual);
  const std::vector<double> constants = fem::pack_constants(*_residual);
  const int width = _residual->coefficient_offsets().back() + 1;
  fem::assemble_vector<double>(
      b, *_residual, std::span<const double>(constants),
      {{{fem::IntegralType::cell, cell_integral_id(*_residual)}, {std::span<const double>(w), width}}});
  double violation = 0;
  for (std::size_t i = 0; i < _cells.size(); ++i)
  {
    r[2 * i] = _data.R_theta[i];
    r[2 * i + 1] = _data.R_p[i];
    violation = std::max(violation, std::abs(_data.R_p[i]));
    if (std::isnan(_data.R_p[i]) or std::isnan(_data.R_theta[i]))
      violation = std::numeric_limits<double>::quiet_NaN();
  }
  return violation;
}

void FbarCellUnknowns::jacobian(Mat A)
{
  const std::vector<double> w = widened_coefficients(*_jacobian);
  const std::vector<double> constants = fem::pack_constants(*_jacobian);
  const int width = _jacobian->coefficient_offsets().back() + 1;
  // Dirichlet rows zeroed (set_diagonal puts the identity there), columns kept:
  // the residual is not lifted, so K is the true derivative also while the
  // boundary values are not yet met (a damped step leaves them unmet)
  fem::assemble_matrix(
      la::petsc::Matrix::set_block_fn(A, ADD_VALUES), *_jacobian,
      std::span<const double>(constants),
      {{{fem::IntegralType::cell, cell_integral_id(*_jacobian)}, {std::span<const double>(w), width}}},
      std::span<const std::int8_t>(_fixed), std::span<const std::int8_t>());
}

double FbarCellUnknowns::dot(std::size_t cell, const std::vector<double>& a,
                             std::span<const double> du) const
{
  const std::size_t n = _data.n;
  double s = 0;
  for (std::size_t j = 0; j < n; ++j)
    s += a[cell * n + j] * du[_cell_dofs[cell * n + j]];
  return s;
}

bool FbarCellUnknowns::linearisation_is_finite() const
{
  for (const std::vector<double>* v :
       {&_data.R_theta, &_data.R_p, &_data.K00, &_data.g, &_data.K_u0, &_data.K_0u})
    for (double x : *v)
      if (!std::isfinite(x))
        return false;
  return true;
}

// Dirichlet dofs: identity rows, full columns everywhere (no lifting), so
// the elimination below is exact; recovery and product run over every dof.

void FbarCellUnknowns::condense(std::span<const double> b_cells, std::span<double> b_u) const
{
  // K du = b_u + K_u0 b_p + g (K_00 b_p + b_theta) on the free rows (K: the
  // condensed tangent, Dirichlet columns kept)
  const std::size_t n = _data.n;
  for (std::size_t i = 0; i < _cells.size(); ++i)
  {
    const double b_theta = b_cells[2 * i], b_p = b_cells[2 * i + 1];
    for (std::size_t j = 0; j < n; ++j)
    {
      const std::int32_t d = _cell_dofs[i * n + j];
      if (!_fixed[d])
        b_u[d] += _data.K_u0[i * n + j] * b_p
                  + _data.g[i * n + j] * (_data.K00[i] * b_p + b_theta);
    }
  }
}

void FbarCellUnknowns::recover(std::span<const double> du, std::span<const double> b_cells,
                               std::span<double> d_cells) const
{
  // p row: g^T du - dtheta = b_p;  theta row: K_0u du + K_00 dtheta - dp = b_theta
  // (every dof: du holds the Dirichlet part too)
  for (std::size_t i = 0; i < _cells.size(); ++i)
  {
    const double b_theta = b_cells[2 * i], b_p = b_cells[2 * i + 1];
    const double dtheta = dot(i, _data.g, du) - b_p;
    d_cells[2 * i] = dtheta;
    d_cells[2 * i + 1] = dot(i, _data.K_0u, du) + _data.K00[i] * dtheta - b_theta;
  }
}

void FbarCellUnknowns::multiply(std::span<const double> du, std::span<const double> d_cells,
                                std::span<double> y_u, std::span<double> y_cells) const
{
  const std::size_t n = _data.n;
  for (std::size_t i = 0; i < _cells.size(); ++i)
  {
    const double dtheta = d_cells[2 * i], dp = d_cells[2 * i + 1];
    const double gdu = dot(i, _data.g, du), Kdu = dot(i, _data.K_0u, du);
    y_cells[2 * i] = Kdu + _data.K00[i] * dtheta - dp;
    y_cells[2 * i + 1] = gdu - dtheta;
    // free rows: K du + K_u0 (dtheta - g du) + g (dp - K_0u du - K_00 g du)
    for (std::size_t j = 0; j < n; ++j)
    {
      const std::int32_t d = _cell_dofs[i * n + j];
      if (!_fixed[d])
        y_u[d] += _data.K_u0[i * n + j] * (dtheta - gdu)
                  + _data.g[i * n + j] * (dp - Kdu - _data.K00[i] * gdu);
    }
  }
}

} // namespace muscle
