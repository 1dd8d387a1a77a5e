"""WKM: Weickenmeier's generalized active strain, omega_a from the twitch train (eq. Psi_WKM)."""

from muscleforms.law import omega_kernel
from muscleforms.parts import EHRET_ACTIVE_PARAMETERS, EHRET_MATRIX_PARAMETERS, ehret_energy

PARAMETERS = EHRET_MATRIX_PARAMETERS + EHRET_ACTIVE_PARAMETERS
# the paper's stress S_WKM holds omega_a fixed; the tangent needs omega_a'
ACTIVATION = omega_kernel("wkm", taylor_order=1, stress_holds_omega=True)
PASSIVE = "ehret_passive"
FIT_PARAMETERS = ["alpha", "beta", "gamma", "omega_0", "lambda_opt", "lambda_min", "N_a"]
# one of the paper's four (loadcases --model all)
DEFAULT_FOR = ("paper",)


def energy(kin, p, drive):
    return ehret_energy(kin, p, drive.omega)
