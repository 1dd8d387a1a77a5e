"""Laws run through a scene against their closed forms.

uniaxial_strain.yaml pulls a block to F = diag(1, 1, lambda): bottom clamped, sides on
rollers, top displaced.  The deformation is homogeneous, so every element (plain Q1,
F-bar, Q2) represents it exactly and the top's reaction per reference area is the
first Piola-Kirchhoff stress P33(lambda), written out here by hand from each law's
energy.  mooney_rivlin is a user's law compiled from outside the tree
(-DMUSCLE_MATERIALS=tests/materials/mooney_rivlin.py, as tools/muscle test builds).
"""
import math
import os
import subprocess
import sys

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "support"))
from checks import read_json  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
SCENE = os.path.join(HERE, "uniaxial_strain.yaml")
AREA, LENGTH = 10.0 * 10.0, 30.0  # meshes/block.geo defaults


def lame(E, nu):
    return E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))


def svk(l, E, nu):
    mu, lmbda = lame(E, nu)
    E33 = (l * l - 1) / 2
    return l * (lmbda + 2 * mu) * E33  # P = F S, S33 = (lambda + 2 mu) E33


def neohooke(l, E, nu):
    mu, lmbda = lame(E, nu)
    return mu * (l - 1 / l) + lmbda * math.log(l) / l


def mooney_rivlin(l, c1, c2, kappa):
    # d/dl of c1 (l^-2/3 (2 + l^2) - 3) + c2 (l^-4/3 (1 + 2 l^2) - 3) + kappa/2 (l - 1)^2
    return (c1 * (-2 / 3 * l**(-5 / 3) * (2 + l * l) + 2 * l**(1 / 3))
            + c2 * (-4 / 3 * l**(-7 / 3) * (1 + 2 * l * l) + 4 * l**(-1 / 3))
            + kappa * (l - 1))


# (law, parameters, closed form, element overrides)
CASES = [
    ("svk", {"E": 1.0e5, "nu": 0.3}, svk, []),
    ("svk", {"E": 2.0e3, "nu": 0.45}, svk, ["element.degree=2"]),
    ("neohooke", {"E": 1.0e3, "nu": 0.3}, neohooke, []),
    ("neohooke", {"E": 50.0, "nu": 0.49}, neohooke, ["element.fbar=false"]),
    ("mooney_rivlin", {"c1": 10.0, "c2": 5.0, "kappa": 100.0}, mooney_rivlin, []),
    ("mooney_rivlin", {"c1": 3.0, "c2": 0.0, "kappa": 300.0}, mooney_rivlin, ["element.degree=2"]),
]


def case_id(case):
    law, p, _, element = case
    return f"{law} " + " ".join(f"{k}={v:g}" for k, v in p.items()) + "".join(
        f" {e}" for e in element)


@pytest.mark.parametrize("case", CASES, ids=[case_id(c) for c in CASES])
@pytest.mark.parametrize("pull", [6.0, -6.0], ids=["tension", "compression"])
def test_uniaxial_strain(build, scratch, record, case, pull):
    law, parameters, closed_form, element = case
    sets = [f"parts[0].material.model={law}",
            f"boundary[3].value.ramp.value={pull}"] + element
    sets += [f"parts[0].material.parameters.{k}={v!r}" for k, v in parameters.items()]
    command = [os.path.join(build, "muscle-run"), SCENE, "--out", scratch]
    for s in sets:
        command += ["--set", s]
    run = subprocess.run(command, capture_output=True, text=True, timeout=600)
    if run.returncode == 2 and "unknown model" in run.stderr and law == "mooney_rivlin":
        pytest.fail("mooney_rivlin is not compiled: build with "
                    "-DMUSCLE_MATERIALS=tests/materials/mooney_rivlin.py (tools/muscle test does)")
    assert run.returncode == 0, run.stdout + run.stderr
    with open(os.path.join(scratch, "series.csv")) as f:
        rows = [line.strip().split(",") for line in f if line.strip()]
    header, rows = rows[0], [dict(zip(rows[0], map(float, r))) for r in rows[1:]]
    assert len(rows) == 4, header
    worst = 0.0
    for r in rows:
        l = 1 + r["u_top"] / LENGTH
        expected = closed_form(l, **parameters)
        measured = -r["force"] / AREA  # the body pulls the top face back
        worst = max(worst, abs(measured - expected) / abs(expected))
    record(f"{case_id(case)} {'tension' if pull > 0 else 'compression'}: "
           f"|P33 - closed form| / |P33| = {worst:.1e} (lambda = {l:.2f})")
    assert worst < 1e-7
    summary = read_json(os.path.join(scratch, "summary.json"))
    assert summary["overrides"], summary
