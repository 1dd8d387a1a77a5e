"""Mooney-Rivlin: c1 (I1_bar - 3) + c2 (I2_bar - 3) + kappa/2 (J - 1)^2 (a user's law, tests/materials)."""

from muscleforms.law import PASSIVE_LAW, nonnegative, positive

PARAMETERS = [
    nonnegative("c1", 10.0, "kPa", "first Mooney-Rivlin constant"),
    nonnegative("c2", 5.0, "kPa", "second Mooney-Rivlin constant"),
    positive("kappa", 100.0, "kPa", "bulk modulus"),
]
ACTIVATION = PASSIVE_LAW


def energy(kin, p, drive):
    J = kin.J
    I1_bar = J**(-2.0 / 3.0) * (kin.I1_m3 + 3)
    I2_bar = J**(-4.0 / 3.0) * kin.I2
    return p["c1"] * (I1_bar - 3) + p["c2"] * (I2_bar - 3) + p["kappa"] / 2 * (J - 1)**2
