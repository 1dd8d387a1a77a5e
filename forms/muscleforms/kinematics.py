"""Kinematics of a material point, built from the displacement gradient H.

Strain-like quantities are formed from H directly (E = (H + H^T + H^T H)/2,
lambda^2 - 1 = 2 m.E.m) so that the reference state H = 0 is exact to the bit:
the BLE passive fibre switch sits exactly at fibre stretch 1 and a fibre
vector normalised to 1 +- 1e-16 must not move it (ERRATA, "numerical trap").
"""

import ufl
from ufl import Identity, cofac, det, dot, inner, outer, sqrt, tr


class Kinematics:
    """Deformation of one material point: F = I + H, fibre direction m (unit)."""

    def __init__(self, H, m):
        I = Identity(3)
        self.H = H
        self.m = m
        self.F = I + H
        self.C = self.F.T * self.F
        self.E = (H + H.T + H.T * H) / 2
        self.J = det(self.F)
        self.M = outer(m, m)
        # lambda^2 - 1, exactly zero in the reference state
        self.fibre_stretch_sq_m1 = 2 * inner(self.E, self.M)
        self.fibre_stretch = sqrt(1 + self.fibre_stretch_sq_m1)

        # The invariants every model is written in.  Working with these (instead of
        # C_e = F_a^-T C F_a^-1 or cof(C) : L as matrices) keeps the UFL graph and the
        # generated tangent kernels several times smaller.
        cofF = cofac(self.F)
        cofF_m = dot(cofF, m)
        Cm = dot(self.C, m)
        self.I1_m3 = 2 * tr(self.E)                 # tr C - 3
        self.I2 = inner(cofF, cofF)                 # tr cof C
        self.I4 = 1 + self.fibre_stretch_sq_m1      # C : M = lambda^2
        self.K4 = dot(cofF_m, cofF_m)               # cof C : M (area stretch across the fibre)
        self.I5 = dot(Cm, Cm)                       # C^2 : M


def cauchy_stress(kin, P):
    return P * kin.F.T / kin.J


def current_fibre(kin):
    a = dot(kin.F, kin.m)
    return a / sqrt(dot(a, a))


def fibre_cauchy_stress(kin, P):
    """sigma_m = n . sigma . n with n the unit fibre direction in the current configuration."""
    n = current_fibre(kin)
    return dot(n, dot(cauchy_stress(kin, P), n))


def von_mises_stress(kin, P):
    sigma = cauchy_stress(kin, P)
    s = ufl.dev(sigma)
    return sqrt(1.5 * inner(s, s))


def von_mises_strain(kin):
    """sqrt(2/3 dev E : dev E) of the Green-Lagrange strain: the strain in uniaxial
    incompressible stretch for small strains."""
    e = ufl.dev(kin.E)
    return sqrt(2.0 / 3.0 * inner(e, e))
