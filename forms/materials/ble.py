"""BLE: Blemker's active stress with a Neo-Hooke matrix and kappa/2 ln(J)^2 (paper eq. Psi_Ble)."""

from muscleforms.law import TANH_LEVEL, interval, nonnegative, positive
from muscleforms.parts import blemker_fibre, blemker_shear, isochoric_neo_hooke, log_volumetric

PARAMETERS = [
    nonnegative("G1", 0.1, "kPa", "along-fibre shear modulus"),
    nonnegative("G2", 0.05, "kPa", "transverse-fibre shear modulus"),
    nonnegative("P1", 3.6055, "-", "magnitude of passive fibre tension"),
    positive("P2", 4.4883, "-", "exponential rate of passive fibre tension"),
    positive("lambda_opt", 1.2264, "-", "optimal fibre stretch"),
    interval("lambda_star", 1.4, 1, float("inf"), "-",
             "fibre stretch where passive tension turns linear", lower_open=True, upper_open=True),
    nonnegative("sigma_max", 1.145, "kPa", "maximum isometric stress"),
    nonnegative("alpha_a", 69.5471, "-", "activation amplitude"),
    nonnegative("mu", 10.0, "kPa", "Neo-Hooke shear modulus"),
    positive("kappa", 10000.0, "kPa", "bulk modulus"),
]
ACTIVATION = TANH_LEVEL
FIT_PARAMETERS = ["G1", "G2", "P1", "P2", "lambda_opt", "alpha_a", "mu"]
# the law of a fit result before the fit; one of the paper's four
DEFAULT_FOR = ("fit", "paper")


def energy(kin, p, drive):
    return (blemker_shear(kin, p) + blemker_fibre(kin, p, drive.level)
            + isochoric_neo_hooke(kin, p["mu"]) + log_volumetric(kin.J, p["kappa"]))


def volumetric_stiff_part(kin, p):
    # the rest of the energy is isochoric: nothing else needs the penalty
    return log_volumetric(kin.J, p["kappa"])
