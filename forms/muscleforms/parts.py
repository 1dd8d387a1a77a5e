"""Parts that laws compose their energies from (paper section 3), one material point.

Each part takes the kinematics (kinematics.py) and the parameters as UFL constants by
name.  Nothing here knows about meshes, assembly or which law uses it.
"""

from ufl import exp, ln, sqrt

from .force_stretch import (acosh1p_squared, blemker_active_integral, blemker_passive_integral,
                            force_stretch_integral, uniaxial_first_invariant)
from .law import interval, nonnegative, positive

# Ehret et al.'s matrix (WKM, GIANT, COMBI and their passive state; Table fitting_all)
EHRET_MATRIX_PARAMETERS = [
    positive("alpha", 2.3796, "-", "along-fibre exponent"),
    positive("beta", 0.5161, "-", "transverse exponent"),
    positive("gamma", 27.1072, "kPa", "stiffness"),
    interval("omega_0", 0.6388, 0, 1, "-", "weight of the isotropic matrix"),
    positive("kappa", 1000.0, "-", "incompressibility parameter"),
]
# the uniaxial active response the omega_a of WKM, GIANT and COMBI is built from
EHRET_ACTIVE_PARAMETERS = [
    positive("lambda_opt", 1.1806, "-", "optimal fibre stretch"),
    positive("lambda_min", 0.5680, "-", "minimal active fibre stretch"),
    nonnegative("P_opt", 64.6809, "kPa", "peak active nominal stress"),
]


def volumetric_penalty(J, gamma, kappa):
    """gamma/(4 kappa) (det(C)^-kappa - 1), the coupled penalty of the Ehret matrix."""
    return gamma / (4 * kappa) * (exp(-2 * kappa * ln(J)) - 1)


def log_volumetric(J, kappa):
    """kappa/2 ln(J)^2."""
    return kappa / 2 * ln(J)**2


def ehret_exponentials(I_m1, J_m1, p):
    return p["gamma"] / 4 * ((exp(p["alpha"] * I_m1) - 1) / p["alpha"]
                             + (exp(p["beta"] * J_m1) - 1) / p["beta"])


def ehret_energy(kin, p, omega):
    """Weickenmeier's generalized active strain in Ehret's coupled compressible form
    (eq. Psi_WKM); omega = None: the passive matrix.

    With L~ = w0/3 I + (1 - w0) M:  I~ = C:L~ + omega_a C:M,  J~ = cof(C):L~.
    """
    w0 = p["omega_0"]
    I_m1 = w0 / 3 * kin.I1_m3 + (1 - w0) * kin.fibre_stretch_sq_m1
    if omega is not None:
        I_m1 += omega * kin.I4
    J_m1 = w0 / 3 * (kin.I2 - 3) + (1 - w0) * (kin.K4 - 1)
    return ehret_exponentials(I_m1, J_m1, p) + volumetric_penalty(kin.J, p["gamma"], p["kappa"])


def ehret_volumetric_stiff_part(kin, p):
    """The coupled penalty minus its reference stress -gamma/2 (R(1) = R'(1) = 0).

    The reference stress balances the Ehret terms and must stay fully integrated,
    otherwise distorted elements carry a spurious self-stress.
    """
    return volumetric_penalty(kin.J, p["gamma"], p["kappa"]) + p["gamma"] / 2 * (kin.J - 1)


def combi_activation(stretch, p, level):
    """COMBI's explicit omega_a = ln(phi)/(alpha lambda^2) (paper section modified_material)."""
    Ip = uniaxial_first_invariant(stretch, p["omega_0"])
    phi = 1 + (4 * p["alpha"] / p["gamma"] * exp(p["alpha"] * (1 - Ip)) * p["P_opt"] * level
               * force_stretch_integral(stretch, p["lambda_min"], p["lambda_opt"]))
    return ln(phi) / (p["alpha"] * stretch**2)


def modified_fibre_stretch(kin):
    """(lambda_bar, lambda_bar - 1) of the isochoric part; lambda_bar^2 - 1 is exact in
    the reference state."""
    Jm23 = kin.J**(-2.0 / 3.0)
    stretch_sq_m1 = Jm23 * kin.fibre_stretch_sq_m1 + (Jm23 - 1)
    stretch = sqrt(1 + stretch_sq_m1)
    return stretch, stretch_sq_m1 / (stretch + 1)


def blemker_shear(kin, p):
    """G1 B1^2 + G2 B2^2: Blemker's along- and transverse-fibre shear invariants."""
    Jm23 = kin.J**(-2.0 / 3.0)
    I1b = Jm23 * (kin.I1_m3 + 3)
    I4b = Jm23 * kin.I4
    I5b = Jm23**2 * kin.I5
    # B1^2 = I5/I4^2 - 1 needs no square root; the J factors cancel.
    B1_sq = kin.I5 / kin.I4**2 - 1
    theta_m1 = (I1b * I4b - I5b) / (2 * sqrt(I4b)) - 1
    return p["G1"] * B1_sq + p["G2"] * acosh1p_squared(theta_m1)


def blemker_fibre(kin, p, level):
    """sigma_max (passive fibre integral + alpha_a level active integral); level None:
    passive only."""
    stretch, stretch_m1 = modified_fibre_stretch(kin)
    psi = p["sigma_max"] * blemker_passive_integral(stretch_m1, stretch, p["P1"], p["P2"],
                                                    p["lambda_star"])
    if level is not None:
        psi += (p["sigma_max"] * p["alpha_a"] * level
                * blemker_active_integral(stretch / p["lambda_opt"]))
    return psi


def isochoric_neo_hooke(kin, mu):
    """mu/2 (I1_bar - 3)."""
    Jm23 = kin.J**(-2.0 / 3.0)
    return mu / 2 * (Jm23 * kin.I1_m3 + 3 * (Jm23 - 1))


def lame_from_young(p):
    """(mu, lambda) of Young's modulus E and Poisson's ratio nu."""
    E, nu = p["E"], p["nu"]
    return E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))


def young_poisson(E, nu):
    """Parameters E and nu with presets."""
    return [positive("E", E, "kPa", "Young's modulus"),
            interval("nu", nu, -1, 0.5, "-", "Poisson's ratio", lower_open=True,
                     upper_open=True)]
