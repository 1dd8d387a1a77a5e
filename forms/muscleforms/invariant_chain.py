"""Residual and tangent of an energy through its invariants (the chain rule written out).

UFL differentiates forward: diff(psi, H) carries a 3x3 derivative through every scalar
node of psi, and derivative(., u, du) then 3x3 more per node, so FFCx's tangent kernel
computes about 81 values per node of psi at every quadrature point (BLE Q1: 16,700).
With the invariants I_k of the energy as UFL variables,

    R[v]     = sum_k psi_k dI_k[v],
    K[v, du] = sum_k (sum_l psi_kl dI_l[du]) dI_k[v] + psi_k d2I_k[v, du],

psi_k and psi_kl hold no test or trial function (one value each per point), and only the
few small I_k(H) carry the arguments.  The same residual and the exact tangent, up to
round-off.

An energy that reads a tensor of the kinematics (F, C, E, H, M: Neo-Hooke's tr C, St.
Venant-Kirchhoff's E) is not a function of the invariants alone; chain_forms then
returns None and the caller differentiates psi(H) as before.

A law whose stress holds omega_a fixed (WKM) builds omega_a on kinematics of its own:
their invariants are left out of R's sum (the stress does not see them) and kept in K's
inner sum (the tangent does).
"""

from ufl import derivative, diff, inner
from ufl.constantvalue import Zero

from .activation import taylor_omega
from .law import Drive


def _terms(psi, variables):
    """(variable, expression, d psi / d variable) for the variables psi depends on."""
    out = []
    for var, expr in variables:
        d = diff(psi, var)
        if not isinstance(d, Zero):
            out.append((var, expr, d))
    return out


def chain_forms(law, kinematics, p, level, taylor, state, test, trial, part=None,
                trial_state=None):
    """(residual integrand, tangent integrand) of the law's energy, or None.

    kinematics() -> a fresh Kinematics with invariant variables, functions of `state`;
    part(kin, p, psi) -> the energy to differentiate (default psi itself), for the
    anti-locking split into the stiff volumetric part and the rest;
    trial_state: the coefficient the tangent differentiates in direction `trial` (default
    `state`), for the off-diagonal blocks of a system of two fields (Taylor-Hood).
    """
    if trial_state is None:
        trial_state = state
    kin = kinematics()
    kin_omega = kin
    omega = None
    if taylor is not None:
        if law.activation.stress_holds_omega:
            kin_omega = kinematics()
        omega = taylor_omega(kin_omega.fibre_stretch, taylor, law.activation.taylor_order)
    psi = law.energy(kin, p, Drive(level, omega))
    if part is not None:
        psi = part(kin, p, psi)
    if kin.tensor_read or kin_omega.tensor_read:
        return None

    held = kin_omega.variables if kin_omega is not kin else []
    first = {id(var): derivative(expr, state, test) for var, expr in kin.variables}
    residual = 0
    tangent = 0
    for var, expr, psi_k in _terms(psi, kin.variables):
        dI_k = first[id(var)]
        residual += psi_k * dI_k
        inner_sum = 0
        for _, expr_l, psi_kl in _terms(psi_k, kin.variables + held):
            inner_sum += psi_kl * derivative(expr_l, trial_state, trial)
        tangent += inner_sum * dI_k + psi_k * derivative(dI_k, trial_state, trial)
    return residual, tangent


def energy_forms(law, kinematics, P, H, p, level, taylor, state, test, trial, part=None,
                 trial_state=None):
    """chain_forms, or for an energy that reads a tensor the stress P = dpsi/dH through
    the chain rule of the displacement gradient H(state): (P : dH[test], its derivative)."""
    chained = chain_forms(law, kinematics, p, level, taylor, state, test, trial, part,
                          trial_state)
    if chained is not None:
        return chained
    residual = inner(P, derivative(H, state, test))
    return residual, derivative(residual, state if trial_state is None else trial_state, trial)
