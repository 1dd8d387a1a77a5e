"""Strain-energy functions of the four muscle models (paper section 3), one material point.

Each function takes the kinematics, a dict of material parameters (UFL Constants named
as in the paper) and what drives the activation, and returns the energy density.
Nothing here knows about meshes or assembly.

Activation drivers:
  level  -- dimensionless activation at the point: time factor x element scale
            (None: passive, the active terms are not even built)
  omega  -- activation parameter omega_a (UFL expression) for the active-strain models
"""

from ufl import exp, ln, sqrt, tr

from .force_stretch import (acosh1p_squared, blemker_active_integral, blemker_passive_integral,
                            force_stretch_integral, uniaxial_first_invariant)

# Parameter names as the forms see them (UFL Constants of these names).  The time
# function parameters (c, t0, N_a, twitch data) live in C++ only.
PARAMETERS = {
    "ble": ["G1", "G2", "P1", "P2", "lambda_opt", "lambda_star", "sigma_max", "alpha_a", "mu", "kappa"],
    "ble_passive": ["G1", "G2", "P1", "P2", "lambda_star", "sigma_max", "mu", "kappa"],
    "wkm": ["alpha", "beta", "gamma", "omega_0", "kappa"],
    "giant": ["alpha", "beta", "gamma", "omega_0", "kappa"],
    "combi": ["alpha", "beta", "gamma", "omega_0", "kappa", "lambda_opt", "lambda_min", "P_opt"],
    "ehret_passive": ["alpha", "beta", "gamma", "omega_0", "kappa"],
    "neohooke": ["mu", "lmbda"],
}


def volumetric_penalty(J, gamma, kappa):
    """gamma/(4 kappa) (det(C)^-kappa - 1), the coupled penalty of WKM, GIANT and COMBI."""
    return gamma / (4 * kappa) * (exp(-2 * kappa * ln(J)) - 1)


def volumetric_stiff_part(model, J, p):
    """The part of Psi that enforces near-incompressibility, with zero stress at J = 1.

    Q1 elements lock under it; integrating it with a one-point rule (selective reduced
    integration, the B-bar / mean-dilatation family of anti-locking choices) removes
    the locking.  The coupled penalty's reference stress -gamma/2 balances the Ehret
    terms and must stay fully integrated, otherwise distorted elements carry a
    spurious self-stress; so only the remainder with R(1) = R'(1) = 0 is returned.
    """
    if model in ("ble", "ble_passive"):
        return p["kappa"] / 2 * ln(J)**2
    if model in ("wkm", "giant", "combi", "ehret_passive"):
        return volumetric_penalty(J, p["gamma"], p["kappa"]) + p["gamma"] / 2 * (J - 1)
    if model == "neohooke":
        return p["lmbda"] / 2 * ln(J)**2
    raise ValueError(f"unknown model {model}")


def ble_energy(kin, p, level):
    """Blemker active stress + Neo-Hooke + kappa/2 ln(J)^2 (paper eq. Psi_Ble, our variant)."""
    J = kin.J
    Jm23 = J**(-2.0 / 3.0)
    I1b = Jm23 * (kin.I1_m3 + 3)
    I4b = Jm23 * kin.I4
    I5b = Jm23**2 * kin.I5

    # B1^2 = I5/I4^2 - 1 needs no square root; the J factors cancel.
    B1_sq = kin.I5 / kin.I4**2 - 1
    theta_m1 = (I1b * I4b - I5b) / (2 * sqrt(I4b)) - 1
    B2_sq = acosh1p_squared(theta_m1)

    # modified fibre stretch; lambda_bar^2 - 1 is exact in the reference state
    stretch_sq_m1 = Jm23 * kin.fibre_stretch_sq_m1 + (Jm23 - 1)
    stretch = sqrt(1 + stretch_sq_m1)
    stretch_m1 = stretch_sq_m1 / (stretch + 1)

    psi_fibre = p["sigma_max"] * blemker_passive_integral(stretch_m1, stretch, p["P1"], p["P2"],
                                                          p["lambda_star"])
    if level is not None:
        psi_fibre += (p["sigma_max"] * p["alpha_a"] * level
                      * blemker_active_integral(stretch / p["lambda_opt"]))

    psi_neo_hooke = p["mu"] / 2 * (Jm23 * kin.I1_m3 + 3 * (Jm23 - 1))
    psi_vol = p["kappa"] / 2 * ln(J)**2
    return p["G1"] * B1_sq + p["G2"] * B2_sq + psi_fibre + psi_neo_hooke + psi_vol


def _ehret_exponentials(I_m1, J_m1, p):
    return p["gamma"] / 4 * ((exp(p["alpha"] * I_m1) - 1) / p["alpha"]
                             + (exp(p["beta"] * J_m1) - 1) / p["beta"])


def wkm_energy(kin, p, omega):
    """Weickenmeier generalized active strain, coupled compressible form (eq. Psi_WKM).

    With L~ = w0/3 I + (1 - w0) M:  I~ = C:L~ + omega_a C:M,  J~ = cof(C):L~.
    """
    w0 = p["omega_0"]
    I_m1 = w0 / 3 * kin.I1_m3 + (1 - w0) * kin.fibre_stretch_sq_m1
    if omega is not None:
        I_m1 += omega * kin.I4
    J_m1 = w0 / 3 * (kin.I2 - 3) + (1 - w0) * (kin.K4 - 1)
    return _ehret_exponentials(I_m1, J_m1, p) + volumetric_penalty(kin.J, p["gamma"], p["kappa"])


def giant_energy(kin, p, omega):
    """Giantesio active strain, F = F_e F_a, F_a = eta M + eta^-1/2 (I - M), eta = 1 - omega_a.

    F_a is coaxial with the fibre, so C_e = F_a^-1 C F_a^-1 and cof(C_e) = F_a cof(C) F_a give
      tr C_e = I4/eta^2 + eta (I1 - I4),        C_e : M = I4/eta^2,
      tr cof C_e = eta^2 K4 + (I2 - K4)/eta,    cof C_e : M = eta^2 K4.
    """
    w0 = p["omega_0"]
    eta = 1 - omega
    I4_e = kin.I4 / eta**2
    K4_e = eta**2 * kin.K4
    Ie_m1 = w0 / 3 * (I4_e + eta * (kin.I1_m3 + 3 - kin.I4) - 3) + (1 - w0) * (I4_e - 1)
    Je_m1 = w0 / 3 * (K4_e + (kin.I2 - kin.K4) / eta - 3) + (1 - w0) * (K4_e - 1)
    return _ehret_exponentials(Ie_m1, Je_m1, p) + volumetric_penalty(kin.J, p["gamma"], p["kappa"])


def combi_activation(stretch, p, level):
    """COMBI's explicit omega_a = ln(phi)/(alpha lambda^2) (paper section modified_material)."""
    Ip = uniaxial_first_invariant(stretch, p["omega_0"])
    phi = 1 + (4 * p["alpha"] / p["gamma"] * exp(p["alpha"] * (1 - Ip)) * p["P_opt"] * level
               * force_stretch_integral(stretch, p["lambda_min"], p["lambda_opt"]))
    return ln(phi) / (p["alpha"] * stretch**2)


def neohooke_energy(kin, p):
    """Compressible Neo-Hooke, the cost yardstick of the benchmarks."""
    lnJ = ln(kin.J)
    return p["mu"] / 2 * (tr(kin.C) - 3) - p["mu"] * lnJ + p["lmbda"] / 2 * lnJ**2
