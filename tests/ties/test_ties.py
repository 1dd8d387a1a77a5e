"""Tie of non-matching meshes: the patch test and bad input.

tied_blocks.yaml stretches two separately meshed Neo-Hooke blocks (3 and 2 cells per
edge) to lambda = 1.2 in uniaxial stress.  The exact solution is homogeneous, linear in
x, so a tie whose slave nodes interpolate the master facets reproduces it exactly: the
same reactions at both ends, the closed-form stress and lateral stretch, no jump at the
interface.  The same on 2 ranks.
"""
import json
import math
import os
import sys

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "support"))
from checks import muscle_run, series_rows  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
E, NU = 1000.0, 0.3
MU_L, LAMBDA_L = E / (2 * (1 + NU)), E * NU / ((1 + NU) * (1 - 2 * NU))


def lateral_stretch(lam):
    """mu with P11 = mu_L (mu - 1/mu) + lambda_L ln(mu^2 lam) / mu = 0 (bisection)."""
    lo, hi = 0.5, 1.5
    for _ in range(200):
        mu = 0.5 * (lo + hi)
        if MU_L * (mu - 1 / mu) + LAMBDA_L * math.log(mu * mu * lam) / mu > 0:
            hi = mu
        else:
            lo = mu
    return 0.5 * (lo + hi)


def nominal_stress(lam):
    mu = lateral_stretch(lam)
    return MU_L * (lam - 1 / lam) + LAMBDA_L * math.log(mu * mu * lam) / lam


def run(build, out, sets=(), ranks=1):
    return muscle_run(build, os.path.join(HERE, "tied_blocks.yaml"), out, sets, ranks)


def last_row(out):
    return series_rows(out)[-1]


@pytest.mark.parametrize("ranks", [1, 2])
@pytest.mark.parametrize("slave", ["fine", "coarse"])
def test_tie_patch(build, scratch, record, slave, ranks):
    sets = [] if slave == "fine" else ["tie[0].surfaces=[upper_bottom, lower_top]"]
    result = run(build, scratch, sets, ranks)
    assert result.returncode == 0, result.stdout + result.stderr
    r = last_row(scratch)
    lam = 1.2
    mu = lateral_stretch(lam)
    force = nominal_stress(lam) * 100.0
    errors = {
        "top reaction": abs(abs(r["top_force"]) - force) / force,
        "bottom reaction": abs(abs(r["bottom_force"]) - force) / force,
        "lower lateral": abs(r["lower_x"] - 10 * (mu - 1)) / (10 * (1 - mu)),
        "upper lateral": abs(r["upper_x"] - 10 * (mu - 1)) / (10 * (1 - mu)),
        "interface (master node)": abs(r["lower_z"] - 2.0) / 2.0,
        "interface (inside a facet)": abs(r["interface_z"] - 2.0) / 2.0,
    }
    worst = max(errors, key=errors.get)
    record(f"tie patch test, {slave} slave, {ranks} rank(s): largest relative error "
           f"{errors[worst]:.1e} ({worst}); force {force:.6f} mN")
    assert errors[worst] < 1e-8, errors


@pytest.mark.parametrize("change, message", [
    (["tie[0].surfaces=[lower_top, top]"], "from the master surface"),
    (["tie[0].surfaces=[lower_top, nowhere]"], "nowhere"),
    (["tie[0].surfaces=[lower_top, lower_top]"], "itself"),
    (["boundary[3]={uniform_axial: top, component: z}"], "uniform_axial"),
], ids=["surfaces apart", "unknown surface", "same surface", "with uniform_axial"])
def test_tie_broken(build, scratch, change, message):
    result = run(build, scratch, change)
    assert result.returncode == 2, result.stdout + result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], result.stderr


STIFF_SOFT = os.path.join(HERE, "..", "..", "demos", "scenes", "stiff_soft.yaml")


def test_tie_stiff_soft(build, scratch, record):
    """demos/scenes/stiff_soft.yaml at contrast 1e5 (bone E = 2.301e7 kPa), coarse, one
    step: GMRES + GAMG with the per-body near-null space on 2 ranks (the bodies found
    across ranks) ends where MUMPS does, to the solver tolerances."""
    sets = ["mesh.set.n_lower=4", "mesh.set.n_upper=6", "time.end=0.01",
            "parts[0].material.parameters.E=2.301e7", "solver.near_null_space=bodies"]
    out = {}
    for solver, ranks in (("lu", 1), ("gmres-gamg", 2)):
        folder = os.path.join(scratch, solver)
        result = muscle_run(build, STIFF_SOFT, folder, sets + [f"solver.linear={solver}"], ranks)
        assert result.returncode == 0, result.stdout + result.stderr
        with open(os.path.join(folder, "summary.json")) as f:
            out[solver] = json.load(f)
    lu, gamg = out["lu"], out["gmres-gamg"]
    assert gamg["built"]["bodies"] == 2
    errors = {k: abs(gamg["final"][k] - lu["final"][k]) / abs(lu["final"][k])
              for k in ("force", "interface_z", "muscle_x")}
    per_newton = gamg["linear_iterations"] / gamg["newton_iterations"]
    record(f"stiff-soft, contrast 1e5: GAMG (2 ranks) against MUMPS {max(errors.values()):.1e} "
           f"(force {lu['final']['force']:.6g} mN); {per_newton:.1f} Krylov its per Newton it")
    assert max(errors.values()) < 1e-7, errors
