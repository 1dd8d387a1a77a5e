"""Laws run through a scene against their closed forms, and users' laws through every command.

uniaxial_strain.yaml pulls a block to F = diag(1, 1, lambda): bottom clamped, sides on
rollers, top displaced.  The deformation is homogeneous, so every element (plain Q1,
F-bar, Q2, Taylor-Hood; P1, P2 on tet_block.geo) represents it exactly and the top's
reaction per reference area is the first Piola-Kirchhoff stress P33(lambda), written out
here by hand from each law's energy.  mooney_rivlin (passive) and active_fibre (active)
are users' laws compiled from outside the tree (-DMUSCLE_MATERIALS="tests/materials/
mooney_rivlin.py;tests/materials/active_fibre.py", as tools/muscle test builds): they go
through every element here, and test_users_law_* runs them through the other commands
(loadcases, fit, fusiform).
"""
import json
import math
import os
import subprocess
import sys

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "support"))
from checks import read_json  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
SCENE = os.path.join(HERE, "uniaxial_strain.yaml")
AREA, LENGTH = 10.0 * 10.0, 30.0  # meshes/block.geo defaults, tet_block.geo's
USERS_LAWS = {"mooney_rivlin": "mooney_rivlin.py", "active_fibre": "active_fibre.py"}
TET = ["mesh.file=tet_block.geo"]  # unstructured tetrahedra, same block and groups
ACTIVE = ["parts[0].activation.time.constant=1"]  # level = 1 x scale 1


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


def active_fibre(l, c1, c2, kappa, sigma_a):
    # the fibre along the pull, level 1: d/dl of sigma_a (l - 1) added
    return mooney_rivlin(l, c1, c2, kappa) + sigma_a


# (law, parameters, closed form, element overrides)
CASES = [
    ("svk", {"E": 1.0e5, "nu": 0.3}, svk, []),
    ("svk", {"E": 2.0e3, "nu": 0.45}, svk, ["element.degree=2"]),
    ("neohooke", {"E": 1.0e3, "nu": 0.3}, neohooke, []),
    ("neohooke", {"E": 50.0, "nu": 0.49}, neohooke, ["element.fbar=false"]),
    ("mooney_rivlin", {"c1": 10.0, "c2": 5.0, "kappa": 100.0}, mooney_rivlin, []),
    ("mooney_rivlin", {"c1": 3.0, "c2": 0.0, "kappa": 300.0}, mooney_rivlin, ["element.degree=2"]),
    # the users' laws on every element: Q1 F-bar (the default), plain Q1, Q2, Taylor-Hood,
    # P1, P2, Taylor-Hood on tetrahedra; passive and active
    ("mooney_rivlin", {"c1": 10.0, "c2": 5.0, "kappa": 100.0}, mooney_rivlin, ["element.fbar=false"]),
    ("mooney_rivlin", {"c1": 10.0, "c2": 5.0, "kappa": 100.0}, mooney_rivlin, ["element.degree=2", "element.taylor_hood=true"]),
    ("mooney_rivlin", {"c1": 10.0, "c2": 5.0, "kappa": 100.0}, mooney_rivlin, TET),
    ("mooney_rivlin", {"c1": 10.0, "c2": 5.0, "kappa": 100.0}, mooney_rivlin, TET + ["element.degree=2"]),
    ("mooney_rivlin", {"c1": 10.0, "c2": 5.0, "kappa": 100.0}, mooney_rivlin, TET + ["element.degree=2", "element.taylor_hood=true"]),
    ("active_fibre", {"c1": 10.0, "c2": 5.0, "kappa": 100.0, "sigma_a": 20.0}, active_fibre, ACTIVE),
    ("active_fibre", {"c1": 10.0, "c2": 5.0, "kappa": 100.0, "sigma_a": 20.0}, active_fibre, ACTIVE + ["element.fbar=false"]),
    ("active_fibre", {"c1": 10.0, "c2": 5.0, "kappa": 100.0, "sigma_a": 20.0}, active_fibre, ACTIVE + ["element.degree=2"]),
    ("active_fibre", {"c1": 10.0, "c2": 5.0, "kappa": 100.0, "sigma_a": 20.0}, active_fibre, ACTIVE + ["element.degree=2", "element.taylor_hood=true"]),
    ("active_fibre", {"c1": 10.0, "c2": 5.0, "kappa": 100.0, "sigma_a": 20.0}, active_fibre, ACTIVE + TET),
    ("active_fibre", {"c1": 10.0, "c2": 5.0, "kappa": 100.0, "sigma_a": 20.0}, active_fibre, ACTIVE + TET + ["element.degree=2"]),
    ("active_fibre", {"c1": 10.0, "c2": 5.0, "kappa": 100.0, "sigma_a": 20.0}, active_fibre,
     ACTIVE + TET + ["element.degree=2", "element.taylor_hood=true"]),
]


