"""Passive muscle: Ehret's transversely isotropic matrix, the passive state of WKM, GIANT and COMBI."""

from muscleforms.law import PASSIVE_LAW
from muscleforms.parts import EHRET_MATRIX_PARAMETERS, ehret_energy

PARAMETERS = EHRET_MATRIX_PARAMETERS
ACTIVATION = PASSIVE_LAW


def energy(kin, p, drive):
    return ehret_energy(kin, p, None)
