"""Taylor-Hood elements (Q2-Q1 hexahedra, P2-P1 tetrahedra) for every law.

A law's energy is any psi(F), with its stiff volumetric part coupled into it (the Ehret
penalty, Blemker's and Neo-Hooke's kappa terms), so the mixed form is the three-field
Hu-Washizu one on continuous degree-1 fields theta (volume ratio) and p (its multiplier):

    Pi(u, theta, p) = int psi(F_bar) + p (J - theta) dX,   F_bar = (theta/J)^(1/3) F,

det F_bar = theta.  With theta and p in the same space, theta is the L2 projection of J and
p that of dpsi/dtheta: the pressure lives on the Q1/P1 nodes, the inf-sup stable Taylor-Hood
pair, and the element carries one volume constraint per pressure node instead of one per
quadrature point (plain Q2 locks mildly in bending under kappa = 1000; BENCHMARKS.md,
"Taylor-Hood (Q2-Q1)").

(theta, p) is one Lagrange degree-1 field of two components, "th_state".  Exported:

  residual, jacobian      R_u and dR_u/du (the displacement block: loads, contact and
                          Dirichlet conditions act on it as on every other element)
  th_residual             R_q = (R_theta, R_p) on the test space of th_state
  th_jacobian_uq, th_jacobian_qu, th_jacobian_qq    the other three blocks
  volume, energy, fibre_stretch, post   as the displacement variants, at F_bar
"""

import ufl
from ffcx.element_interface import create_quadrature
from ufl import (Coefficient, FiniteElement, TestFunction, TrialFunction, VectorElement, as_vector,
                 derivative, det, dx, grad, variable)

from .fbar import fbar_displacement_gradient, fbar_kinematics
from .invariant_chain import energy_forms
from .kinematics import fibre_cauchy_stress, von_mises_stress, von_mises_strain
from .variants import CELLS, _Names, activation_inputs, constants, stress_and_energy

# the displacement degree of each Taylor-Hood element; the pressure is one lower
TAYLOR_HOOD_ELEMENTS = {("hex", 2), ("tet", 2)}


def build_taylor_hood_variant(law, active, cell, degree, qdeg):
    if (cell, degree) not in TAYLOR_HOOD_ELEMENTS:
        raise ValueError(f"Taylor-Hood is for degree-2 displacements, not {cell} degree {degree}")
    ucell = getattr(ufl, CELLS[cell])
    names = _Names()
    V = VectorElement("Lagrange", ucell, degree)
    Q = VectorElement("Lagrange", ucell, degree - 1, dim=2)

    u = names.name(Coefficient(V), "u")
    q = names.name(Coefficient(Q), "th_state")
    theta, pressure = q[0], q[1]
    fibre = names.name(Coefficient(VectorElement("DG", ucell, 0)), "fibre")
    p = constants(ucell, law, names)
    level, taylor = activation_inputs(
        law, active, ucell, names, FiniteElement("Quadrature", ucell, qdeg, quad_scheme="default"))
    measure = dx(metadata={"quadrature_degree": qdeg})

    H_bar = fbar_displacement_gradient(grad(u), theta)
    P, psi, kin, _, _ = stress_and_energy(law, lambda: variable(H_bar), fibre, p, level, taylor)
    J = det(ufl.Identity(3) + grad(u))
    v, du = TestFunction(V), TrialFunction(V)
    w, dq = TestFunction(Q), TrialFunction(Q)
    fields = {"u": (u, v, du), "q": (q, w, dq)}
    # the multiplier's term p (J - theta) is small: UFL differentiates it
    constraint = pressure * (J - theta)

    def block(row, column=None):
        """(residual of `row`, tangent of row and column): psi through F_bar's invariants
        (invariant_chain.py, F-bar's scaled invariants with theta for J0) when the energy
        allows, else P = dpsi/dH_bar (WKM: omega_a held, as in every variant) through
        the chain rule of H_bar."""
        state, test, _ = fields[row]
        trial_state, _, trial = fields[column or row]
        chained = energy_forms(law, lambda: fbar_kinematics(grad(u), theta, fibre), P, H_bar,
                               p, level, taylor, state, test, trial, trial_state=trial_state)
        r_c = derivative(constraint, state, test)
        return ((chained[0] + r_c) * measure,
                (chained[1] + derivative(r_c, trial_state, trial)) * measure)

    residual_u, jacobian_uu = block("u")
    residual_q, jacobian_qq = block("q")
    names.export(residual_u, "residual")
    names.export(jacobian_uu, "jacobian")
    names.export(residual_q, "th_residual")
    names.export(block("u", "q")[1], "th_jacobian_uq")
    names.export(block("q", "u")[1], "th_jacobian_qu")
    names.export(jacobian_qq, "th_jacobian_qq")
    names.export(J * measure, "volume")
    names.export(psi * measure, "energy")

    points, _ = create_quadrature(CELLS[cell], qdeg, "default")
    if taylor is not None:
        names.export((kin.fibre_stretch, points), "fibre_stretch")
    post = as_vector([kin.fibre_stretch, fibre_cauchy_stress(kin, P), von_mises_stress(kin, P), J,
                      von_mises_strain(kin)])
    names.export((post, points), "post")
    return names
