#include "fem/time/generalized_alpha.h"

#include "common/errors.h"
#include "fem/constraints/constraint.h"
#include "fem/terms/loads.h"

#include <dolfinx/fem/assembler.h>
#include <dolfinx/fem/petsc.h>
#include <dolfinx/la/petsc.h>
#include <petscksp.h>

using namespace dolfinx;

namespace muscle
{

AlphaParameters::AlphaParameters(double rho_inf)
{
  if (!(rho_inf >= 0 and rho_inf <= 1))
    throw InputError("generalized-alpha: rho_inf = " + std::to_string(rho_inf)
                     + " is outside [0, 1]");
  alpha_m = (2 * rho_inf - 1) / (rho_inf + 1);
  alpha_f = rho_inf / (rho_inf + 1);
  gamma = 0.5 - alpha_m + alpha_f;
  beta = 0.25 * (1 - alpha_m + alpha_f) * (1 - alpha_m + alpha_f);
}

namespace
{
Mat assemble_mass(const fem::Form<double>& mass,
                  const std::vector<std::shared_ptr<const fem::DirichletBC<double>>>& bcs)
{
  Mat M = fem::petsc::create_matrix(mass);
  MatZeroEntries(M);
  fem::assemble_matrix(la::petsc::Matrix::set_block_fn(M, ADD_VALUES), mass, bcs);
  MatAssemblyBegin(M, MAT_FINAL_ASSEMBLY);
  MatAssemblyEnd(M, MAT_FINAL_ASSEMBLY);
  return M;
}

std::shared_ptr<fem::Function<double>> zero_like(const fem::Function<double>& u,
                                                 const std::string& name)
{
  auto f = std::make_shared<fem::Function<double>>(u.function_space());
  f->name = name;
  return f;
}
} // namespace

GeneralizedAlpha::GeneralizedAlpha(
    std::shared_ptr<fem::Function<double>> u, const std::vector<double>& density,
    std::vector<std::shared_ptr<const fem::DirichletBC<double>>> bcs, double rho_inf)
    : _u(std::move(u)), _v(zero_like(*_u, "velocity")), _a(zero_like(*_u, "acceleration")),
      _r(zero_like(*_u, "forces")), _p(rho_inf)
{
  const auto V = _u->function_space();
  const auto mass = mass_form(V, density_function(V->mesh(), density));
  _M = MatHandle(assemble_mass(*mass, {}));
  _M_bc = MatHandle(assemble_mass(*mass, bcs));
  {
    // the fixed dofs: their rows of _M_bc are empty (every part has a density)
    Vec diagonal;
    MatCreateVecs(_M_bc, &diagonal, nullptr);
    MatGetDiagonal(_M_bc, diagonal);
    PetscInt begin, end;
    VecGetOwnershipRange(diagonal, &begin, &end);
    const PetscScalar* d;
    VecGetArrayRead(diagonal, &d);
    std::vector<PetscInt> fixed;
    for (PetscInt i = begin; i < end; ++i)
    {
      _free.push_back(d[i - begin] != 0);
      if (!_free.back())
        fixed.push_back(i);
    }
    VecRestoreArrayRead(diagonal, &d);
    VecDestroy(&diagonal);
    MatDuplicate(_M, MAT_COPY_VALUES, _M_rows.out());
    MatZeroRows(_M_rows, fixed.size(), fixed.data(), 0.0, nullptr, nullptr);
  }
  _u_vec = VecHandle(la::petsc::create_vector_wrap(*_u->x()));
  _v_vec = VecHandle(la::petsc::create_vector_wrap(*_v->x()));
  _a_vec = VecHandle(la::petsc::create_vector_wrap(*_a->x()));
  _r_vec = VecHandle(la::petsc::create_vector_wrap(*_r->x()));
  VecDuplicate(_u_vec, _u_n.out());
  VecDuplicate(_u_vec, _w.out());
  VecDuplicate(_u_vec, _Mw.out());
  VecCopy(_u_vec, _u_n);
}

void GeneralizedAlpha::start(const la::Vector<double>& r0,
                             const DisplacementConstraint* constraint)
{
  VecCopy(_u_vec, _u_n);
  // r_0 on the owned dofs (r0 is laid out as u)
  {
    PetscScalar* r;
    VecGetArray(_r_vec, &r);
    const PetscInt n = r0.map()->size_local() * r0.bs();
    std::copy_n(r0.array().begin(), n, r);
    VecRestoreArray(_r_vec, &r);
  }
  _r->x()->scatter_fwd();
  PetscReal norm;
  VecNorm(_r_vec, NORM_INFINITY, &norm);
  VecZeroEntries(_a_vec);
  if (norm == 0)
    return;

  // M a_0 = -r_0 on the free dofs: the mass with unit rows at the fixed dofs
  // (their rows and columns are empty) and a zero right-hand side there
  Mat M;
  MatDuplicate(_M_bc, MAT_COPY_VALUES, &M);
  Vec rhs, diagonal;
  VecDuplicate(_r_vec, &rhs);
  VecDuplicate(_r_vec, &diagonal);
  {
    PetscScalar *d, *b;
    const PetscScalar* r;
    VecGetArray(diagonal, &d);
    VecGetArray(rhs, &b);
    VecGetArrayRead(_r_vec, &r);
    for (std::size_t i = 0; i < _free.size(); ++i)
    {
      b[i] = _free[i] ? -r[i] : 0;
      d[i] = _free[i] ? 0 : 1;
    }
    VecRestoreArrayRead(_r_vec, &r);
    VecRestoreArray(rhs, &b);
    VecRestoreArray(diagonal, &d);
  }
  MatDiagonalSet(M, diagonal, ADD_VALUES);
  VecDestroy(&diagonal);
  KSP ksp;
  KSPCreate(PetscObjectComm((PetscObject)M), &ksp);
  KSPSetType(ksp, KSPCG);
  PC pc;
  KSPGetPC(ksp, &pc);
  PCSetType(pc, PCJACOBI);
  KSPSetTolerances(ksp, 1e-14, 1e-300, PETSC_DEFAULT, 10000);
  if (constraint)
  {
    Mat M_red;
    MatPtAP(M, constraint->T(), MAT_INITIAL_MATRIX, PETSC_DEFAULT, &M_red);
    Vec b_red = constraint->create_reduced_vector(), y;
    VecDuplicate(b_red, &y);
    MatMultTranspose(constraint->T(), rhs, b_red);
    KSPSetOperators(ksp, M_red, M_red);
    KSPSolve(ksp, b_red, y);
    MatMult(constraint->T(), y, _a_vec);
    VecDestroy(&b_red);
    VecDestroy(&y);
    MatDestroy(&M_red);
  }
  else
  {
    KSPSetOperators(ksp, M, M);
    KSPSolve(ksp, rhs, _a_vec);
  }
  KSPConvergedReason reason;
  KSPGetConvergedReason(ksp, &reason);
  KSPDestroy(&ksp);
  VecDestroy(&rhs);
  MatDestroy(&M);
  if (reason < 0)
    throw SolveError("generalized-alpha: the initial acceleration M a_0 = -r_0 did not solve "
                     "(KSP reason " + std::to_string(reason) + ")");
  _a->x()->scatter_fwd();
}

void GeneralizedAlpha::set_velocity(std::array<double, 3> v)
{
  PetscScalar* x;
  VecGetArray(_v_vec, &x);
  for (std::size_t i = 0; i < _free.size(); ++i)
    x[i] = _free[i] ? v[i % 3] : 0.0;
  VecRestoreArray(_v_vec, &x);
  _v->x()->scatter_fwd();
}

void GeneralizedAlpha::combine(double c_u, double c_a, Vec w) const
{
  // w = c_u (u - u_n - h v_n) + c_a a_n
  VecWAXPY(w, -1.0, _u_n, _u_vec);
  VecAXPY(w, -_h, _v_vec);
  VecAXPBY(w, c_a, c_u, _a_vec);
}

void GeneralizedAlpha::begin_step(double h)
{
  // Newton starts from u_n: a constant-acceleration guess u_n + h v_n + h^2/2 a_n
  // saves an iteration at small steps but throws a large step (h far above the
  // periods, where the method damps) out of Newton's reach
  _h = h;
}

void GeneralizedAlpha::add_residual(Vec F)
{
  if (_h == 0)
    return; // between steps: nodal forces (reactions, sections) are the static ones
  const auto& p = _p;
  const double c_u = (1 - p.alpha_m) / (p.beta * _h * _h);
  const double c_a = p.alpha_m - (1 - p.alpha_m) * (0.5 / p.beta - 1);
  combine(c_u, c_a, _w); // a_m
  MatMult(_M, _w, _Mw);
  VecAXPY(_Mw, p.alpha_f, _r_vec);
  VecScale(_Mw, 1 / (1 - p.alpha_f));
  PetscInt begin, end;
  VecGetOwnershipRange(_Mw, &begin, &end);
  const PetscScalar* values;
  VecGetArrayRead(_Mw, &values);
  std::vector<PetscInt> rows(end - begin);
  for (PetscInt i = begin; i < end; ++i)
    rows[i - begin] = i;
  VecSetValues(F, end - begin, rows.data(), values, ADD_VALUES);
  VecRestoreArrayRead(_Mw, &values);
}

void GeneralizedAlpha::add_jacobian(Mat A)
{
  if (_h == 0)
    return;
  const double c = (1 - _p.alpha_m) / ((1 - _p.alpha_f) * _p.beta * _h * _h);
  PetscInt begin, end;
  MatGetOwnershipRange(_M_rows, &begin, &end);
  std::vector<PetscScalar> scaled;
  for (PetscInt row = begin; row < end; ++row)
  {
    PetscInt n;
    const PetscInt* columns;
    const PetscScalar* values;
    MatGetRow(_M_rows, row, &n, &columns, &values);
    scaled.assign(values, values + n);
    for (PetscScalar& s : scaled)
      s *= c;
    MatSetValues(A, 1, &row, n, columns, scaled.data(), ADD_VALUES);
    MatRestoreRow(_M_rows, row, &n, &columns, &values);
  }
}

void GeneralizedAlpha::accept_step()
{
  const auto& p = _p;
  // a_{n+1}
  Vec a_new = _w;
  combine(1 / (p.beta * _h * _h), -(0.5 / p.beta - 1), a_new);
  // v_{n+1} = v_n + h ((1 - gamma) a_n + gamma a_{n+1})
  VecAXPY(_v_vec, _h * (1 - p.gamma), _a_vec);
  VecAXPY(_v_vec, _h * p.gamma, a_new);
  // r_{n+1} from the converged equation: -(M a_m + alpha_f r_n) / (1 - alpha_f);
  // at the fixed dofs and across a constraint it carries the reactions, which
  // never enter a free equation
  VecAXPBY(_a_vec, 1 - p.alpha_m, p.alpha_m, a_new); // a_m, for the moment
  MatMult(_M, _a_vec, _Mw);
  VecAXPBY(_r_vec, -1 / (1 - p.alpha_f), -p.alpha_f / (1 - p.alpha_f), _Mw);
  VecCopy(a_new, _a_vec);
  VecCopy(_u_vec, _u_n);
  for (auto& f : {_v, _a, _r})
    f->x()->scatter_fwd();
  _h = 0;
}

double GeneralizedAlpha::kinetic_energy() const
{
  PetscScalar vMv;
  MatMult(_M, _v_vec, _Mw);
  VecDot(_v_vec, _Mw, &vMv);
  return 0.5 * vMv;
}

std::vector<std::shared_ptr<fem::Function<double>>> GeneralizedAlpha::state() const
{
  return {_v, _a, _r};
}

void GeneralizedAlpha::restore()
{
  VecCopy(_u_vec, _u_n);
  for (auto& f : {_v, _a, _r})
    f->x()->scatter_fwd();
}

} // namespace muscle
