"""Kinematics of a material point, built from the displacement gradient H.

Strain-like quantities are formed from H directly (E = (H + H^T + H^T H)/2,
lambda^2 - 1 = 2 m.E.m) so that the reference state H = 0 is exact to the bit:
the BLE passive fibre switch sits exactly at fibre stretch 1 and a fibre
vector normalised to 1 +- 1e-16 must not move it (ERRATA, "numerical trap").
"""

import ufl
from ufl import Identity, cofac, det, dot, inner, outer, sqrt, tr


class Kinematics:
    """Deformation of one material point: F = I + H, fibre direction m (unit).

    invariant_variables: the invariants become UFL variables (`variables`: pairs of the
    variable and its expression in H) for the chain rule of invariant_chain.py; reading
    a tensor (H, F, C, E, M) then sets `tensor_read`.
    """

    TENSORS = ("H", "F", "C", "E", "M")

    def __init__(self, H, m, invariant_variables=False):
        I = Identity(3)
        self.H = H
        self.m = m
        self.F = I + H
        self.C = self.F.T * self.F
        self.E = (H + H.T + H.T * H) / 2
        self.M = outer(m, m)

        # The invariants every model is written in.  Working with these (instead of
        # C_e = F_a^-T C F_a^-1 or cof(C) : L as matrices) keeps the UFL graph and the
        # generated tangent kernels several times smaller.
        cofF = cofac(self.F)
        cofF_m = dot(cofF, m)
        Cm = dot(self.C, m)
        invariants = {
            "J": det(self.F),
            # lambda^2 - 1, exactly zero in the reference state
            "fibre_stretch_sq_m1": 2 * inner(self.E, self.M),
            "I1_m3": 2 * tr(self.E),                # tr C - 3
            "I2": inner(cofF, cofF),                # tr cof C
            "K4": dot(cofF_m, cofF_m),              # cof C : M (area stretch across the fibre)
            "I5": dot(Cm, Cm),                      # C^2 : M
        }
        self.variables = []
        self.tensor_read = False
        for name, expr in invariants.items():
            if invariant_variables:
                var = ufl.variable(expr)
                self.variables.append((var, expr))
                expr = var
            setattr(self, name, expr)
        self._derived()
        if invariant_variables:
            self._tensors = {t: self.__dict__.pop(t) for t in self.TENSORS}

    def _derived(self):
        self.I4 = 1 + self.fibre_stretch_sq_m1      # C : M = lambda^2
        self.fibre_stretch = sqrt(1 + self.fibre_stretch_sq_m1)

    def scale(self, s, s_m1, J):
        """The invariants of s F (F-bar), with s - 1 and det(s F) = J given.

        tr C and C : M scale with s^2, tr cof C, cof C : M and C^2 : M with s^4; the
        "- 1" and "- 3" are formed from s^2 - 1, so s = 1 exactly keeps them exact.  The
        tensors are not scaled: an energy that reads one is not differentiated through
        the invariants (invariant_chain.py).
        """
        s2, s2_m1 = s * s, s_m1 * (s + 1)
        self.fibre_stretch_sq_m1 = s2 * self.fibre_stretch_sq_m1 + s2_m1
        self.I1_m3 = s2 * self.I1_m3 + 3 * s2_m1
        for name in ("I2", "K4", "I5"):
            setattr(self, name, s2 * s2 * getattr(self, name))
        self.J = J
        self._derived()

    def __getattr__(self, name):
        # only reached for the tensors moved aside in invariant-variable mode
        tensors = self.__dict__.get("_tensors")
        if tensors is None or name not in tensors:
            known = sorted(set(self.TENSORS) | {k for k in self.__dict__ if not k.startswith("_")}
                           - {"variables", "tensor_read"})
            raise AttributeError(f"the kinematics have no {name!r}; they have {', '.join(known)}")
        self.tensor_read = True
        return tensors[name]


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
