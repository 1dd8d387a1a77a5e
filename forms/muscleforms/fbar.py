"""F-bar hexahedra (de Souza Neto et al. 1996; the element of the paper's fusiform study).

The energy is evaluated at F_bar = (J0/J)^(1/3) F, with J0 = det F at the cell centre:
det F_bar = J0 at every quadrature point, so a Q1 cell carries one volume constraint
instead of eight and does not lock.  Because J0 depends on the cell's displacement
through one point, the element is written with J0 as an extra cell unknown and C++
eliminates it cell by cell (cpp/fem/elements/fbar_element.cpp), which keeps the tangent exact:

    R = R_u + r_0 g,
    K = K_uu + K_u0 g^T + g K_0u + K_00 g g^T + r_0 G,

where (R_u, r_0) and the 25x25 [K_uu K_u0; K_0u K_00] come from one mixed kernel on
(u, J0) ("fbar_residual", "fbar_jacobian"; r_0 alone from "fbar_r0"), and g = dJ0/du,
G = d2J0/du2 from kernels on the centre point ("fbar_gradient", "fbar_hessian",
"fbar_centre").

With J0 = theta kept as a cell unknown and its constraint J0(u) = theta enforced by
a multiplier p (the three-field form, cpp/fem/elements/fbar_unknowns.h), the same kernels give

    R_u = R_u(u, theta) + p g,   R_theta = r_0 - p,   R_p = J0(u) - theta,

whose Newton iteration keeps the penalty's argument theta linear in each step.

Exported besides:
  residual, jacobian   carriers: DOLFINx packs the cell data (u, theta = "fbar_J0",
                       p = "fbar_pressure", fibre, activation scale, omega_a Taylor data,
                       constants) through them; their own kernels are never called.
  fibre_stretch, post  expressions with F_bar, reading J0 from the DG0 field "fbar_J0".
"""

import ufl
from ffcx.element_interface import create_quadrature
from ufl.algorithms import expand_derivatives
from ufl import (Coefficient, Constant, FiniteElement, Identity, MixedElement, TestFunction,
                 TrialFunction, VectorElement, as_vector, derivative, det, dx, grad, inner,
                 variable)

from .invariant_chain import energy_forms
from .kinematics import Kinematics, fibre_cauchy_stress, von_mises_stress, von_mises_strain
from .variants import CELLS, _Names, activation_inputs, constants, stress_and_energy

# F-bar exists for Q1 hexahedra (every law): Q2 does not lock, and on tetrahedra a centre
# value is the whole P1 field.
FBAR_ELEMENTS = {("hex", 1)}


def fbar_scale(J0, J):
    """(s, s - 1) of F_bar = s F, s = (J0/J)^(1/3).

    s - 1 is formed from J0 - J, so the reference state (H = 0, J0 = 1) gives s - 1 = 0
    to the bit (the BLE passive switch at fibre stretch 1).
    """
    ratio_m1 = (J0 - J) / J
    s = (1 + ratio_m1)**(1.0 / 3.0)
    return s, ratio_m1 / (s * s + s + 1)


def fbar_displacement_gradient(H, J0):
    """F_bar - I for F = I + H."""
    I = Identity(3)
    _, s_m1 = fbar_scale(J0, det(I + H))
    return H + s_m1 * (I + H)


def fbar_kinematics(H, J0, m):
    """Kinematics of F_bar for the chain rule (invariant_chain.py): its invariants are
    F's scaled by s (Kinematics.scale), so the variables are F's invariants and J0, and
    no argument passes through the cube root more than once."""
    kin = Kinematics(H, m, invariant_variables=True)
    J0_var = variable(J0)
    kin.variables.append((J0_var, J0))
    s, s_m1 = fbar_scale(J0_var, kin.J)
    kin.scale(s, s_m1, J0_var)
    return kin


def _centre_measure():
    return dx(metadata={"quadrature_degree": 1})


def build_fbar_variant(law, active, cell, degree, qdeg):
    if (cell, degree) not in FBAR_ELEMENTS:
        raise ValueError(f"F-bar is for Q1 hexahedra, not {cell} degree {degree}")
    ucell = getattr(ufl, CELLS[cell])
    names = _Names()
    V = VectorElement("Lagrange", ucell, degree)
    Q0 = FiniteElement("DG", ucell, 0)
    W = MixedElement([V, Q0])

    u = names.name(Coefficient(V), "u")
    J0_field = names.name(Coefficient(Q0), "fbar_J0")
    pressure = names.name(Coefficient(Q0), "fbar_pressure")
    state = names.name(Coefficient(W), "fbar_state")
    u_s, J0_s = ufl.split(state)
    fibre = names.name(Coefficient(VectorElement("DG", ucell, 0)), "fibre")
    p = constants(ucell, law, names)
    level, taylor = activation_inputs(
        law, active, ucell, names, FiniteElement("Quadrature", ucell, qdeg, quad_scheme="default"))
    measure = dx(metadata={"quadrature_degree": qdeg})

    # the mixed element on (u, J0)
    H_bar = fbar_displacement_gradient(grad(u_s), J0_s)
    test, trial = TestFunction(W), TrialFunction(W)
    P, _, _, _, _ = stress_and_energy(law, lambda: variable(H_bar), fibre, p, level, taylor)
    residual, jacobian = energy_forms(law, lambda: fbar_kinematics(grad(u_s), J0_s, fibre), P,
                                      H_bar, p, level, taylor, state, test, trial)
    residual, jacobian = residual * measure, jacobian * measure
    names.export(residual, "fbar_residual")
    names.export(jacobian, "fbar_jacobian")
    # r_0 = R's J0 entry alone: the Jacobian kernels need it besides K, not R_u
    J0_direction = as_vector([0.0] * 3 + [1.0])
    names.export(ufl.replace(expand_derivatives(residual), {test: J0_direction}), "fbar_r0")

    # J0 = det F at the centre: the one-point rule over |det dX/dxi| gives the point value
    v, du = TestFunction(V), TrialFunction(V)
    J_u = det(Identity(3) + grad(u))
    centre = J_u / abs(ufl.JacobianDeterminant(ucell)) * _centre_measure()
    names.export(centre, "fbar_centre")
    gradient = derivative(centre, u, v)
    names.export(gradient, "fbar_gradient")
    names.export(derivative(gradient, u, du), "fbar_hessian")

    # carriers: every coefficient and constant the mixed kernels read
    data = sum((f[i] for f in (u, fibre) for i in range(3)), 1.0 + J0_field + pressure)
    for c in list((taylor or {}).values()) + list(p.values()) + ([level] if level is not None else []):
        data = data + c
    names.export(data * inner(u, v) * measure, "residual")
    names.export(data * inner(du, v) * measure, "jacobian")
    names.export(J_u * measure, "volume")

    points, _ = create_quadrature(CELLS[cell], qdeg, "default")
    H_post = fbar_displacement_gradient(grad(u), J0_field)
    P_post, psi_post, kin, _, _ = stress_and_energy(law, lambda: variable(H_post), fibre, p,
                                                     level, taylor)
    # the strain energy of the converged state (fbar_J0 = J0(u) there)
    names.export(psi_post * measure, "energy")
    if taylor is not None:
        names.export((kin.fibre_stretch, points), "fibre_stretch")
    post = as_vector([kin.fibre_stretch, fibre_cauchy_stress(kin, P_post),
                      von_mises_stress(kin, P_post), J_u, von_mises_strain(kin)])
    names.export((post, points), "post")
    names.export((J_u, [[0.5, 0.5, 0.5]]), "fbar_centre_dilatation")
    return names
