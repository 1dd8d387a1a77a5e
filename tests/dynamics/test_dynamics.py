"""Structural dynamics (generalized-alpha) against independent references.

    P -k test_period        the cantilever's period within 3 % of Euler-Bernoulli,
                            also after --set of E, rho and the dimensions
    P -k test_modes         ... and within 0.5 % of SLEPc's first eigenfrequency of
                            the same mesh
    P -k test_order         second order in the time step at rho_inf = 1 and 0.5
    P -k test_energy        rho_inf = 1: kinetic + strain energy kept over 10 periods
    P -k test_damping       rho_inf < 1: a mode far above the step's resolution decays
                            by the spectral radius rho_inf per step
    P -k test_slow_load     a slowly applied load gives the quasi-static answer
    P -k test_initial_velocity  a free body given a velocity flies on: u = v0 t exactly,
                            kinetic energy 1/2 m |v0|^2
    P -k test_resume        a run killed midway resumes to the very same series
    P -k test_parity        1 and 2 MPI ranks agree
    P -k test_bad_input     density, rho_inf, method: one-line errors, exit 2; the step
                            warning
    P -k test_shoulder      the rotator-cuff shoulder crosses its joint gap in time, on 1
                            and 2 ranks alike

(P: pytest tests/dynamics/test_dynamics.py --build BUILD.)  The cantilever is
demos/scenes/beam_vibration.yaml: gravity switched on at t = 0 sets it swinging
about its static deflection.  The period is the one of the sinusoid that fits
the tip's motion best (least squares over a scan of frequencies): a fit over
several periods is not thrown off by the higher modes riding on the first.
"""
import math
import os
import subprocess
import sys

import numpy as np
import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(ROOT, "tests", "support"))
from checks import kill_after, muscle_run, read_json, series_rows  # noqa: E402

BEAM = os.path.join(ROOT, "demos", "scenes", "beam_vibration.yaml")
# the scene's defaults
BEAM_DEFAULTS = {"E": 1.0e5, "rho": 1.0e-6, "length": 100.0, "width": 5.0, "height": 5.0}


def euler_bernoulli_period(E, rho, length, width, height):
    """First bending period of a cantilever: omega = 1.8751^2 sqrt(E I / (rho A L^4))."""
    inertia, area = width * height ** 3 / 12, width * height
    return 2 * math.pi / (1.8751 ** 2 * math.sqrt(E * inertia / (rho * area * length ** 4)))


def fitted_period(t, y, guess):
    """The period of the sinusoid a + b cos(w t) + c sin(w t) closest to y (least squares),
    scanning w within 20 % of 2 pi / guess, then refining the best by golden section."""
    t, y = np.asarray(t), np.asarray(y)

    def misfit(w):
        A = np.column_stack([np.ones_like(t), np.cos(w * t), np.sin(w * t)])
        coef = np.linalg.lstsq(A, y, rcond=None)[0]
        return float(np.sum((A @ coef - y) ** 2))

    w0 = 2 * math.pi / guess
    ws = np.linspace(0.8 * w0, 1.2 * w0, 401)
    k = int(np.argmin([misfit(w) for w in ws]))
    lo, hi = ws[max(k - 1, 0)], ws[min(k + 1, len(ws) - 1)]
    g = (math.sqrt(5) - 1) / 2
    for _ in range(80):
        a, b = hi - g * (hi - lo), lo + g * (hi - lo)
        if misfit(a) < misfit(b):
            hi = b
        else:
            lo = a
    return 2 * math.pi / (0.5 * (lo + hi))


def beam_sets(E=None, rho=None, length=None, width=None, height=None):
    sets = []
    for key, value in (("parts[0].material.parameters.E", E), ("parts[0].density", rho),
                       ("mesh.set.length", length), ("mesh.set.width", width),
                       ("mesh.set.height", height)):
        if value is not None:
            sets.append(f"{key}={value}")
    return sets


def run_ok(build, scene, out, sets=(), ranks=1):
    r = muscle_run(build, scene, out, sets, ranks)
    assert r.returncode == 0, f"muscle-run {' '.join(sets)}: exit {r.returncode}\n{r.stderr[-2000:]}"
    return series_rows(out)


