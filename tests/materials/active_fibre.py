"""Active fibre: Mooney-Rivlin with an active fibre stress sigma_a x level (a user's law, tests)."""

from muscleforms.law import TANH_LEVEL, nonnegative, positive

PARAMETERS = [
    nonnegative("c1", 10.0, "kPa", "first Mooney-Rivlin constant"),
    nonnegative("c2", 5.0, "kPa", "second Mooney-Rivlin constant"),
    positive("kappa", 100.0, "kPa", "bulk modulus"),
    nonnegative("sigma_a", 20.0, "kPa", "active nominal fibre stress at full activation"),
]
ACTIVATION = TANH_LEVEL  # drive.level = tanh(c (t - t0)) x scale; the passive kernels: drive None


def energy(kin, p, drive):
    J = kin.J
    I1_bar = J**(-2.0 / 3.0) * (kin.I1_m3 + 3)
    I2_bar = J**(-4.0 / 3.0) * kin.I2
    psi = p["c1"] * (I1_bar - 3) + p["c2"] * (I2_bar - 3) + p["kappa"] / 2 * (J - 1)**2
    if drive.level is None:
        return psi
    # d/dF of sigma_a level (lambda - 1): the nominal stress sigma_a level along the fibre
    return psi + p["sigma_a"] * drive.level * (kin.fibre_stretch - 1)