def users_law_compiled(run, law):
    """Fail with the remedy if a users' law is not in this build."""
    if run.returncode == 2 and "unknown model" in run.stderr and law in USERS_LAWS:
        pytest.fail(f"{law} is not compiled: build with -DMUSCLE_MATERIALS="
                    f"tests/materials/{USERS_LAWS[law]} (tools/muscle test does)")


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
    users_law_compiled(run, law)
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


# ------------------------------------------------- users' laws through every command --

def run_command(build, law, *args):
    binary = os.path.join(build, args[0])
    run = subprocess.run([binary, *args[1:]], capture_output=True, text=True, timeout=600)
    users_law_compiled(run, law)
    assert run.returncode == 0, f"{' '.join(args)}: exit {run.returncode}\n{run.stdout}{run.stderr}"
    return run


def read_csv(path):
    with open(path) as f:
        rows = [line.strip().split(",") for line in f if line.strip()]
    return [dict(zip(rows[0], r)) for r in rows[1:]]


def incompressible_mooney_rivlin(l, c1, c2):
    # uniaxial tension of the incompressible solid: J = 1, lateral stretch l^-1/2
    return 2 * (c1 + c2 / l) * (l - l**-2)


@pytest.mark.parametrize("law", ["mooney_rivlin", "active_fibre"])
def test_users_law_loadcases(build, scratch, record, law):
    # loadcases --model LAW: the exact incompressible response against its closed form,
    # the single-element FE beside it; the active state adds sigma_a along the fibre
    run_command(build, law, "loadcases", "--model", law, "--case", "UTCAF", "--state", "both",
                "--stretch", "0.8:1.2:5", "--out", scratch, "--quiet")
    worst = 0.0
    for state in ("passive", "active"):
        rows = read_csv(os.path.join(scratch, f"{law}_{state}_UTCAF.csv"))
        assert len(rows) == 5, rows
        for r in rows:
            l, exact, fe = float(r["stretch"]), float(r["P_exact"]), float(r["P_fe"])
            expected = incompressible_mooney_rivlin(l, 10.0, 5.0)
            if law == "active_fibre" and state == "active":
                expected += 20.0  # sigma_a at the tetanic level (time factor 1)
            worst = max(worst, abs(exact - expected) / max(1.0, abs(expected)))
            assert math.isfinite(fe), r
    record(f"loadcases --model {law} UTCAF: |P_exact - closed form| = {worst:.1e}")
    assert worst < 1e-7, f"{law}: P_exact off its closed form by {worst:.1e}"


@pytest.mark.parametrize("law", ["mooney_rivlin", "active_fibre"])
def test_users_law_fit(build, scratch, record, law):
    # fit --model LAW: its own noise-free data (passive cases and active UTCAF) fitted
    # back from a start 20 % off
    data = os.path.join(scratch, "data.csv")
    run_command(build, law, "fit", "--model", law, "--synthesize", data, "--state", "both")
    start = {"c1": 12.0, "c2": 4.0} | ({"sigma_a": 24.0} if law == "active_fibre" else {})
    sets = [a for k, v in start.items() for a in ("--set", f"{k}={v}")]
    out = os.path.join(scratch, "fit")
    run_command(build, law, "fit", "--model", law, "--data", data, *sets, "--out", out)
    result = read_json(os.path.join(out, "fit.json"))
    presets = {"c1": 10.0, "c2": 5.0, "sigma_a": 20.0}
    assert set(start) <= set(result["free"]), result["free"]
    worst = max(abs(result["parameters"][k] / presets[k] - 1) for k in start)
    record(f"fit --model {law}: worst relative error {worst:.1e} ({', '.join(result['free'])})")
    assert result["converged"], result["termination"]
    assert worst < 1e-6, f"{law}: fitted {result['parameters']}"


# F-bar hexahedra (fusiform's default) and tetrahedra; the other elements in the
# uniaxial scene above (an active Q2 fusiform takes minutes)
FUSIFORM = [("mooney_rivlin", []), ("active_fibre", []), ("active_fibre", ["--cell", "tet"])]


@pytest.mark.parametrize("case", FUSIFORM, ids=[" ".join([c[0]] + c[1]) for c in FUSIFORM])
def test_users_law_fusiform(build, scratch, record, case):
    # fusiform --model LAW: the isometric contraction's first two steps; the mid-section force
    # equals the origin's reaction; the passive law carries nothing, the active one pulls
    law, element = case
    run_command(build, law, "fusiform", "--model", law, "--case", "isometric", *element,
                "--t-end", "0.02", "--out", scratch, "--quiet", "--no-fields")
    summary = read_json(os.path.join(scratch, "summary.json"))
    final = summary["final"]
    assert summary["model"] == law, summary["model"]
    force, origin = final["F33"], final["F33_origin"]
    record(f"fusiform --model {law} {' '.join(element)}: F33 = {force:.6g} at t = 0.02 s")
    if law == "mooney_rivlin":
        assert abs(force) < 1e-6 and final["activation"] == 0, final
    else:
        assert final["activation"] > 0 and abs(force) > 100, final
        assert abs(force - origin) <= 1e-6 * abs(force), final
