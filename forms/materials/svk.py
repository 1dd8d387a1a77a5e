"""St. Venant-Kirchhoff: lambda/2 (tr E)^2 + mu E:E, for bone and labrum (small strains only)."""

from ufl import inner, tr

from muscleforms.law import PASSIVE_LAW
from muscleforms.parts import lame_from_young, young_poisson

PARAMETERS = young_poisson(E=1.0e5, nu=0.3)  # 0.1 GPa: the paper's bone
ACTIVATION = PASSIVE_LAW


def energy(kin, p, drive):
    mu, lmbda = lame_from_young(p)
    return lmbda / 2 * tr(kin.E)**2 + mu * inner(kin.E, kin.E)
