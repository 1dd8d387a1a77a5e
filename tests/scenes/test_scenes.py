"""Scene-file tests of muscle-run, run by pytest.  ctest runs one group of test
functions per test, named test_<group>_... (P = python3 -m pytest -p no:cacheprovider
tests/scenes/test_scenes.py --build DIR):

    P -k test_demos         every demo scene: checked, run over a short horizon
    P -k test_broken        the table of broken scenes: message and exit status
    P -k test_resume        a run killed midway resumes to the uninterrupted result
    P -k test_parity        1 and 2 MPI ranks agree (and resume across them)
    P -k test_parts         several parts: a split body equals the whole, 1 = 2 ranks
    P -k test_anti_locking  BLE's anti-locking Q1 against Q1 and Q2 (block)
    P -k test_fbar          F-bar Q1 (COMBI, GIANT) against Q1 and Q2 (block)
    P -k test_overrides     --set KEY=VALUE against the edited file; point probes
    P -k test_extremes      penalty x3..x100, activation x2, one large step,
                            nearly degenerate elements: converge or stop cleanly
                            (F-bar, the default; the failure path on plain Q1)

One test case per check (e.g. test_broken[model misspelt]); a run that several
checks need is made once per module.

References are independent of the code under test: the section force must equal
the support reaction (equilibrium), a free muscle shortens, every number is finite,
a resumed run equals an uninterrupted one, the error names what the table says.
"""
import collections
import csv
import functools
import math
import os
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCENES = os.path.join(ROOT, "demos", "scenes")
sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                                "support"))
from checks import all_finite, finite_json, kill_after, read_json  # noqa: E402


