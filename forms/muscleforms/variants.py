"""Build the UFL objects of one compiled variant: a law's kernel set on a cell, degree
and quadrature.

Two kinds of variant share the law's energy (law.py):

* finite-element variants (residual, Jacobian, volume functional and quadrature-point
  expressions) with F = I + grad(u);
* material-point variants (energy, first Piola-Kirchhoff stress, its derivative) with
  the displacement gradient H given cell-wise (DG0), used for the homogeneous
  load-case responses and the point-wise tests: the very kernels the FE uses.

A kernel set is (law, active): the law's own kernels, or its passive counterpart
(drive = None: no active term, no activation coefficients).
"""

import ufl
from ffcx.element_interface import create_quadrature
from ufl import (Coefficient, Constant, FiniteElement, TensorElement, TestFunction, TrialFunction,
                 VectorElement, as_vector, diff, dx, grad, inner, variable)

from .activation import TAYLOR_COEFFICIENTS, taylor_omega
from .invariant_chain import energy_forms
from .kinematics import Kinematics, fibre_cauchy_stress, von_mises_stress, von_mises_strain
from .law import Drive, Parameters

CELLS = {"hex": "hexahedron", "tet": "tetrahedron"}
# quadrature degree per (cell, degree) unless a variant asks for another one
DEFAULT_QUADRATURE = {("hex", 1): 2, ("hex", 2): 4, ("tet", 1): 2, ("tet", 2): 4}

# Q1 with the stiff volumetric part on one point per cell (selective reduced integration),
# compiled for the laws that give volumetric_stiff_part (BLE: the rest of its energy is
# isochoric).  The coupled Ehret energies of WKM, GIANT and COMBI soften in volume without
# their penalty; with it on one point their within-cell volume modes are unstable
# (Newton stagnates within the first millisecond; BENCHMARKS.md, "Q1 with the
# anti-locking choice (selective reduced integration, BLE only)").
REDUCED_VOLUMETRIC = {("hex", 1): 1}


def variant_name(kernels, cell, degree, qdeg, vqdeg=None, kind=""):
    """vqdeg: quadrature degree of the stiff volumetric part when it differs from qdeg;
    kind: "" (the displacement element), "fbar" (fbar.py) or "th" (Taylor-Hood,
    taylor_hood.py)."""
    name = f"{kernels}_{cell}{degree}_q{qdeg}"
    if kind:
        return f"{name}_{kind}"
    return name if vqdeg in (None, qdeg) else f"{name}_v{vqdeg}"


class _Names:
    """Collects the names FFCx gives to forms, expressions, coefficients and constants."""

    def __init__(self):
        self.object_names = {}
        self.objects = []

    def name(self, obj, name):
        self.object_names[id(obj)] = name
        return obj

    def export(self, obj, name):
        """Export a form, or an expression given as (expr, points)."""
        self.objects.append(obj)
        self.name(obj[0] if isinstance(obj, tuple) else obj, name)
        return obj


def constants(cell, law, names):
    """Every parameter as a UFL Constant of its name; FFCx keeps the ones a form uses.
    Reading an undeclared one raises law.UndeclaredParameter."""
    return Parameters({n: names.name(Constant(cell), n) for n in law.parameter_names()})


def activation_inputs(law, active, ucell, names, taylor_element):
    """(level, taylor): level = time factor x element scale (DG0 "activation_scale");
    taylor: omega_a's Taylor data at quadrature points for an omega-kernel law."""
    if not active:
        return None, None
    scale = names.name(Coefficient(FiniteElement("DG", ucell, 0)), "activation_scale")
    time_factor = names.name(Constant(ucell), "time_factor")
    taylor = None
    if law.activation.drive == "omega_kernel":
        order = law.activation.taylor_order
        taylor = {c: names.name(Coefficient(taylor_element), c)
                  for c in TAYLOR_COEFFICIENTS[:order + 2]}
    return time_factor * scale, taylor


def stress_and_energy(law, H_of, fibre, p, level, taylor):
    """First Piola-Kirchhoff stress P = dPsi/dH and Psi.

    H_of() returns a fresh ufl.variable of the displacement gradient.  A law whose
    stress holds omega_a fixed (WKM, eq. S_WKM) gets omega_a built on a second
    variable that diff(., H) does not see.
    Returns (P, psi, kin, H, H_omega) where H_omega is the variable omega_a depends on.
    """
    H = H_of()
    kin = Kinematics(H, fibre)
    H_omega = H
    omega = None
    if taylor is not None:
        kin_omega = kin
        if law.activation.stress_holds_omega:
            H_omega = H_of()
            kin_omega = Kinematics(H_omega, fibre)
        omega = taylor_omega(kin_omega.fibre_stretch, taylor, law.activation.taylor_order)
    psi = law.energy(kin, p, Drive(level, omega))
    return diff(psi, H), psi, kin, H, H_omega


