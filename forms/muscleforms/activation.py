"""omega_a at a material point for the laws whose activation comes from a C++ kernel.

The quadrature-point kernel (cpp/material/activation_kernels.cpp) solves for omega_a at
the current fibre stretch lambda0 and writes, per quadrature point, lambda0,
omega_a(lambda0), omega_a'(lambda0) and omega_a''(lambda0) (implicit-function theorem).
The forms use the Taylor polynomial in d = lambda - lambda0, so that value, first and
second derivative -- all that the stress and the exact tangent need -- are exact at
the current iterate while the rest of the model stays in UFL.
"""

TAYLOR_COEFFICIENTS = ("omega_a_lambda", "omega_a", "domega_a", "d2omega_a")

def taylor_omega(stretch, coefficients, order):
    d = stretch - coefficients["omega_a_lambda"]
    omega = coefficients["omega_a"] + coefficients["domega_a"] * d
    if order >= 2:
        omega += coefficients["d2omega_a"] * d * d / 2
    return omega