# ---------------------------------------------------------------------------
# the period of the cantilever
# ---------------------------------------------------------------------------
PERIOD_CASES = {
    "default": {},
    # stiffer and lighter, longer and flatter: the period moves by 1.5x
    "changed": {"E": 2.0e5, "rho": 1.5e-6, "length": 130, "width": 6, "height": 4},
}


@pytest.mark.parametrize("case", sorted(PERIOD_CASES))
def test_period(build, scratch, record, case):
    change = PERIOD_CASES[case]
    p = dict(BEAM_DEFAULTS, **change)
    T = euler_bernoulli_period(p["E"], p["rho"], p["length"], p["width"], p["height"])
    # 100 steps a period, two periods
    sets = beam_sets(**change) + [f"time.step={T / 100:.6g}", f"time.end={2 * T:.6g}"]
    rows = run_ok(build, BEAM, scratch, sets)
    measured = fitted_period([r["t"] for r in rows], [r["tip_z"] for r in rows], T)
    error = measured / T - 1
    record(f"cantilever {case}: period {measured:.6g} s, Euler-Bernoulli {T:.6g} s "
           f"({100 * error:+.2f} %)")
    assert abs(error) < 0.03


def test_modes(build, scratch, record):
    T = euler_bernoulli_period(**{k: BEAM_DEFAULTS[k] for k in ("E", "rho", "length", "width",
                                                               "height")})
    modes_out = os.path.join(scratch, "modes")
    r = subprocess.run([os.path.join(build, "muscle-run"), BEAM, "--out", modes_out, "--modes",
                        "2"], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-2000:]
    modes = read_json(os.path.join(modes_out, "modes.json"))["modes"]
    T_slepc = modes[0]["period_s"]
    rows = run_ok(build, BEAM, os.path.join(scratch, "run"),
                  [f"time.step={T / 100:.6g}", f"time.end={2 * T:.6g}"])
    measured = fitted_period([r["t"] for r in rows], [r["tip_z"] for r in rows], T)
    error = measured / T_slepc - 1
    record(f"cantilever: period {measured:.6g} s, SLEPc's first mode {T_slepc:.6g} s "
           f"({100 * error:+.3f} %); Euler-Bernoulli {T:.6g} s")
    assert abs(error) < 0.005
    # the two bending modes (y and z) of the square section
    assert abs(modes[1]["period_s"] / T_slepc - 1) < 1e-6


# ---------------------------------------------------------------------------
# order, energy, damping, a slow load
# ---------------------------------------------------------------------------
# a coarse beam (quadratic hexahedra of 10 mm): the time error, not the space error
COARSE = ["mesh.set.size=10", "mesh.set.width=10", "mesh.set.height=10"]


def smooth_load_sets(T):
    # gravity rising smoothly over half a period: no jump excites the high modes
    return [f"loads[0].value={{expression: 'sin(pi * min(t, {T / 2:.6g}) / {T:.6g})^2'}}"]


@pytest.mark.parametrize("rho_inf", [1.0, 0.5])
def test_order(build, scratch, record, rho_inf):
    T = euler_bernoulli_period(1e5, 1e-6, 100, 10, 10)
    base = COARSE + smooth_load_sets(T) + [f"dynamics.rho_inf={rho_inf}", f"time.end={T:.6g}"]
    tips = {}
    for n in (20, 40, 80, 640):
        out = os.path.join(scratch, str(n))
        rows = run_ok(build, BEAM, out, base + [f"time.step={T / n:.6g}"])
        tips[n] = rows[-1]["tip_z"]
    e1, e2, e3 = (abs(tips[n] - tips[640]) for n in (20, 40, 80))
    order = math.log2(e2 / e3)
    record(f"generalized-alpha rho_inf = {rho_inf}: tip errors {e1:.3e}, {e2:.3e}, {e3:.3e} at "
           f"T/20, T/40, T/80 (against T/640): order {math.log2(e1 / e2):.2f}, {order:.2f}")
    assert order >= 1.9