def build_fe_variant(law, active, cell, degree, qdeg, vqdeg=None):
    """Residual, Jacobian, volume and strain-energy functionals, quadrature-point expressions.

    vqdeg (if not None or qdeg): the law's volumetric_stiff_part is integrated with
    this lower degree and the rest with qdeg (anti-locking Q1).
    """
    ucell = getattr(ufl, CELLS[cell])
    names = _Names()
    V = VectorElement("Lagrange", ucell, degree)
    u = names.name(Coefficient(V), "u")
    v = TestFunction(V)
    du = TrialFunction(V)
    fibre = names.name(Coefficient(VectorElement("DG", ucell, 0)), "fibre")
    p = constants(ucell, law, names)
    level, taylor = activation_inputs(
        law, active, ucell, names, FiniteElement("Quadrature", ucell, qdeg, quad_scheme="default"))

    P, psi, kin, _, _ = stress_and_energy(law, lambda: variable(grad(u)), fibre, p, level, taylor)
    measure = dx(metadata={"quadrature_degree": qdeg})

    def forms(part=None, P_part=P):
        """(residual, tangent) integrands: through the invariants when the energy allows."""
        return energy_forms(law, lambda: Kinematics(grad(u), fibre, invariant_variables=True),
                            P_part, grad(u), p, level, taylor, u, v, du, part)

    if vqdeg in (None, qdeg):
        residual, jacobian = forms()
    else:
        # The volumetric part is a form of its own (C++ runs both kernels per cell):
        # FFCx 0.5 mixes up two rules of one integral -- the full rule's loop reads the
        # one-point rule's grad(u) and geometry (a wrong residual on a 2x2x2 cube).
        P_vol = diff(law.volumetric_stiff_part(kin, p), kin.H)
        residual, jacobian = forms(lambda k, q, psi: psi - law.volumetric_stiff_part(k, q),
                                   P - P_vol)
        residual_vol, jacobian_vol = forms(lambda k, q, psi: law.volumetric_stiff_part(k, q),
                                           P_vol)
        vmeasure = dx(metadata={"quadrature_degree": vqdeg})
        names.export(residual_vol * vmeasure, "residual_volumetric")
        names.export(jacobian_vol * vmeasure, "jacobian_volumetric")
    names.export(residual * measure, "residual")
    names.export(jacobian * measure, "jacobian")
    names.export(kin.J * measure, "volume")
    names.export(psi * measure, "energy")

    points, _ = create_quadrature(CELLS[cell], qdeg, "default")
    if taylor is not None:
        names.export((kin.fibre_stretch, points), "fibre_stretch")
    post = as_vector([kin.fibre_stretch, fibre_cauchy_stress(kin, P), von_mises_stress(kin, P), kin.J,
                      von_mises_strain(kin)])
    names.export((post, points), "post")
    return names


def build_material_point_variant(law, active):
    """Psi, P and dP/dH of one kernel set for a cell-wise constant displacement gradient."""
    ucell = ufl.hexahedron
    names = _Names()
    Hc = names.name(Coefficient(TensorElement("DG", ucell, 0)), "H")
    fibre = names.name(Coefficient(VectorElement("DG", ucell, 0)), "fibre")
    p = constants(ucell, law, names)
    level, taylor = activation_inputs(law, active, ucell, names, FiniteElement("DG", ucell, 0))

    P, psi, kin, H, H_omega = stress_and_energy(law, lambda: variable(Hc), fibre, p, level, taylor)
    tangent = diff(P, H)
    if H_omega is not H:
        tangent = tangent + diff(P, H_omega)
    point = [[0.5, 0.5, 0.5]]
    names.export((psi, point), "energy")
    names.export((P, point), "stress")
    names.export((tangent, point), "tangent")
    names.export((kin.fibre_stretch, point), "fibre_stretch")
    return names


def check_volumetric_part(law):
    """The law's volumetric_stiff_part as UFL (no form): errors show before FFCx runs."""
    ucell = ufl.hexahedron
    names = _Names()
    H = variable(Coefficient(TensorElement("DG", ucell, 0)))
    fibre = Coefficient(VectorElement("DG", ucell, 0))
    law.volumetric_stiff_part(Kinematics(H, fibre), constants(ucell, law, names))


def build_fibre_variant(cell):
    """Laplace problem for the fibre potential and its cell-wise gradient.

    Fibres follow grad(phi) with phi = 0 on the origin and 1 on the insertion
    (fusiform example); the expression is evaluated at the cell midpoint.
    """
    ucell = getattr(ufl, CELLS[cell])
    names = _Names()
    element = FiniteElement("Lagrange", ucell, 1)
    phi = names.name(TrialFunction(element), "phi")
    q = names.name(TestFunction(element), "q")
    potential = names.name(Coefficient(element), "potential")
    source = names.name(Constant(ucell), "source")
    names.export(inner(grad(phi), grad(q)) * dx, "laplace")
    names.export(source * q * dx, "rhs")
    midpoint = [[0.5, 0.5, 0.5]] if cell == "hex" else [[0.25, 0.25, 0.25]]
    names.export((grad(potential), midpoint), "gradient")
    return names
