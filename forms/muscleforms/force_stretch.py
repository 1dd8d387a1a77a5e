"""Force-stretch relations of the paper and the closed-form integrals the energies need.

Every branch switch is written as a strict inequality on a quantity that is exact
in the reference state, so the branch taken at the switch point is the one the
paper writes down (for example f_passive = 0 at lambda = 1).
"""

from ufl import conditional, exp, gt, le, ln, lt, sqrt

# ---------------------------------------------------------------------------
# Ehret / Weickenmeier / Giantesio force-stretch relation f_xi (paper eq. fxi)
# ---------------------------------------------------------------------------


def _s(stretch, lambda_min, lambda_opt):
    return (stretch - lambda_min) / (lambda_opt - lambda_min)


def force_stretch(stretch, lambda_min, lambda_opt):
    """f_xi(lambda) = s exp(1/2 - s^2/2), s = (lambda - lambda_min)/(lambda_opt - lambda_min)."""
    s = _s(stretch, lambda_min, lambda_opt)
    return conditional(gt(stretch, lambda_min), s * exp(0.5 - s * s / 2), 0.0)


def force_stretch_integral(stretch, lambda_min, lambda_opt):
    """int_{lambda_min}^{lambda} f_xi = (lambda_opt - lambda_min) e^(1/2) (1 - exp(-s^2/2))."""
    s = _s(stretch, lambda_min, lambda_opt)
    value = (lambda_opt - lambda_min) * exp(0.5) * (1 - exp(-s * s / 2))
    return conditional(gt(stretch, lambda_min), value, 0.0)


def uniaxial_first_invariant(stretch, omega_0):
    """I_p(l) = l^2 (1 - 2 w0/3) + 2 w0/(3 l)  (ERRATA item 1)."""
    return stretch**2 * (1 - 2 * omega_0 / 3) + 2 * omega_0 / (3 * stretch)


# ---------------------------------------------------------------------------
# Blemker: f_active (paper eq. fxia_blemker) and f_passive (eq. fxip_blemker)
# ---------------------------------------------------------------------------

# Antiderivative of f_active(x), zero at x = 1; the constants make it continuous at
# x = 0.6 and x = 1.4: F(0.6) = -0.4 + 4/3 0.4^3, minus 3 (0.2)^3 from the outer cubic.
_F_AT_06 = -0.4 + 4.0 / 3.0 * 0.4**3
_C_LOW = _F_AT_06 - 3 * 0.2**3
_C_HIGH = -_C_LOW


def blemker_active_integral(x):
    """int_1^x f_active(s) ds, with x = lambda/lambda_opt."""
    low = 3 * (x - 0.4)**3 + _C_LOW
    mid = (x - 1) + 4.0 / 3.0 * (1 - x)**3
    high = 3 * (x - 1.6)**3 + _C_HIGH
    return conditional(le(x, 0.6), low, conditional(lt(x, 1.4), mid, high))


def blemker_passive_integral(stretch_m1, stretch, P1, P2, lambda_star):
    """int_1^lambda f_passive(s) ds; stretch_m1 = lambda - 1 (computed without cancellation).

    f_passive = 0 for lambda <= 1, P1 (exp(P2 (lambda - 1)) - 1) below lambda_star and the
    tangent line P3 lambda + P4 above it.
    """
    e_star = exp(P2 * (lambda_star - 1))
    P3 = P1 * P2 * e_star
    P4 = P1 * (e_star - 1) - lambda_star * P3

    def exp_part(d):
        return P1 * ((exp(P2 * d) - 1) / P2 - d)

    at_star = exp_part(lambda_star - 1)
    linear = at_star + P3 * (stretch**2 - lambda_star**2) / 2 + P4 * (stretch - lambda_star)
    return conditional(gt(stretch_m1, 0.0),
                       conditional(lt(stretch, lambda_star), exp_part(stretch_m1), linear),
                       0.0)


# ---------------------------------------------------------------------------
# acosh(1 + x)^2, smooth through x = 0 (BLE's transverse shear invariant B2^2)
# ---------------------------------------------------------------------------

# Taylor coefficients of acosh(1 + x)^2 = 4 asinh(sqrt(x/2))^2 (checked in tests against
# std::acosh); with |x| < 1e-2 the truncation error is below 1e-16 relative.
_ACOSH_SQ_SERIES = (2.0, -1.0 / 3.0, 4.0 / 45.0, -1.0 / 35.0, 16.0 / 1575.0, -8.0 / 2079.0)
ACOSH_SQ_SERIES_RADIUS = 1e-2


def acosh1p_squared(x):
    """acosh(1 + x)^2 for x >= 0 (slightly negative x from round-off is fine).

    The closed form has an infinite derivative factor 1/sqrt(x) times acosh -> the paper's
    singularity of A_2 at theta = 1; the series is analytic there.
    """
    series = 0.0
    for c in reversed(_ACOSH_SQ_SERIES):
        series = (series + c) * x
    closed = ln(1 + x + sqrt(x * (2 + x)))**2
    return conditional(lt(x, ACOSH_SQ_SERIES_RADIUS), series, closed)