def test_energy(build, scratch, record):
    """rho_inf = 1, a pulse of gravity for a quarter period, then 10 periods of free vibration:
    kinetic + strain energy stays within 0.5 %."""
    T = euler_bernoulli_period(1e5, 1e-6, 100, 10, 10)
    # large: the tip swings by about 10 % of the length (geometrically nonlinear)
    pulse = (f"loads[0].value={{table: [[0, 40], [{T / 4:.6g}, 40], [{T / 4 + T / 50:.6g}, 0], "
             f"[1, 0]]}}")
    rows = run_ok(build, BEAM, scratch, COARSE + [pulse, f"time.step={T / 50:.6g}",
                                                    f"time.end={T / 4 + T / 50 + 10 * T:.6g}"])
    free = [r for r in rows if r["t"] >= T / 4 + T / 50 - 1e-12]
    energy = [r["kinetic_energy"] + r["strain_energy"] for r in free]
    drift = (max(energy) - min(energy)) / energy[0]
    swing = max(abs(r["tip_z"]) for r in free)
    record(f"free vibration, rho_inf = 1: total energy {energy[0]:.4g} µJ varies by "
           f"{100 * drift:.3f} % over 10 periods (tip swing {swing:.3g} mm)")
    assert swing > 5
    assert drift < 0.005


def spectral_radius(y):
    """The largest root of the three-term linear recurrence y[n+3] = a y[n+2] + b y[n+1] +
    c y[n] fitted to the sequence y: the spectral radius of a one-step method with three
    state variables (u, v, a) that produced it."""
    y = np.asarray(y)
    A = np.column_stack([y[2:-1], y[1:-2], y[:-3]])
    a, b, c = np.linalg.lstsq(A, y[3:], rcond=None)[0]
    return max(abs(np.roots([1, -a, -b, -c])))


@pytest.mark.parametrize("rho_inf", [0.0, 0.5, 0.8])
def test_damping(build, scratch, record, rho_inf):
    """Gravity switched off after the start, with a step of 1000 periods of the first mode:
    every mode lies far above what the step resolves (omega h >= 6000), where the method's
    amplification has the spectral radius rho_inf (to 0.5 %).  The tip's sequence of
    displacements is fitted by the recurrence of such a method."""
    T = euler_bernoulli_period(1e5, 1e-6, 100, 10, 10)
    release = "loads[0].value={table: [[0, 1], [1.0e-9, 0], [1.0e6, 0]]}"
    rows = run_ok(build, BEAM, scratch, COARSE + [release, f"dynamics.rho_inf={rho_inf}",
                                                    f"time.step={1000 * T:.6g}",
                                                    f"time.end={10 * 1000 * T:.6g}"])
    # from the second step on: the load is gone at the first, which moves the tip
    # little (at rho_inf = 0 not at all)
    tips = [r["tip_z"] for r in rows[1:]]
    if rho_inf == 0:
        record(f"rho_inf = 0: tip after 2, 3 steps {tips[0]:.2e}, {tips[1]:.2e} mm")
        # a disturbance is gone one step later (to the 0.3 % of omega h = 6000)
        assert abs(tips[1]) < 1e-3 * abs(tips[0])
        return
    measured = spectral_radius(tips[:8])
    record(f"rho_inf = {rho_inf}: spectral radius of the computed sequence {measured:.4f}")
    assert abs(measured - rho_inf) < 0.01


def test_slow_load(build, scratch, record):
    """Gravity ramped over 20 periods: the tip ends at the quasi-static deflection."""
    T = euler_bernoulli_period(1e5, 1e-6, 100, 5, 5)
    ramp = f"loads[0].value={{ramp: {{start: 0, duration: {20 * T:.6g}, value: 1}}}}"
    end = f"time.end={20 * T:.6g}"
    dynamic = run_ok(build, BEAM, os.path.join(scratch, "dynamic"),
                     [ramp, end, f"time.step={T / 20:.6g}", "dynamics.rho_inf=0.5"])
    static_scene = os.path.join(scratch, "static.yaml")
    with open(BEAM) as f:
        text = f.read()
    with open(static_scene, "w") as f:
        f.write(text.replace("dynamics: {method: generalized_alpha, rho_inf: 1}\n", "")
                .replace("../../meshes/beam.geo", os.path.join(ROOT, "meshes", "beam.geo"))
                .replace("    - {name: kinetic_energy, quantity: kinetic_energy}\n", ""))
    static = run_ok(build, static_scene, os.path.join(scratch, "static"),
                    [ramp, end, f"time.step={20 * T:.6g}"])
    a, b = dynamic[-1]["tip_z"], static[-1]["tip_z"]
    record(f"slow load: tip {a:.6g} mm dynamic, {b:.6g} mm quasi-static ({100 * (a / b - 1):+.2f} %)")
    assert abs(a / b - 1) < 0.01


