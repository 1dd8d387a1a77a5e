"""Compressible Neo-Hooke: mu/2 (I1 - 3) - mu ln J + lambda/2 ln(J)^2, for tendon and soft parts."""

from ufl import ln, tr

from muscleforms.law import PASSIVE_LAW
from muscleforms.parts import lame_from_young, young_poisson

PARAMETERS = young_poisson(E=1000.0, nu=0.3)
ACTIVATION = PASSIVE_LAW


def energy(kin, p, drive):
    mu, lmbda = lame_from_young(p)
    lnJ = ln(kin.J)
    return mu / 2 * (tr(kin.C) - 3) - mu * lnJ + lmbda / 2 * lnJ**2