def run(build, args, ranks=1, timeout=None):
    """muscle-run with `args`; a run that exceeds `timeout` seconds counts as exit None."""
    command = [os.path.join(build, "muscle-run")] + args
    if ranks > 1:
        command = ["mpirun", "--allow-run-as-root", "--oversubscribe", "-n", str(ranks)] + command
    try:
        return subprocess.run(command, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired as e:
        output = [o.decode(errors="replace") if isinstance(o, bytes) else (o or "")
                  for o in (e.stdout, e.stderr)]
        return subprocess.CompletedProcess(command, None, output[0],
                                           output[1] + f"\n(hung: killed after {timeout} s)")


def read_series(path):
    """The rows of a series.csv ([] if there is none)."""
    try:
        with open(path) as f:
            return list(csv.DictReader(f))
    except OSError:
        return []


def final(out):
    """The final values of a run's summary.json ({} if there is none)."""
    return (read_json(os.path.join(out, "summary.json")) or {}).get("final", {})


def write(path, text):
    with open(path, "w") as f:
        f.write(text)
    return path


def absolute_paths(text):
    return text.replace("../../", ROOT + "/").replace("file: data/", f"file: {SCENES}/data/")


def scene_text(name):
    """A demo scene with its relative paths made absolute (same lines), for copies elsewhere."""
    with open(os.path.join(SCENES, name + ".yaml")) as f:
        return absolute_paths(f.read())


def worst_difference(a, b, floor):
    """Largest relative difference of the final values b against a (relative to |a|, at least
    `floor`); inf if b lacks a value or a has none."""
    if not a or any(k not in b for k in a):
        return math.inf
    return max(abs(a[k] - b[k]) / max(abs(a[k]), floor) for k in a)


# ---------------------------------------------------------------------------
# demos: every demo scene over a short horizon [s]; the extra checks per scene
# ---------------------------------------------------------------------------
HORIZONS = {"block_muscle_tendon": 0.03, "fusiform_isometric": 0.02, "fusiform_free": 0.02,
            "fusiform_passive_stretch": 0.03, "block_graded": 0.03, "block_wave": 0.03,
            "block_cell_data": 0.005, "hertz": 0.5, "humerus_deltoid": 0.05,
            "beam_vibration": 0.004, "shoulder": 0.001, "stiff_soft": 0.01,
            "cantilever_pressure": 0.1}
DEMOS = sorted(HORIZONS)
Demo = collections.namedtuple("Demo", "code stderr summary rows out")


def test_demos_every_scene_tested():
    names = sorted(f[:-5] for f in os.listdir(SCENES) if f.endswith(".yaml"))
    assert set(names) == set(HORIZONS), f"every demo scene is tested ({names}; tested {DEMOS})"


@pytest.fixture(scope="module")
def demo(build, module_scratch):
    """demo(name): the scene run over its horizon, once."""
    @functools.lru_cache(maxsize=None)
    def get(name):
        out = os.path.join(module_scratch, name)
        r = run(build, [os.path.join(SCENES, name + ".yaml"), "--out", out, "--quiet",
                        "--t-end", str(HORIZONS[name])])
        return Demo(r.returncode, r.stderr, read_json(os.path.join(out, "summary.json")),
                    read_series(os.path.join(out, "series.csv")), out)
    return get


def demo_summary(demo, name):
    """The summary of a demo run that succeeded (the checks below need one)."""
    d = demo(name)
    assert d.code == 0 and d.summary, f"{name} did not run (exit {d.code}) {d.stderr[-400:]}"
    return d.summary


@pytest.mark.parametrize("name", DEMOS)
def test_demos_runs(demo, name):
    d = demo(name)
    assert d.code == 0, f"{name}: runs (exit {d.code}) {d.stderr[-400:]}"


@pytest.mark.parametrize("name", DEMOS)
def test_demos_completes_with_series(demo, name):
    summary, rows = demo_summary(demo, name), demo(name).rows
    assert summary["completed"] and len(rows) == summary["steps"] > 0, (
        f"{name}: completed, {len(rows)} series rows ({summary['steps']} steps)")


@pytest.mark.parametrize("name", DEMOS)
def test_demos_series_finite(demo, name):
    demo_summary(demo, name)
    assert all_finite(demo(name).rows), f"{name}: every series value is finite"


@pytest.mark.parametrize("name", DEMOS)
def test_demos_checkpoint_written(demo, name):
    demo_summary(demo, name)
    assert os.path.exists(os.path.join(demo(name).out, "checkpoint.json")), (
        f"{name}: checkpoint written")


def equilibrium(name, s):
    f, r = s["final"]["F33"], s["final"]["F33_origin"]
    return (f > 0 and abs(f - r) <= 1e-6 * abs(f),
            f"{name}: section force {f:.6f} = origin reaction {r:.6f} (equilibrium)")


def shortens(name, s):
    return s["final"]["epsilon"] < 1, (f"{name}: the free muscle shortens "
                                       f"(epsilon {s['final']['epsilon']:.5f})")


def axial_constraint(name, s):
    return s["built"]["axial_constraint_unknown"], f"{name}: the axial constraint is built"


def passive_forms_only(name, s):
    built = s["built"]
    return (built["forms"] == "ehret_passive" and not built["activation_kernel"]
            and not built["activation_terms"] and not built["twitch_train"],
            f"{name}: passive forms only, no activation kernel or time function ({built})")


def pulls_on_origin(name, s):
    return s["final"]["F33_origin"] > 0, (f"{name}: stretching pulls on the origin "
                                          f"(F33_origin {s['final']['F33_origin']})")


def no_twitch_train_nor_kernel(name, s):
    built = s["built"]
    return (not built["twitch_train"] and not built["activation_kernel"],
            f"{name}: BLE/COMBI evaluate neither the twitch train nor a kernel ({built})")


def twitch_train_and_kernel(name, s):
    built = s["built"]
    return (built["twitch_train"] and built["activation_kernel"],
            f"{name}: WKM builds its twitch train and Lambert-W kernel ({built})")


def kernel_and_ramp(name, s):
    built = s["built"]
    return (built["activation_kernel"] and not built["twitch_train"],
            f"{name}: GIANT kernel, ramp instead of the twitch train ({built})")


def section_force_equals_reaction(name, s):
    b, m = s["final"]["F33_bottom"], s["final"]["F33_middle"]
    return abs(b - m) <= 1e-6 * max(abs(b), 1.0), f"{name}: section force {m:.6f} = reaction {b:.6f}"


def no_extra_unknown(name, s):
    built = s["built"]
    return (not built["axial_constraint_unknown"] and built["unknowns"] == 3 * s["nodes"],
            f"{name}: no extra unknown without the axial constraint ({built['unknowns']} unknowns, "
            f"{s['nodes']} nodes)")


DEMO_CHECKS = [("fusiform_isometric", equilibrium), ("fusiform_free", shortens),
               ("block_graded", shortens), ("block_cell_data", shortens),
               ("fusiform_free", axial_constraint), ("fusiform_passive_stretch", passive_forms_only),
               ("fusiform_passive_stretch", pulls_on_origin),
               ("fusiform_isometric", no_twitch_train_nor_kernel),
               ("block_graded", no_twitch_train_nor_kernel),
               ("block_cell_data", twitch_train_and_kernel), ("block_wave", kernel_and_ramp),
               ("block_wave", section_force_equals_reaction), ("fusiform_isometric", no_extra_unknown)]


@pytest.mark.parametrize("name, check", [pytest.param(n, c, id=f"{n}-{c.__name__}")
                                         for n, c in DEMO_CHECKS])
def test_demos_scene_property(demo, name, check):
    ok, message = check(name, demo_summary(demo, name))
    assert ok, message


@pytest.mark.parametrize("case, column", [("isometric", "F33"), ("free", "epsilon")],
                         ids=["fusiform_isometric", "fusiform_free"])
def test_demos_same_as_fusiform_binary(build, scratch, demo, case, column):
    """The fusiform binary's defaults are the fusiform scenes: same numbers."""
    name = "fusiform_" + case
    value = demo_summary(demo, name)["final"][column]
    out = os.path.join(scratch, "demo_" + case)
    r = subprocess.run([os.path.join(build, "fusiform"), "--model", "combi", "--case", case,
                        "--t-end", str(HORIZONS[name]), "--no-fields", "--quiet", "--out", out],
                       capture_output=True, text=True)
    reference = (read_json(os.path.join(out, "summary.json")) or {}).get("final", {}) \
        .get(column, math.nan) if r.returncode == 0 else math.nan
    assert abs(value - reference) <= 1e-9 * abs(reference), (
        f"{name}: {column} {value:.10g} equals the fusiform demo's {reference:.10g} "
        f"(fusiform exit {r.returncode})")


@pytest.fixture(scope="module")
def sheared_block(build, module_scratch):
    """A sheared block (the top pulled along x, held along z): its final values."""
    text = scene_text("block_graded")
    text = text.replace("{displacement: top, component: x, value: 0}",
                        "{displacement: top, component: x, value: {ramp: {duration: 0.02, value: 1}}}")
    text = text.replace("  - {uniform_axial: top, component: z}\n", "  - {displacement: top, component: z, value: 0}\n")
    text = text.replace("    - {name: min_J, quantity: min_J}\n",
                        "    - {name: Fx_bottom, quantity: reaction, surface: bottom, component: x}\n"
                        "    - {name: Fx_middle, quantity: section_force, surface: middle, component: x}\n"
                        "    - {name: Fz_bottom, quantity: reaction, surface: bottom, component: z}\n"
                        "    - {name: Fz_middle, quantity: section_force, surface: middle, component: z}\n")
    path = write(os.path.join(module_scratch, "shear.yaml"), text)
    out = os.path.join(module_scratch, "shear")
    r = run(build, [path, "--out", out, "--quiet", "--t-end", "0.02"])
    return final(out) if r.returncode == 0 else {}


@pytest.mark.parametrize("c", ["x", "z"])
def test_demos_sheared_block_section_force(sheared_block, c):
    """Equilibrium of a sheared block: the force through the mid-plane equals the
    reaction at the bottom (the side of a cell is decided along the plane's normal,
    z, not along the force component)."""
    a, b = sheared_block.get(f"F{c}_bottom", math.nan), sheared_block.get(f"F{c}_middle", math.nan)
    assert abs(a) > 1 and abs(a - b) <= 1e-6 * abs(a), (
        f"sheared block: {c} section force {b:.6f} = {c} reaction {a:.6f} mN")


# ---------------------------------------------------------------------------
# broken scenes: (what, base scene, old text, new text, expected fragments, line check)
# The base is block_graded.yaml unless named; `line` asks the message to point
# at the line holding the replacement.
# ---------------------------------------------------------------------------
B, F, T = "block_graded", "fusiform_free", "block_muscle_tendon"
BROKEN = [
    ("anti-locking element for COMBI", F, "element: {degree: 1}",
     "element: {degree: 1, volumetric_quadrature_degree: 1}",
     ["element.volumetric_quadrature_degree", "volumetric_stiff_part", "combi"], True),
    ("a mesh that cannot fit in memory", F, "set: {refinement: 1}", "set: {refinement: 1000}",
     ["mesh", "cells", "GiB", "lower the refinement"], True),
    ("model misspelt", B, "model: ble", "model: bel", ["material.model", "'bel'", "did you mean 'ble'"], True),
    ("unknown top-level key", B, "time: {end", "tme: {end", ["unknown key 'tme'", "did you mean 'time'"], True),
    ("unknown parameter", B, "model: ble}", "model: ble, parameters: {kapa: 3}}",
     ["unknown key 'kapa'", "did you mean 'kappa'"], True),
    ("kappa not positive", B, "model: ble}", "model: ble, parameters: {kappa: -1}}", ["kappa", "-1"], True),
    ("omega_0 above 1", F, "model: combi}", "model: combi, parameters: {omega_0: 1.5}}", ["omega_0", "1.5"], True),
    ("lambda_min above lambda_opt", F, "model: combi}",
     "model: combi, parameters: {lambda_min: 1.2, lambda_opt: 1.1}}", ["lambda_min", "lambda_opt"], True),
    ("tanh frequency zero", B, "model: ble}", "model: ble, parameters: {c: 0}}", ["parameter c = 0", "must be > 0"], True),
    ("negative time step", B, "step: 0.01", "step: -0.01", ["time.step", "must be > 0"], True),
    ("time step not a number", B, "step: 0.01", "step: abc", ["time.step", "'abc' is not a number"], True),
    ("time end missing", B, "end: 0.1, ", "", ["time", "missing key 'end'"], True),
    ("step longer than the run", B, "step: 0.01", "step: 1", ["time.step", "longer than the simulated time"], True),
    ("mesh file missing", B, "block.geo", "blok.geo", ["mesh.file", "not found"], True),
    ("mesh not a Gmsh file", B, "../../meshes/block.geo", "../../demos/scenes/block_graded.yaml", ["mesh.file", ".geo or .msh"], True),
    ("unknown surface", B, "clamp: bottom", "clamp: bottm", ["boundary[0]", "no physical surface 'bottm'",
                                                            "did you mean 'bottom'"], True),
    ("unknown volume group", B, "lower: 1.0", "lowr: 1.0", ["no volume group 'lowr'", "did you mean 'lower'"], False),
    ("component not x, y, z", B, "top, component: x", "top, component: w", ["component", "'w'", "allowed: x, y, z"], True),
    ("two kinds in one condition", B, "- clamp: bottom", "- {clamp: bottom, uniform_axial: bottom}",
     ["boundary[0]", "only one of"], True),
    ("two axial constraints", B, "- clamp: bottom", "- {uniform_axial: bottom, component: z}",
     ["only one uniform_axial"], False),
    # T^T J T would sum the prescribed rows into the tied value's equation
    ("tied component also prescribed", B, "top, component: x, value: 0", "top, component: z, value: 0",
     ["boundary[3]: uniform_axial: top ties 49 displacement components", "boundary[1] (displacement: top)",
      "cannot also be prescribed"], True),
    ("degree 3", B, "{degree: 2}", "{degree: 3}", ["element.degree", "integer from 1 to 2"], True),
    ("zero fibre direction", B, "[0, 0, 1]", "[0, 0, 0]", ["fibres.direction", "must not be zero"], True),
    ("fibre direction of two numbers", B, "[0, 0, 1]", "[0, 1]", ["fibres.direction", "expected [a1, a2, a3]"], True),
    ("activation on a passive part", B, "model: ble}", "model: ble, active: false}",
     ["activation", "passive part"], False),
    ("not YAML", B, "{degree: 2}", "{degree: 2", ["not valid YAML"], False),
    ("negative group scale", B, "upper: 0.5", "upper: -0.5", ["upper", "must be >= 0"], True),
    ("expression syntax", B, "scale: {groups: {lower: 1.0, upper: 0.5}}", "scale: {expression: \"exp(-z\"}",
     ["activation.scale.expression", "expected ')'"], True),
    ("expression unknown variable", B, "scale: {groups: {lower: 1.0, upper: 0.5}}",
     "scale: {expression: \"exp(-w)\"}", ["unknown name 'w'", "variables: x, y, z, t"], True),
    ("time table not increasing", B, "time: model", "time: {table: [[0, 0], [0.05, 1], [0.02, 1]]}",
     ["activation.time.table[2][0]", "times must increase"], True),
    ("unknown linear solver", B, "time: {end", "solver: {linear: cholesky}\ntime: {end",
     ["solver.linear", "'cholesky'", "allowed: lu, gmres-hypre, gmres-gamg, gmres-schur, gmres-stars"], True),
    ("unknown series quantity", B, "quantity: min_J", "quantity: minJ", ["quantity", "did you mean 'min_J'"], True),
    ("reaction on a free surface", B, "quantity: min_J}", "quantity: reaction, surface: sides, component: z}",
     ["'sides' carries no boundary condition"], True),
    ("two columns of one name", B, "name: min_J", "name: epsilon", ["two columns named 'epsilon'"], True),
    ("PETSc options without dash", B, "time: {end", "solver: {petsc: snes_monitor}\ntime: {end",
     ["solver.petsc", "start with '-'"], True),
    ("unknown line search", B, "time: {end", "solver: {line_search: wolfe}\ntime: {end",
     ["solver.line_search", "'wolfe'"], True),
    ("flag not true/false", B, "series:", "fields: maybe\n  series:", ["output.fields", "'maybe'", "true, false"], True),
    ("parameter file missing", B, "model: ble}", "model: ble, parameter_file: fitted.txt}",
     ["parameter_file", "not found"], True),
    ("quadrature degree not compiled", B, "{degree: 2}", "{degree: 2, quadrature_degree: 3}",
     ["element", "no compiled kernels"], False),
    ("a second part without volumes", B, "boundary:", "  - {name: two, material: {model: ble}}\nboundary:",
     ["parts[0]", "each names its volume groups"], False),
    ("two parts of one name", T, "name: tendon", "name: muscle", ["parts[1].name", "two parts named 'muscle'"], True),
    ("a volume in two parts", T, "volumes: [upper]", "volumes: [upper, lower]",
     ["parts[1].volumes", "'lower' already belongs to part 'muscle'"], False),
    ("empty volume list", T, "volumes: [upper]", "volumes: []", ["parts[1].volumes", "non-empty list"], True),
    ("cells in no part", B, "  - name: muscle\n", "  - name: muscle\n    volumes: lower\n",
     ["parts:", "cells belong to no part", "volume groups in no part: upper"], False),
    ("unknown volume of a part", T, "volumes: [upper]", "volumes: [uper]",
     ["parts[1].volumes", "no volume group 'uper'", "did you mean 'upper'"], False),
    ("activation negative later on", B, "time: model", "time: {table: [[0, 0], [0.05, 1], [0.08, -1]]}",
     ["parts[0]", "activation.time is -", "t = 0.07"], False),
    ("scale formula negative later on", B, "scale: {groups: {lower: 1.0, upper: 0.5}}",
     "scale: {expression: \"1 - 20*t\"}", ["activation.scale.expression", "must be finite and >= 0",
                                            "t = 0.06"], True),
    ("displacement formula not finite", B, "{displacement: top, component: x, value: 0}",
     "{displacement: top, component: x, value: {expression: \"sqrt(0.05 - t)\"}}",
     ["boundary[1]", "prescribed displacement is", "nan", "t = 0.06"], True),
    ("displacement NaN at an end time off the step grid", B,
     ("{displacement: top, component: x, value: 0}", "time: {end: 0.1, step: 0.01}"),
     ("{displacement: top, component: x, value: {expression: \"sqrt(0.095 - t)\"}}",
      "time: {end: 0.1, step: 0.03}"), ["boundary[1]", "prescribed displacement is", "t = 0.1"], True),
    ("negative scale outside the groups", B, "upper: 0.5}}", "upper: 0.5}, other: -1}",
     ["activation.scale.other", "must be >= 0"], True),
    ("section force through a surface that is not a plane", B,
     "{name: u3_middle, quantity: displacement, surface: middle, component: z}",
     "{name: u3_middle, quantity: section_force, surface: sides, component: z}",
     ["output.series[2]", "needs a plane surface", "'sides'"], True),
    ("scene is a list", B, "title:", "- title:", ["a scene is a mapping"], False),
]


def test_broken_table_size():
    assert len(BROKEN) >= 25, f"{len(BROKEN)} broken scenes (at least 25)"


@pytest.mark.parametrize("what, base, old, new, fragments, line_check",
                         [pytest.param(*case, id=case[0]) for case in BROKEN])
def test_broken(build, scratch, what, base, old, new, fragments, line_check):
    with open(os.path.join(SCENES, base + ".yaml")) as f:
        text = f.read()
    olds, news = (old, new) if isinstance(old, tuple) else ((old,), (new,))
    assert all(o in text for o in olds), f"{what}: test table out of date ('{olds}' not in {base}.yaml)"
    line = text[:text.index(olds[0])].count("\n") + 1
    mutated = text
    for o, n in zip(olds, news):
        mutated = mutated.replace(o, n, 1)
    # relative paths made absolute (same length in lines) for the copy in tmp
    path = write(os.path.join(scratch, base + ".yaml"), absolute_paths(mutated))
    r = run(build, [path, "--out", os.path.join(scratch, "out"), "--quiet", "--check"], timeout=120)
    message = (r.stdout + r.stderr).strip()
    ok = r.returncode == 2 and all(fr in message for fr in fragments)
    ok = ok and message.count("\n") == 0 and "PETSC ERROR" not in message and "terminate" not in message
    ok = ok and path in message
    if line_check:
        ok = ok and f"{path}:{line}:" in message
    assert ok, f"{what}: exit {r.returncode}, message: {message[:300]}"


# ---------------------------------------------------------------------------
# resume after kill
# ---------------------------------------------------------------------------
def compare(reference, resumed, what):
    """Two checks, (ok, message) each: the resumed final values and series.csv equal
    the uninterrupted run's."""
    a = read_json(os.path.join(reference, "summary.json")) or {}
    b = read_json(os.path.join(resumed, "summary.json")) or {}
    worst = worst_difference(a.get("final"), b.get("final", {}), 1e-12)
    result = (bool(b.get("completed") and b.get("resumed") and worst <= 1e-8),
              f"{what}: resumed result equals the uninterrupted one (worst relative difference "
              f"{worst:.1e})")
    ra, rb = read_series(os.path.join(reference, "series.csv")), read_series(os.path.join(resumed, "series.csv"))
    same = len(ra) == len(rb) and all(
        abs(float(x[k]) - float(y[k])) <= 1e-8 * max(abs(float(x[k])), 1e-9)
        for x, y in zip(ra, rb) for k in x if k not in ("wall_time", "residual"))
    series = (same, f"{what}: the resumed series.csv has every step once and equals the "
                    f"uninterrupted one ({len(ra)} vs {len(rb)} rows)")
    return result, series


@pytest.fixture(scope="module")
def resumed(build, module_scratch):
    """The resume scenario, each step on the output of the one before; what each step gave."""
    o = {}
    scene = os.path.join(SCENES, "block_graded.yaml")
    extra = ["--t-end", "0.1"]
    tmp = module_scratch
    ref, killed = os.path.join(tmp, "ref"), os.path.join(tmp, "killed")
    o["uninterrupted"] = run(build, [scene, "--out", ref, "--quiet"] + extra)
    o["state"] = kill_after(build, scene, killed, 4, extra=extra)
    o["summary_after_kill"] = os.path.exists(os.path.join(killed, "summary.json"))
    # what a kill between the checkpoint JSON's rename and the old binary's removal leaves
    write(os.path.join(killed, "checkpoint_0.bin"), "left by a kill")
    o["resume"] = run(build, [scene, "--out", killed, "--resume", "--quiet"] + extra)
    if o["resume"].returncode == 0:
        o["compare"] = compare(ref, killed, "kill + resume")
    # a changed scene refuses to resume
    changed = os.path.join(tmp, "changed.yaml")
    text = scene_text("block_graded")
    write(changed, text.replace("upper: 0.5", "upper: 0.6"))
    o["changed_physics"] = run(build, [changed, "--out", killed, "--resume", "--quiet"])
    # solver and time settings may change (e.g. a smaller step after a failure)
    write(changed, text.replace("time: {end: 0.1, step: 0.01}", "time: {end: 0.15, step: 0.005}")
          .replace("output:", "solver: {line_search: bt}\noutput:"))
    o["extend"] = run(build, [changed, "--out", killed, "--resume", "--quiet"])
    o["extended_rows"] = read_series(os.path.join(killed, "series.csv")) \
        if o["extend"].returncode == 0 else []
    o["bins"] = [f for f in os.listdir(killed) if f.startswith("checkpoint_") and f.endswith(".bin")]
    # nothing left to do: the summary reports the state at the checkpoint, not zeros
    o["before"] = final(killed)
    o["again"] = run(build, [changed, "--out", killed, "--resume", "--quiet"])
    o["after"] = final(killed) if o["again"].returncode == 0 else {}
    write(changed, text.replace("    - {name: min_J, quantity: min_J}\n", ""))
    o["changed_series"] = run(build, [changed, "--out", killed, "--resume", "--quiet"])
    o["no_checkpoint"] = run(build, [scene, "--out", os.path.join(tmp, "empty"), "--resume", "--quiet"])
    return o


def test_resume_uninterrupted_run(resumed):
    r = resumed["uninterrupted"]
    assert r.returncode == 0, f"uninterrupted run (exit {r.returncode}) {r.stderr[-300:]}"


def test_resume_killed_midway(resumed):
    state = resumed["state"]
    assert state is not None and 4 <= state["step"] < 10, (
        f"killed midway (last checkpoint at step {state and state['step']})")


def test_resume_killed_run_wrote_no_summary(resumed):
    assert not resumed["summary_after_kill"], "the killed run wrote no summary"


def test_resume_finishes(resumed):
    r = resumed["resume"]
    assert r.returncode == 0, f"resumed run finishes (exit {r.returncode}) {r.stderr[-300:]}"


@pytest.mark.parametrize("i", [0, 1], ids=["final values", "series"])
def test_resume_equals_uninterrupted(resumed, i):
    assert "compare" in resumed, f"the resumed run failed (exit {resumed['resume'].returncode})"
    ok, message = resumed["compare"][i]
    assert ok, message


def test_resume_changed_physics_refused(resumed):
    r = resumed["changed_physics"]
    assert r.returncode == 2 and "changed since the checkpoint" in r.stderr + r.stdout, (
        f"resuming with changed physics is refused (exit {r.returncode}) {r.stderr[-300:]}")


def test_resume_new_step_and_line_search_extend(resumed):
    r, rows = resumed["extend"], resumed["extended_rows"]
    assert r.returncode == 0 and len(rows) == 10 + 10, (
        f"resuming with a new time step and line search extends the finished run from its "
        f"checkpoint ({len(rows)} rows: 10 steps to 0.1 s, 10 to 0.15 s; exit {r.returncode}) "
        f"{r.stdout[-500:]} {r.stderr[-500:]}")


def test_resume_one_checkpoint_binary_kept(resumed):
    assert len(resumed["bins"]) == 1, f"one checkpoint binary is kept ({resumed['bins']})"


def test_resume_finished_run_changes_nothing(resumed):
    before, after, r = resumed["before"], resumed["after"], resumed["again"]
    assert r.returncode == 0 and before and all(
        k in after and abs(after[k] - before[k]) <= 1e-12 * max(abs(before[k]), 1) for k in before), (
        f"resuming a finished run changes nothing (exit {r.returncode}; before {before}; after {after})")


def test_resume_changed_series_refused(resumed):
    r = resumed["changed_series"]
    assert r.returncode == 2 and "output.series changed" in r.stderr + r.stdout, (
        f"resuming with other series columns is refused (exit {r.returncode}) {r.stderr[-300:]}")


def test_resume_without_checkpoint_refused(resumed):
    r = resumed["no_checkpoint"]
    assert r.returncode == 2 and "no checkpoint" in r.stderr + r.stdout, (
        f"resuming without checkpoint is refused (exit {r.returncode}) {r.stderr[-300:]}")


# ---------------------------------------------------------------------------
# FE extremes (issue "numerical stability"): each converges, possibly after
# cutbacks, or stops cleanly (exit 3, completed false, failure counts, the last
# converged state written); no NaN ever reaches an output file.
# ---------------------------------------------------------------------------
# A stiffer penalty than the presets (BLE kappa 1e4 kPa, the Ehret models 1000):
# x100 for BLE, x10 for WKM and COMBI, x3 for GIANT.
STIFF_PENALTY = {"ble": 1e6, "wkm": 1e4, "giant": 3e3, "combi": 1e4}
EXTREMES = [(m, k) for m in ["ble", "wkm", "giant", "combi"]
            for k in ["stiff_penalty", "activation_x2", "one_large_step", "degenerate_elements"]] + \
    [("combi", "fusiform_stiff_penalty"), ("combi", "fusiform_stiff_penalty_q1")]


def extreme_scene(model, kind):
    mesh = f"file: {ROOT}/meshes/block.geo"
    parameters, scale, end, step = "{}", 1, 0.02, 0.005
    if kind == "stiff_penalty":
        parameters = "{kappa: %g}" % STIFF_PENALTY[model]
    elif kind == "activation_x2":
        scale = 2
    elif kind == "one_large_step":
        end, step = 0.05, 0.05
    elif kind == "degenerate_elements":
        mesh = f"file: {ROOT}/meshes/fusiform.geo\n  set: {{refinement: 1, core: 0.95}}"
        end, step = 0.01, 0.01
    elif kind.startswith("fusiform_stiff_penalty"):
        mesh = f"file: {ROOT}/meshes/fusiform.geo\n  set: {{refinement: 1}}"
        parameters = "{kappa: %g}" % STIFF_PENALTY[model]
        end, step = 0.01, 0.01
    # plain Q1 fails the stiff fusiform (docs/stability.md): the failure path;
    # everything else runs on the default element (F-bar on these hexahedra)
    element = "{degree: 1, fbar: false}" if kind.endswith("_q1") else "{degree: 1}"
    return f"""title: {model} {kind}
mesh:
  {mesh}
element: {element}
parts:
  - material: {{model: {model}, parameters: {parameters}}}
    fibres: {{direction: [0, 0, 1]}}
    activation: {{time: model, scale: {scale}}}
boundary:
  - clamp: {"bottom" if "block" in mesh else "origin"}
  - clamp: {"top" if "block" in mesh else "insertion"}
time: {{end: {end}, step: {step}, max_cutbacks: 4}}
output:
  series:
    - {{name: activation, quantity: activation}}
    - {{name: min_J, quantity: min_J}}
    - {{name: volume_change, quantity: volume_change}}
  fields: false
"""


@pytest.fixture(scope="module")
def extreme(build, module_scratch):
    """extreme(model, kind): the run's exit status, output and output directory, once."""
    @functools.lru_cache(maxsize=None)
    def get(model, kind):
        path = write(os.path.join(module_scratch, f"{model}_{kind}.yaml"), extreme_scene(model, kind))
        out = os.path.join(module_scratch, f"{model}_{kind}")
        r = run(build, [path, "--out", out, "--quiet"], timeout=900)
        return r.returncode, r.stdout + r.stderr, out
    return get


@pytest.mark.parametrize("model, kind", [pytest.param(*c, id="-".join(c)) for c in EXTREMES])
def test_extremes(extreme, record, model, kind):
    code, message, out = extreme(model, kind)
    what = f"{model} {kind}"
    assert code in (0, 3), f"{what}: exit {code}: {message[-400:]}"
    summary = read_json(os.path.join(out, "summary.json"))
    rows = read_series(os.path.join(out, "series.csv"))
    surface = read_json(os.path.join(out, "surface.json"))
    clean = all_finite(rows) and finite_json(summary) and finite_json(surface)
    summary = summary or {}
    if code == 0:
        ok = summary.get("completed") and clean
        outcome = (f"converged, {summary.get('newton_iterations')} Newton its, "
                   f"{summary.get('cutbacks')} cutbacks")
    else:
        failure = summary.get("failure", {})
        ok = (summary.get("completed") is False and clean and "Newton failed" in message
              and "Try:" in message and failure.get("cutbacks", 0) >= 5
              and "PETSC ERROR" not in message)
        outcome = (f"stopped cleanly at t = {failure.get('t_converged', math.nan):.3g} s after "
                   f"{failure.get('cutbacks')} cutbacks")
    record(f"{what:32s} {outcome}")
    assert ok, f"{what}: {outcome}; outputs finite: {clean}"


def test_extremes_fusiform_stiff_penalty_q1_fails(extreme):
    code, message, _ = extreme("combi", "fusiform_stiff_penalty_q1")
    assert code == 3, (f"combi fusiform_stiff_penalty_q1: fails as the stability report says "
                       f"(exit {code}) {message[-300:]}")


# ---------------------------------------------------------------------------
# element comparisons: the free shortening of the graded block against Q2
# (anti-locking Q1 for BLE, F-bar for COMBI and GIANT); one element of each
# comparison also runs on 2 ranks, which must agree to 1e-8
# ---------------------------------------------------------------------------
ELEMENTS = {"Q1": "{degree: 1, fbar: false}",
            "Q1 anti-locking": "{degree: 1, volumetric_quadrature_degree: 1}",
            "Q1 F-bar": "{degree: 1, fbar: true}", "Q2": "{degree: 2}"}


def graded_block(model):
    """The graded block, free, at 5 ms steps, with `model`."""
    text = scene_text("block_graded").replace("step: 0.01", "step: 0.005")
    text = text.replace("material: {model: ble}", f"material: {{model: {model}}}")
    if model == "giant":  # twitch train: 1 ms steps resolve it (demo default)
        text = text.replace("step: 0.005", "step: 0.002").replace("end: 0.1", "end: 0.03")
    return text


@pytest.fixture(scope="module")
def block_run(build, module_scratch):
    """block_run(model, element, ranks): (exit status, output, final free shortening
    1 - epsilon or None) of the graded block, once."""
    @functools.lru_cache(maxsize=None)
    def get(model, element, ranks=1):
        name = f"{model}_{element.replace(' ', '_')}_np{ranks}"
        path = write(os.path.join(module_scratch, name + ".yaml"),
                     graded_block(model).replace("element: {degree: 2}", "element: " + ELEMENTS[element]))
        out = os.path.join(module_scratch, name)
        r = run(build, [path, "--out", out, "--quiet"], ranks=ranks,
                timeout=600 if model == "ble" else 900)
        rows = read_series(os.path.join(out, "series.csv")) if r.returncode == 0 else []
        return r.returncode, (r.stdout + r.stderr)[-300:], 1 - float(rows[-1]["epsilon"]) if rows else None
    return get


def errors_against_q2(block_run, record, model, elements):
    """Relative error of each element's free shortening against Q2's."""
    shortening = {e: block_run(model, e)[2] for e in elements}
    failed = [e for e, s in shortening.items() if s is None]
    assert not failed, f"{model}: every element's run is needed; failed: {failed}"
    reference = shortening["Q2"]
    error = {k: abs(v - reference) / reference for k, v in shortening.items()}
    record(f"{model}: free shortening {shortening}; error against Q2 {error}")
    return error


def element_runs(model, element, ranks):
    """The run test case of one element (id model-element[-2 ranks])."""
    return pytest.param(model, element, ranks, id=f"{model}-{element}" + ("-2 ranks" if ranks > 1 else ""))


def check_element_run(block_run, model, element, ranks):
    code, output, _ = block_run(model, element, ranks)
    assert code == 0, f"{model} {element} on {ranks} rank(s): exit {code} {output}"


def check_ranks_agree(block_run, model, element):
    one, two = block_run(model, element)[2], block_run(model, element, 2)[2]
    assert one is not None and two is not None and abs(two - one) <= 1e-8 * one, (
        f"{model} {element}: 1 and 2 ranks agree ({one!r} vs {two!r})")


# anti-locking: BLE's one-point volumetric penalty against plain Q1 and Q2
ANTI_LOCKING = ["Q1", "Q1 anti-locking", "Q2"]


@pytest.mark.parametrize("model, element, ranks", [element_runs("ble", e, 1) for e in ANTI_LOCKING]
                         + [element_runs("ble", "Q1 anti-locking", 2)])
def test_anti_locking_runs(block_run, model, element, ranks):
    check_element_run(block_run, model, element, ranks)


def test_anti_locking_ranks_agree(block_run):
    check_ranks_agree(block_run, "ble", "Q1 anti-locking")


def test_anti_locking_plain_q1_locks(block_run, record):
    error = errors_against_q2(block_run, record, "ble", ANTI_LOCKING)
    # plain Q1 locks (64 % when written)
    assert error["Q1"] > 0.3, f"plain Q1 locks: {error['Q1']:.1%} from Q2"


def test_anti_locking_removes_most_locking(block_run, record):
    error = errors_against_q2(block_run, record, "ble", ANTI_LOCKING)
    # the one-point penalty removes most of it
    assert error["Q1 anti-locking"] < 0.15 and error["Q1 anti-locking"] < error["Q1"] / 4, (
        f"anti-locking Q1: {error['Q1 anti-locking']:.1%} from Q2 (plain {error['Q1']:.1%})")


# F-bar Q1 against plain Q1 and Q2 for COMBI and GIANT; COMBI's F-bar also on 2
# ranks (the eliminated J0 on ghosted cells)
FBAR = ["Q1", "Q1 F-bar", "Q2"]
FBAR_MODELS = ["combi", "giant"]


@pytest.mark.parametrize("model, element, ranks", [element_runs(m, e, 1) for m in FBAR_MODELS for e in FBAR]
                         + [element_runs("combi", "Q1 F-bar", 2)])
def test_fbar_runs(block_run, model, element, ranks):
    check_element_run(block_run, model, element, ranks)


def test_fbar_ranks_agree(block_run):
    check_ranks_agree(block_run, "combi", "Q1 F-bar")


@pytest.mark.parametrize("model", FBAR_MODELS)
def test_fbar_plain_q1_locks(block_run, record, model):
    error = errors_against_q2(block_run, record, model, FBAR)
    assert error["Q1"] > 0.1, f"{model}: plain Q1 locks: {error['Q1']:.1%} from Q2"


@pytest.mark.parametrize("model", FBAR_MODELS)
def test_fbar_keeps_only_discretisation_error(block_run, record, model):
    error = errors_against_q2(block_run, record, model, FBAR)
    # 54 cells of 5 mm: F-bar keeps Q1's discretisation error (6-7 % when written),
    # not its locking (17-19 %)
    assert error["Q1 F-bar"] < min(0.1, error["Q1"] / 2), (
        f"{model}: F-bar Q1 {error['Q1 F-bar']:.1%} from Q2 (plain {error['Q1']:.1%})")


# ---------------------------------------------------------------------------
# several parts: a body split into parts of the same material must give the
# single-part result (the forms, kernels and post-processing of each part see
# only its cells); a real two-material body agrees on 1 and 2 ranks.
# ---------------------------------------------------------------------------
def split_in_two(text, part_a, part_b):
    start = text.index("parts:\n") + len("parts:\n")
    end = text.index("boundary:")
    return text[:start] + part_a + part_b + text[end:]


def split_scenes():
    """name -> (one-part scene, the same body as two parts of one material, t_end)."""
    graded = scene_text("block_graded")
    body = """    material: {{model: ble}}
    fibres: {{direction: [0, 0, 1]}}
    activation: {{time: model, scale: {scale}}}
"""
    two_graded = split_in_two(graded, "  - name: a\n    volumes: lower\n" + body.format(scale=1.0),
                              "  - name: b\n    volumes: [upper]\n" + body.format(scale=0.5))
    wave = scene_text("block_wave")
    wave_part = """    material: {model: giant}
    fibres: {direction: [0, 0, 1]}
    activation:
      time: {ramp: {start: 0, duration: 0.02, value: 1}}
      scale: {expression: "exp(-((z - 300*t)/8)^2)"}
"""
    two_wave = split_in_two(wave, "  - name: a\n    volumes: [lower]\n" + wave_part,
                            "  - name: b\n    volumes: [upper]\n" + wave_part)
    return {"BLE, activation per group": (graded, two_graded, "0.05"),
            "GIANT kernels, travelling wave": (wave, two_wave, "0.02")}


SPLIT = list(split_scenes())
WAVE = "GIANT kernels, travelling wave"


@pytest.fixture(scope="module")
def parts_run(build, module_scratch):
    """parts_run(name, parts, ranks): (exit status, stderr, final values) of the scene
    `name` of split_scenes() as one or two parts, once."""
    scenes = split_scenes()

    @functools.lru_cache(maxsize=None)
    def get(name, parts, ranks=1):
        label = f"{SPLIT.index(name)}_{parts}_np{ranks}"
        path = write(os.path.join(module_scratch, label + ".yaml"), scenes[name][parts == "two"])
        out = os.path.join(module_scratch, label)
        r = run(build, [path, "--out", out, "--quiet", "--t-end", scenes[name][2]], ranks=ranks)
        return r.returncode, r.stderr[-300:], final(out) if r.returncode == 0 else {}
    return get


@pytest.mark.parametrize("parts", ["one", "two"])
@pytest.mark.parametrize("name", SPLIT)
def test_parts_split_runs(parts_run, name, parts):
    code, stderr, _ = parts_run(name, parts)
    assert code == 0, f"{name}, {parts} part(s): runs (exit {code}) {stderr}"


@pytest.mark.parametrize("name", SPLIT)
def test_parts_split_equals_whole(parts_run, name):
    a, b = parts_run(name, "one")[2], parts_run(name, "two")[2]
    worst = worst_difference(a, b, 1e-12)
    assert bool(a) and worst <= 1e-9, (
        f"{name}: two parts of one material = one part (worst relative difference {worst:.1e})")


def test_parts_two_part_wave_on_two_ranks(parts_run):
    """Per-part formulas and kernels on 2 ranks."""
    code, stderr, b = parts_run(WAVE, "two", 2)
    worst = worst_difference(parts_run(WAVE, "one")[2], b, 1.0) if code == 0 else math.inf
    assert worst <= 1e-8, (f"two-part GIANT wave on 2 ranks = one part on 1 rank ({worst:.1e}; "
                           f"exit {code}) {stderr}")


@pytest.fixture(scope="module")
def muscle_tendon(build, module_scratch):
    """block_muscle_tendon.yaml on 1 and 2 ranks: {ranks: (exit status, stderr, summary)}."""
    scene = os.path.join(SCENES, "block_muscle_tendon.yaml")
    runs = {}
    for n in (1, 2):
        out = os.path.join(module_scratch, f"mt{n}")
        r = run(build, [scene, "--out", out, "--quiet", "--t-end", "0.03"], ranks=n)
        runs[n] = (r.returncode, r.stderr[-300:], read_json(os.path.join(out, "summary.json")) or {})
    return runs


@pytest.mark.parametrize("n", [1, 2], ids=["1 rank", "2 ranks"])
def test_parts_muscle_tendon_runs(muscle_tendon, n):
    code, stderr, _ = muscle_tendon[n]
    assert code == 0, f"muscle + tendon on {n} rank(s) (exit {code}) {stderr}"


def test_parts_muscle_tendon_ranks_agree(muscle_tendon):
    a, b = (muscle_tendon[n][2].get("final", {}) for n in (1, 2))
    # relative to the value, or to 1 mN / 1 mm for quantities that vanish (round-off)
    worst = worst_difference(a, b, 1.0)
    assert worst <= 1e-8, f"muscle + tendon: 1 and 2 ranks agree ({worst:.1e})"


def test_parts_tendon_builds_passive_forms(muscle_tendon):
    built = muscle_tendon[1][2].get("built", {}).get("parts")
    assert built and built[0]["forms"] == "combi" and built[1]["forms"] == "ehret_passive" \
        and not built[1]["activation_terms"], f"the tendon builds passive forms only ({built})"


def test_parts_free_body_shortens_without_axial_force(muscle_tendon):
    f = muscle_tendon[1][2].get("final")
    assert f, f"muscle + tendon on 1 rank: no summary (exit {muscle_tendon[1][0]})"
    assert f["epsilon"] < 1 and abs(f["F33_middle"]) < 1e-6 * 1e3, (
        f"the free body shortens ({f['epsilon']:.4f}) and carries no axial force "
        f"({f['F33_middle']:.2e} mN)")


# ---------------------------------------------------------------------------
# parity: 1 and 2 MPI ranks agree, an error on one rank stops both, a run killed
# on one rank resumes on two
# ---------------------------------------------------------------------------
@pytest.fixture(scope="module")
def parity(build, module_scratch):
    """block_graded.yaml to 0.05 s on 1 rank, on 2 ranks, and killed on 1 rank then
    resumed on 2: {label: (exit status, stderr, output directory)}."""
    scene = os.path.join(SCENES, "block_graded.yaml")
    one, two, mixed = (os.path.join(module_scratch, d) for d in ("one", "two", "mixed"))
    runs = {}
    for label, out, ranks in (("one", one, 1), ("two", two, 2)):
        r = run(build, [scene, "--out", out, "--quiet", "--t-end", "0.05"], ranks=ranks)
        runs[label] = (r.returncode, r.stderr[-300:], out)
    kill_after(build, scene, mixed, 2, extra=["--t-end", "0.05"])
    r = run(build, [scene, "--out", mixed, "--resume", "--quiet", "--t-end", "0.05"], ranks=2)
    runs["mixed"] = (r.returncode, r.stderr[-300:], mixed)
    return runs


def test_parity_two_ranks_run(parity):
    code, stderr, _ = parity["two"]
    assert code == 0, f"2 ranks run (exit {code}) {stderr}"


def test_parity_ranks_agree(parity):
    assert parity["one"][0] == 0, f"1 rank run (exit {parity['one'][0]}) {parity['one'][1]}"
    worst = worst_difference(final(parity["one"][2]), final(parity["two"][2]), 1e-12)
    assert worst <= 1e-8, f"1 and 2 ranks agree (worst relative difference {worst:.1e})"


def test_parity_error_in_one_rank_stops_both(build, scratch):
    """An error in the cells of one rank only stops both ranks with the message."""
    local = scene_text("block_graded").replace(
        "scale: {groups: {lower: 1.0, upper: 0.5}}", "scale: {expression: \"1 - 2*(z > 27)\"}")
    path = write(os.path.join(scratch, "local.yaml"), local)
    r = run(build, [path, "--out", os.path.join(scratch, "local"), "--quiet", "--check"], ranks=2,
            timeout=120)
    output = r.stdout + r.stderr
    assert r.returncode == 2 and "activation scale is -1" in output, (
        f"an error in one rank's cells stops both ranks: exit {r.returncode}, {output[-200:]}")


def test_parity_resume_on_two_ranks(parity):
    code, stderr, _ = parity["mixed"]
    assert code == 0, f"resume on 2 ranks (exit {code}) {stderr}"


@pytest.mark.parametrize("i", [0, 1], ids=["final values", "series"])
def test_parity_resumed_on_two_ranks_equals_one_rank(parity, i):
    assert parity["mixed"][0] == 0, f"resume on 2 ranks failed (exit {parity['mixed'][0]})"
    ok, message = compare(parity["one"][2], parity["mixed"][2], "1 rank killed, resumed on 2")[i]
    assert ok, message


# ---------------------------------------------------------------------------
# --set KEY=VALUE and the point probe: --set gives what the same edit of the file
# gives, is recorded in summary.json, and its mistakes are located at the --set; a
# point probe on the free block's top (which the uniform-axial constraint moves as
# one) equals the surface's mean displacement, and 1 and 2 ranks probe the same value.
# ---------------------------------------------------------------------------
PROBES = ("    - {name: tip_z, quantity: point, at: [5, 5, 30], component: z}\n"
          "    - {name: corner_x, quantity: point, at: [10, 10, 30], component: x, of: position}\n"
          "    - {name: inside_z, quantity: point, at: [3.3, 7.1, 12.9], component: z}\n")
SETS = ["--set", "time.end=0.02", "--set", "time.step=0.005",
        "--set", "parts[0].material.parameters.mu=20",
        "--set", "element.degree=1", "--set", "element.fbar=true"]


def probe_scenes():
    """The graded block with three point probes, and the same edited by hand as SETS edits it."""
    base = scene_text("block_graded").replace("    - {name: min_J, quantity: min_J}\n",
                                              "    - {name: min_J, quantity: min_J}\n" + PROBES)
    edited = (base.replace("time: {end: 0.1, step: 0.01}", "time: {end: 0.02, step: 0.005}")
              .replace("material: {model: ble}", "material: {model: ble, parameters: {mu: 20}}")
              .replace("element: {degree: 2}", "element: {degree: 1, fbar: true}"))
    return base, edited


def test_overrides_edited_scene_differs_in_three_values():
    _, edited = probe_scenes()
    assert edited.count("mu: 20") == 1 and "0.005" in edited and "fbar" in edited, (
        "the hand-edited scene differs from the base in the three values")


@pytest.fixture(scope="module")
def base_scene(module_scratch):
    """The probed graded block and its hand-edited copy, written once: the base's path."""
    base, edited = probe_scenes()
    write(os.path.join(module_scratch, "edited.yaml"), edited)
    return write(os.path.join(module_scratch, "base.yaml"), base)


OVERRIDE_RUNS = {"edited": ("edited", [], 1), "set": ("base", SETS, 1), "set_2_ranks": ("base", SETS, 2)}


@pytest.fixture(scope="module")
def override_run(build, module_scratch, base_scene):
    """override_run(label): (exit status, stderr, summary, series rows), once."""
    @functools.lru_cache(maxsize=None)
    def get(label):
        scene, extra, ranks = OVERRIDE_RUNS[label]
        out = os.path.join(module_scratch, label)
        r = run(build, [os.path.join(module_scratch, scene + ".yaml"), "--out", out, "--quiet"] + extra,
                ranks=ranks)
        return (r.returncode, r.stderr[-300:], read_json(os.path.join(out, "summary.json")) or {},
                read_series(os.path.join(out, "series.csv")))
    return get


def override_summary(override_run, label):
    code, stderr, summary, rows = override_run(label)
    assert code == 0, f"{label} did not run (exit {code}) {stderr}"
    return summary, rows


@pytest.mark.parametrize("label", list(OVERRIDE_RUNS))
def test_overrides_runs(override_run, label):
    code, stderr, _, _ = override_run(label)
    assert code == 0, f"{label}: runs (exit {code}) {stderr}"


def test_overrides_set_equals_edited_series(override_run):
    _, edited_rows = override_summary(override_run, "edited")
    _, set_rows = override_summary(override_run, "set")
    columns = [c for c in (edited_rows[0] if edited_rows else []) if c not in ("wall_time", "residual")]
    same = len(edited_rows) == len(set_rows) == 4 and all(
        a[c] == b[c] for a, b in zip(edited_rows, set_rows) for c in columns)
    assert same, (f"--set gives the hand-edited scene's series to the last digit "
                  f"({len(set_rows)} rows)")


def test_overrides_recorded_in_summary(override_run):
    edited_summary, _ = override_summary(override_run, "edited")
    set_summary, _ = override_summary(override_run, "set")
    assert set_summary.get("overrides") == [a for a in SETS if a != "--set"] \
        and edited_summary.get("overrides") == [], (
            f"summary.json records the overrides ({set_summary.get('overrides')}; "
            f"edited: {edited_summary.get('overrides')})")


def test_overrides_set_builds_fbar(override_run):
    element = override_summary(override_run, "set")[0]["built"].get("element", {})
    assert element.get("fbar") is True and element.get("degree") == 1, (
        f"--set element.fbar=true builds F-bar ({element})")


def test_overrides_probe_top_centre(override_run):
    f = override_summary(override_run, "set")[0]["final"]
    top = 30 * (f["epsilon"] - 1)
    assert abs(f["tip_z"] - top) <= 1e-9 * abs(top), (
        f"probe at the top centre {f['tip_z']:.12f} = top mean displacement {top:.12f}")


def test_overrides_probe_held_corner(override_run):
    f = override_summary(override_run, "set")[0]["final"]
    # the corner is held in x: the interpolated displacement is zero to round-off
    # (exactly 10.0 on one CPU, 10.000000000000002 with OPENBLAS_CORETYPE=Haswell)
    assert abs(f["corner_x"] - 10.0) <= 1e-9, f"position probe at the held corner: x = {f['corner_x']!r}"


def test_overrides_probe_interior(override_run):
    f = override_summary(override_run, "set")[0]["final"]
    top = 30 * (f["epsilon"] - 1)
    assert f["inside_z"] < 0 and f["inside_z"] > top, (
        f"an interior probe moves between the clamp and the top ({f['inside_z']:.6f}; top {top:.6f})")


def test_overrides_probes_on_two_ranks(override_run):
    one = override_summary(override_run, "set")[0]["final"]
    two = override_summary(override_run, "set_2_ranks")[0]["final"]
    worst = max(abs(two[k] - one[k]) / max(abs(one[k]), 1e-12) for k in ("tip_z", "corner_x", "inside_z"))
    assert worst <= 1e-8, f"1 and 2 ranks probe the same values (relative {worst:.1e})"


@pytest.mark.parametrize("assignment, expected", [
    ("time.stp=0.01", "did you mean 'step'"),
    ("parts[2].material.model=ble", "parts[2] does not exist"),
    ("parts[0].material.parameters.kapa=3", "did you mean 'kappa'"),
    ("parts[0].material.parameters.mu=-1", "must be >= 0"),
    ("time.step=abc", "'abc' is not a number"),
    ("prts[0].name=x", "did you mean 'parts'"),
    ("time.step", "expected KEY=VALUE"),
    ("time.end.x=1", "is a value, not a mapping")])
def test_overrides_mistake(build, scratch, base_scene, assignment, expected):
    """Mistakes: exit 2, located at the --set, before anything is built."""
    r = run(build, [base_scene, "--out", os.path.join(scratch, "bad"), "--check", "--set", assignment])
    message = r.stderr.strip()
    assert r.returncode == 2 and f"--set {assignment}" in message and expected in message, (
        f"--set {assignment}: exit {r.returncode}, '{message[-160:]}'")


def test_overrides_overflowing_input_named(build, scratch, base_scene):
    """An overflowing input is named as such, not blamed on the time step."""
    r = run(build, [base_scene, "--out", os.path.join(scratch, "overflow"), "--quiet",
                    "--set", "parts[0].activation.scale.groups.lower=1e308",
                    "--set", "time.end=0.005", "--set", "time.step=0.005",
                    "--set", "time.max_cutbacks=1"])
    message = r.stderr.strip()
    assert r.returncode == 3 and "activation scale of part 'muscle' up to 1e+308" in message \
        and "an input overflows" in message and "smaller time step (" not in message, (
            f"an activation scale of 1e308: exit {r.returncode}, '{message[-300:]}'")


def test_overrides_probe_outside_body(build, scratch):
    """A probe far outside the body is a mistake too."""
    base, _ = probe_scenes()
    path = write(os.path.join(scratch, "far.yaml"), base.replace("at: [5, 5, 30]", "at: [5, 5, 90]"))
    r = run(build, [path, "--out", os.path.join(scratch, "far"), "--check"])
    assert r.returncode == 2 and "outside the body" in r.stderr and "output.series[4].at" in r.stderr, (
        f"a probe outside the body: exit {r.returncode}, '{r.stderr.strip()[-200:]}'")
