"""Build the UFL objects of one compiled variant: a model on a cell, degree and quadrature.

Two kinds of variant share the material maths of models.py:

* finite-element variants (residual, Jacobian, volume functional and quadrature-point
  expressions) with F = I + grad(u);
* material-point variants (energy, first Piola-Kirchhoff stress, its derivative) with
  the displacement gradient H given cell-wise (DG0), used for the homogeneous
  load-case responses and the point-wise tests: the very kernels the FE uses.
"""

import ufl
from ffcx.element_interface import create_quadrature
from ufl import (Coefficient, Constant, FiniteElement, TensorElement, TestFunction, TrialFunction,
                 VectorElement, as_vector, derivative, diff, dx, grad, inner, variable)

from . import models
from .activation import TAYLOR_COEFFICIENTS, TAYLOR_ORDER, taylor_omega
from .kinematics import Kinematics, fibre_cauchy_stress, von_mises_stress

MODELS = ("ble", "wkm", "giant", "combi", "ble_passive", "ehret_passive", "neohooke")
CELLS = {"hex": "hexahedron", "tet": "tetrahedron"}
# quadrature degree per (cell, degree) unless a variant asks for another one
DEFAULT_QUADRATURE = {("hex", 1): 2, ("hex", 2): 4, ("tet", 1): 2, ("tet", 2): 4}

ACTIVE_MODELS = ("ble", "wkm", "giant", "combi")


# Q1 with the stiff volumetric part on one point per cell (selective reduced integration),
# compiled for BLE only: its remaining energy is isochoric, so nothing else needs the
# penalty.  The coupled Ehret energies of WKM, GIANT and COMBI soften in volume without
# their penalty; with it on one point their within-cell volume modes are unstable
# (Newton stagnates at t = 0.8 ms on the block, 0.6 ms on the fusiform; BENCHMARKS.md).
REDUCED_VOLUMETRIC = {("hex", 1): 1}
ANTI_LOCKING_MODELS = ("ble", "ble_passive")


def variant_name(model, cell, degree, qdeg, vqdeg=None, fbar=False):
    """vqdeg: quadrature degree of the stiff volumetric part when it differs from qdeg;
    fbar: the F-bar element (fbar.py)."""
    name = f"{model}_{cell}{degree}_q{qdeg}"
    if fbar:
        return f"{name}_fbar"
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


def _constants(cell, model, names):
    return {p: names.name(Constant(cell), p) for p in models.PARAMETERS[model]}


def _energy(model, kin, p, level, omega):
    if model in ("ble", "ble_passive"):
        return models.ble_energy(kin, p, level)
    if model in ("wkm", "combi", "ehret_passive"):
        return models.wkm_energy(kin, p, omega)
    if model == "giant":
        return models.giant_energy(kin, p, omega)
    if model == "neohooke":
        return models.neohooke_energy(kin, p)
    raise ValueError(f"unknown model {model}")


def _stress_and_energy(model, H_of, fibre, p, level, taylor):
    """First Piola-Kirchhoff stress P = dPsi/dH and Psi.

    H_of() returns a fresh ufl.variable of the displacement gradient.  WKM's stress
    holds omega_a fixed (paper eq. S_WKM): omega_a is built on a second variable that
    diff(., H) does not see.  The other models are hyperelastic in the full sense.
    Returns (P, psi, H, H_omega) where H_omega is the variable omega_a depends on.
    """
    H = H_of()
    kin = Kinematics(H, fibre)
    H_omega = H
    omega = None
    if model == "wkm":
        H_omega = H_of()
        omega = taylor_omega(Kinematics(H_omega, fibre).fibre_stretch, taylor, TAYLOR_ORDER["wkm"])
    elif model == "giant":
        omega = taylor_omega(kin.fibre_stretch, taylor, TAYLOR_ORDER["giant"])
    elif model == "combi":
        omega = models.combi_activation(kin.fibre_stretch, p, level)
    psi = _energy(model, kin, p, level, omega)
    return diff(psi, H), psi, kin, H, H_omega