def test_initial_velocity(build, scratch, record):
    """A 10 mm cube with no boundary condition and a velocity: a rigid translation, which
    the method integrates exactly; its kinetic energy is 1/2 rho V |v0|^2."""
    scene = os.path.join(scratch, "free_cube.yaml")
    with open(scene, "w") as f:
        f.write(f"""title: free cube
mesh: {{file: {os.path.join(ROOT, "meshes", "box.geo")}}}
element: {{degree: 1, fbar: false}}
parts:
  - name: cube
    material: {{model: svk, parameters: {{E: 1.0e5, nu: 0.3}}}}
    fibres: {{direction: [0, 0, 1]}}
    density: 1.0e-6
boundary: []
dynamics: {{method: generalized_alpha, initial_velocity: [100, 0, -50]}}
time: {{end: 0.01, step: 0.001}}
output:
  series:
    - {{name: ux, quantity: displacement, surface: xmax, component: x}}
    - {{name: uz, quantity: displacement, surface: zmin, component: z}}
    - {{name: kinetic_energy, quantity: kinetic_energy}}
  fields: false
  plots: false
  surface: false
""")
    rows = run_ok(build, scene, os.path.join(scratch, "out"))
    energy = 0.5 * 1e-6 * 1000 * (100 ** 2 + 50 ** 2)
    worst_u = max(max(abs(r["ux"] - 100 * r["t"]), abs(r["uz"] + 50 * r["t"])) for r in rows)
    worst_e = max(abs(r["kinetic_energy"] / energy - 1) for r in rows)
    record(f"free cube with a velocity: displacement off by {worst_u:.1e} mm, kinetic energy "
           f"{rows[-1]['kinetic_energy']:.6g} µJ against {energy:.6g} ({worst_e:.1e})")
    assert len(rows) == 10 and worst_u < 1e-9 and worst_e < 1e-9


# ---------------------------------------------------------------------------
# resume, ranks
# ---------------------------------------------------------------------------
SHORT = COARSE + ["time.step=0.002", "time.end=0.06"]


def test_resume(build, scratch, record):
    # 200 steps: long enough to be killed early on a busy machine
    sets = COARSE + ["time.step=0.002", "time.end=0.4"]
    reference = os.path.join(scratch, "reference")
    run_ok(build, BEAM, reference, sets)
    killed = os.path.join(scratch, "killed")
    extra = [a for s in sets for a in ("--set", s)]
    state = kill_after(build, BEAM, killed, 10, extra=extra)
    assert state and state["step"] < 200, "the run ended before it could be killed"
    r = subprocess.run([os.path.join(build, "muscle-run"), BEAM, "--out", killed, "--resume",
                        "--quiet"] + extra, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-2000:]
    a, b = series_rows(reference), series_rows(killed)
    assert len(a) == len(b)
    worst = max(abs(x[k] - y[k]) for x, y in zip(a, b) for k in x
                if k not in ("wall_time", "residual"))
    record(f"dynamics: killed at step {state['step']}, resumed; largest difference {worst:.1e}")
    assert worst == 0


def test_parity(build, scratch, record):
    one = run_ok(build, BEAM, os.path.join(scratch, "one"), SHORT)
    two = run_ok(build, BEAM, os.path.join(scratch, "two"), SHORT, ranks=2)
    scale = max(abs(r["tip_z"]) for r in one)
    worst = max(abs(x["tip_z"] - y["tip_z"]) for x, y in zip(one, two)) / scale
    record(f"dynamics: 1 and 2 ranks differ by {worst:.1e} (relative to the tip's swing)")
    assert len(one) == len(two) and worst < 1e-8


