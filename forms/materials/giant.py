"""GIANT: Giantesio's active strain F = F_e F_a with the implicit omega_a of a C++ kernel.

F_a = eta M + eta^-1/2 (I - M), eta = 1 - omega_a, is coaxial with the fibre, so
C_e = F_a^-1 C F_a^-1 and cof(C_e) = F_a cof(C) F_a give
  tr C_e = I4/eta^2 + eta (I1 - I4),        C_e : M = I4/eta^2,
  tr cof C_e = eta^2 K4 + (I2 - K4)/eta,    cof C_e : M = eta^2 K4.
"""

from muscleforms.law import omega_kernel
from muscleforms.parts import (EHRET_ACTIVE_PARAMETERS, EHRET_MATRIX_PARAMETERS, ehret_energy,
                               ehret_exponentials, volumetric_penalty)

PARAMETERS = EHRET_MATRIX_PARAMETERS + EHRET_ACTIVE_PARAMETERS
# the stress contains omega_a' (the S_2 term); the tangent needs omega_a''
ACTIVATION = omega_kernel("giant", taylor_order=2)
PASSIVE = "ehret_passive"
FIT_PARAMETERS = ["alpha", "beta", "gamma", "omega_0", "lambda_opt", "lambda_min", "N_a"]
# one of the paper's four (loadcases --model all)
DEFAULT_FOR = ("paper",)


def energy(kin, p, drive):
    if drive.omega is None:
        return ehret_energy(kin, p, None)
    w0 = p["omega_0"]
    eta = 1 - drive.omega
    I4_e = kin.I4 / eta**2
    K4_e = eta**2 * kin.K4
    Ie_m1 = w0 / 3 * (I4_e + eta * (kin.I1_m3 + 3 - kin.I4) - 3) + (1 - w0) * (I4_e - 1)
    Je_m1 = w0 / 3 * (K4_e + (kin.I2 - kin.K4) / eta - 3) + (1 - w0) * (K4_e - 1)
    return ehret_exponentials(Ie_m1, Je_m1, p) + volumetric_penalty(kin.J, p["gamma"], p["kappa"])
