"""COMBI: the paper's modified model, WKM's energy with an explicit omega_a of the tanh level."""

from muscleforms.law import TANH_LEVEL
from muscleforms.parts import (EHRET_ACTIVE_PARAMETERS, EHRET_MATRIX_PARAMETERS, combi_activation,
                               ehret_energy)

PARAMETERS = EHRET_MATRIX_PARAMETERS + EHRET_ACTIVE_PARAMETERS
ACTIVATION = TANH_LEVEL
PASSIVE = "ehret_passive"
FIT_PARAMETERS = ["alpha", "beta", "gamma", "omega_0", "lambda_opt", "lambda_min", "P_opt"]
# the muscle of a scene part without a material and of fusiform; one of the paper's four
DEFAULT_FOR = ("muscle", "paper")


def energy(kin, p, drive):
    omega = None if drive.level is None else combi_activation(kin.fibre_stretch, p, drive.level)
    return ehret_energy(kin, p, omega)