# ---------------------------------------------------------------------------
# bad input
# ---------------------------------------------------------------------------
BAD = {
    "negative density": (["parts[0].density=-1e-6"], "parts[0].density"),
    "rho_inf above 1": (["dynamics.rho_inf=1.5"], "outside [0, 1]"),
    "rho_inf below 0": (["dynamics.rho_inf=-0.1"], "outside [0, 1]"),
    "unknown method": (["dynamics.method=newmark"], "generalized_alpha"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_input(build, scratch, case):
    sets, expected = BAD[case]
    r = muscle_run(build, BEAM, scratch, sets + ["time.end=0.001"])
    message = r.stderr.strip()
    assert r.returncode == 2, f"{case}: exit {r.returncode}, {message[-500:]}"
    assert expected in message and len(message.splitlines()) == 1, message


def test_bad_input_no_density(build, scratch):
    scene = os.path.join(scratch, "no_density.yaml")
    with open(BEAM) as f:
        text = f.read()
    with open(scene, "w") as f:
        f.write(text.replace("    density: 1.0e-6\n", "").replace("loads:", "unused:")
                .replace("  - {gravity: [0, 0, -9810], value: {constant: 1}}\n", "")
                .replace("unused:\n", "")
                .replace("../../meshes/beam.geo", os.path.join(ROOT, "meshes", "beam.geo")))
    r = muscle_run(build, scene, os.path.join(scratch, "out"), ["time.end=0.001"])
    message = r.stderr.strip()
    assert r.returncode == 2, message
    assert "needs the density of every part" in message and len(message.splitlines()) == 1


def test_bad_input_step_warning(build, scratch):
    """A ramp over 0.01 s taken in 0.005 s steps: warned, and the run goes on."""
    r = muscle_run(build, BEAM, scratch, COARSE + [
        "loads[0].value={ramp: {start: 0, duration: 0.01, value: 1}}", "time.step=0.005",
        "time.end=0.01"])
    assert r.returncode == 0, r.stderr[-1000:]
    assert "warning:" in r.stderr and "fewer than 10 steps" in r.stderr, r.stderr
    summary = read_json(os.path.join(scratch, "summary.json"))
    assert any("fewer than 10 steps" in w for w in summary["warnings"])


# ---------------------------------------------------------------------------
# the shoulder
# ---------------------------------------------------------------------------
SHOULDER = os.path.join(ROOT, "demos", "scenes", "shoulder.yaml")


def test_shoulder(build, scratch, record):
    """The rotator-cuff shoulder, coarse, to just past the first glenohumeral contact, on 1
    and 2 ranks.  The head must cross the 1 mm joint gap: a rigid humerus (m = 0.08 kg)
    pulled by a force growing like tanh(34.4 t) towards some 3 N crosses it at
    (6 m d / (34.4 F))^(1/3) = 0.017 s; the contact must come within 0.01..0.03 s, with a
    penetration far below the gap, and the ranks must agree."""
    sets = ["mesh.set.size=6", "time.end=0.025", "output.fields=false"]
    one = run_ok(build, SHOULDER, os.path.join(scratch, "one"), sets)
    two = run_ok(build, SHOULDER, os.path.join(scratch, "two"), sets, ranks=2)
    onset = next((r["t"] for r in one if r["contact_force"] > 0), None)
    peak = max(r["contact_force"] for r in one)
    record(f"shoulder (size 6): onset {onset} s, peak force {peak:.0f} mN, head x at the end "
           f"{one[-1]['head_x']:.3f} mm, deepest penetration "
           f"{max(r['max_penetration'] for r in one):.3f} mm")
    assert onset is not None and 0.01 <= onset <= 0.03
    assert min(r["head_x"] for r in one) < -0.9  # the gap (1 mm) closed
    assert max(r["max_penetration"] for r in one) < 0.1
    worst = max(abs(x[k] - y[k]) / max(abs(x[k]), 1.0) for x, y in zip(one, two)
                for k in ("contact_force", "head_x", "head_y", "head_z"))
    record(f"shoulder: 1 and 2 ranks differ by {worst:.1e}")
    assert len(one) == len(two) and worst < 1e-6
