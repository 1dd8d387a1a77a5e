"""External loads, one set of forms per element (any law): they add to the law's residual.

  pressure   follower pressure p on the surface tagged 1 (kPa, along the current
             normal, against it for p > 0): R = int p cof(F) N . v dA, with its tangent
  traction   dead traction t per reference area on the surface tagged 1 (kPa):
             R = -int t . v dA
  gravity    body force rho g (density DG0 per cell, kg/mm^3; g in mm/s^2):
             R = -int rho g . v dV
  area       functional: current area of the surface tagged 1 (Nanson: |cof(F) N| dA)
  mass       bilinear form int rho du . v dV (consistent mass of structural dynamics,
             cpp/fem/time/generalized_alpha.h), density DG0 as for gravity

C++ (cpp/fem/terms/loads.cpp) tags each load's facets 1 and sets the constants per time.
"""

import ufl
from ufl import (Coefficient, Constant, FacetNormal, FiniteElement, Identity, TestFunction,
                 TrialFunction, VectorElement, cofac, derivative, dot, ds, dx, grad, inner, sqrt)

from .variants import CELLS, DEFAULT_QUADRATURE, _Names


def build_load_variant(cell, degree):
    ucell = getattr(ufl, CELLS[cell])
    names = _Names()
    V = VectorElement("Lagrange", ucell, degree)
    u = names.name(Coefficient(V), "u")
    v, du = TestFunction(V), TrialFunction(V)
    F = Identity(3) + grad(u)
    N = FacetNormal(ucell)
    qdeg = DEFAULT_QUADRATURE[(cell, degree)]
    surface = ds(1, metadata={"quadrature_degree": qdeg})

    pressure = names.name(Constant(ucell), "pressure")
    residual = pressure * inner(dot(cofac(F), N), v) * surface
    names.export(residual, "pressure_residual")
    names.export(derivative(residual, u, du), "pressure_jacobian")

    traction = names.name(Constant(ucell, shape=(3,)), "traction")
    names.export(-inner(traction, v) * surface, "traction_residual")

    density = names.name(Coefficient(FiniteElement("DG", ucell, 0)), "density")
    gravity = names.name(Constant(ucell, shape=(3,)), "gravity")
    names.export(-density * inner(gravity, v) * dx(metadata={"quadrature_degree": qdeg}),
                 "gravity_residual")

    # exact for the element's mass (degree 2 p is within the default rule)
    names.export(density * inner(du, v) * dx(metadata={"quadrature_degree": qdeg}), "mass")

    n_current = dot(cofac(F), N)
    names.export(sqrt(inner(n_current, n_current)) * surface, "area")
    return names