def build_fe_variant(model, cell, degree, qdeg, vqdeg=None):
    """Residual, Jacobian, volume functional and quadrature-point expressions.

    vqdeg (if not None or qdeg): the stiff volumetric part of the energy is integrated
    with this lower degree and the rest with qdeg (anti-locking Q1).
    """
    ucell = getattr(ufl, CELLS[cell])
    names = _Names()
    V = VectorElement("Lagrange", ucell, degree)
    u = names.name(Coefficient(V), "u")
    v = TestFunction(V)
    du = TrialFunction(V)
    fibre = names.name(Coefficient(VectorElement("DG", ucell, 0)), "fibre")
    p = _constants(ucell, model, names)

    level = None
    if model in ACTIVE_MODELS:
        scale = names.name(Coefficient(FiniteElement("DG", ucell, 0)), "activation_scale")
        time_factor = names.name(Constant(ucell), "time_factor")
        level = time_factor * scale

    taylor = None
    if model in TAYLOR_ORDER:
        Q = FiniteElement("Quadrature", ucell, qdeg, quad_scheme="default")
        taylor = {c: names.name(Coefficient(Q), c) for c in TAYLOR_COEFFICIENTS[:TAYLOR_ORDER[model] + 2]}

    P, psi, kin, _, _ = _stress_and_energy(model, lambda: variable(grad(u)), fibre, p, level, taylor)
    measure = dx(metadata={"quadrature_degree": qdeg})
    if vqdeg in (None, qdeg):
        residual = inner(P, grad(v)) * measure
    else:
        # The volumetric part is a form of its own (C++ runs both kernels per cell):
        # FFCx 0.5 mixes up two rules of one integral -- the full rule's loop reads the
        # one-point rule's grad(u) and geometry (residual off by 17 % on a 2x2x2 cube).
        P_vol = diff(models.volumetric_stiff_part(model, kin.J, p), kin.H)
        residual = inner(P - P_vol, grad(v)) * measure
        residual_vol = inner(P_vol, grad(v)) * dx(metadata={"quadrature_degree": vqdeg})
        names.export(residual_vol, "residual_volumetric")
        names.export(derivative(residual_vol, u, du), "jacobian_volumetric")
    names.export(residual, "residual")
    names.export(derivative(residual, u, du), "jacobian")
    names.export(kin.J * measure, "volume")

    points, _ = create_quadrature(CELLS[cell], qdeg, "default")
    if model in TAYLOR_ORDER:
        names.export((kin.fibre_stretch, points), "fibre_stretch")
    post = as_vector([kin.fibre_stretch, fibre_cauchy_stress(kin, P), von_mises_stress(kin, P), kin.J])
    names.export((post, points), "post")
    return names


def build_material_point_variant(model):
    """Psi, P and dP/dH of one model for a cell-wise constant displacement gradient."""
    ucell = ufl.hexahedron
    names = _Names()
    Hc = names.name(Coefficient(TensorElement("DG", ucell, 0)), "H")
    fibre = names.name(Coefficient(VectorElement("DG", ucell, 0)), "fibre")
    p = _constants(ucell, model, names)
    level = None
    if model in ACTIVE_MODELS:
        scale = names.name(Coefficient(FiniteElement("DG", ucell, 0)), "activation_scale")
        time_factor = names.name(Constant(ucell), "time_factor")
        level = time_factor * scale
    taylor = None
    if model in TAYLOR_ORDER:
        taylor = {c: names.name(Coefficient(FiniteElement("DG", ucell, 0)), c)
                  for c in TAYLOR_COEFFICIENTS[:TAYLOR_ORDER[model] + 2]}

    P, psi, kin, H, H_omega = _stress_and_energy(model, lambda: variable(Hc), fibre, p, level, taylor)
    tangent = diff(P, H)
    if H_omega is not H:
        tangent = tangent + diff(P, H_omega)
    point = [[0.5, 0.5, 0.5]]
    names.export((psi, point), "energy")
    names.export((P, point), "stress")
    names.export((tangent, point), "tangent")
    names.export((kin.fibre_stretch, point), "fibre_stretch")
    return names


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
