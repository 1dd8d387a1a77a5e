#!/usr/bin/python3
"""Fusiform-muscle tests (issue: fusiform muscle), run by pytest.  ctest runs one group
of test functions per test (P = python3 -m pytest -p no:cacheprovider
tests/fusiform/test_fusiform.py --build B):

    P -k "test_run and E_M"        model M on element E: both cases finish, forces consistent
    P -k "test_findings and [E]"   the paper's findings on E = fbar or q2 (after the E runs)
    P -k test_parity               1 vs 2 MPI ranks; 2 ranks repeated
    P -k test_failure              failure without loss
    P -k test_mesh                 the mesh family's grading (Gmsh only)

M is ble, wkm, giant or combi; E is q1, q2 or fbar (the paper's F-bar hexahedron).
The test_run_* tests leave their summaries under B/test_out/fusiform_<E>/ for
test_findings_*.  The old command line still works and runs the same tests:

    test_fusiform.py run      --build B --model M --element E [--dt DT]
    test_fusiform.py findings --build B [--element E]
    test_fusiform.py parity   --build B
    test_fusiform.py failure  --build B

The binary runs the scenes demos/scenes/fusiform_<case>.yaml with its options as
overrides: series.csv has the columns F33 (mid-section force), F33_origin and, free,
epsilon; summary.json the final values under "final".

References are independent of the code under test: the isometric force is
computed twice (section force at mid-length and reaction at the origin, two
different integrals that equilibrium makes equal); a free muscle carries no net
axial force; the findings are the paper's (section "Fusiform muscle
contraction"); parity compares two parallel decompositions.
"""
import argparse
import collections
import csv
import functools
import math
import os
import shutil
import subprocess
import sys

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                                "support"))
from checks import all_finite, finite_json, read_json  # noqa: E402

MODELS = ["ble", "wkm", "giant", "combi"]
CASES = ["isometric", "free"]
ELEMENT_OPTIONS = {"q1": ["--degree", "1", "--no-fbar"], "q2": ["--degree", "2"],
                   "fbar": ["--fbar"]}
# Q2 costs about 10 s per Newton iteration: 10 ms steps (quasi-static and
# hyperelastic, so the coarse step does not change the state at t_end)
ELEMENT_DT = {"q2": 0.01}
FORCE_SPREAD = 0.05       # paper: "the computed force maxima are close to equal"
SHORTENING_SPREAD = 0.05  # paper: WKM, GIANT, COMBI "total shortening is close to equal"

Run = collections.namedtuple("Run", "code summary series fieldnames output")


def fusiform(build, out, options, ranks=1):
    """Run the fusiform binary; what it wrote (an empty summary or series if it wrote none)."""
    command = [os.path.join(build, "fusiform"), *options, "--out", out, "--quiet",
               "--no-fields"]
    if ranks > 1:
        command = ["mpirun", "--allow-run-as-root", "--oversubscribe", "-n", str(ranks),
                   *command]
    result = subprocess.run(command, capture_output=True, text=True)
    summary = read_json(os.path.join(out, "summary.json")) or {}
    try:
        with open(os.path.join(out, "series.csv")) as f:
            reader = csv.DictReader(f)
            series, fieldnames = list(reader), reader.fieldnames
    except OSError:
        series, fieldnames = [], None
    return Run(result.returncode, summary, series, fieldnames,
               (result.stdout[-1000:] + result.stderr[-1000:]).strip())


def out_dir(build, element):
    return os.path.join(build, "test_out", f"fusiform_{element}")


# ---------------------------------------------------------------------------
# run: both cases of one model on one element finish; the forces are consistent
# ---------------------------------------------------------------------------
RUNS = [pytest.param(element, model, id=f"{element}_{model}",
                     marks=[pytest.mark.long] if element == "q2" else [])
        for element in ELEMENT_OPTIONS for model in MODELS]


@pytest.fixture(scope="module")
def runs(build, request):
    """runs(element, model, case): the run, made once (minutes) and shared by the checks."""
    dt = request.config.getoption("--fusiform-dt")

    @functools.lru_cache(maxsize=None)
    def get(element, model, case):
        options = ["--model", model, "--refinement", "1", *ELEMENT_OPTIONS[element]]
        step = dt or ELEMENT_DT.get(element)
        if step:
            options += ["--dt", str(step)]
        out = os.path.join(out_dir(build, element), f"{model}_{case}")
        return fusiform(build, out, options + ["--case", case])
    return get


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("element, model", RUNS)
def test_run_completes(runs, element, model, case):
    r = runs(element, model, case)
    assert r.code == 0 and r.summary.get("completed"), (
        f"{model} {case}: run completes (exit {r.code}, {r.summary.get('steps')} steps, "
        f"{r.summary.get('cutbacks')} cutbacks) {r.output}")


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("element, model", RUNS)
def test_run_reaches_end(runs, element, model, case):
    series = runs(element, model, case).series
    last = float(series[-1]["t"]) if series else None
    assert last is not None and abs(last - 0.15) < 1e-9, (
        f"{model} {case}: series reaches t = 0.15 s (last row at t = {last})")


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("element, model", RUNS)
def test_run_finite(runs, element, model, case):
    series = runs(element, model, case).series
    assert series and all_finite(series), (
        f"{model} {case}: every value in series.csv is finite ({len(series)} rows)")


def forces(runs, element, model, case):
    series = runs(element, model, case).series
    assert series, f"{model} {case}: no series.csv rows (run failed)"
    return [(float(r["F33"]), float(r["F33_origin"])) for r in series]


@pytest.mark.parametrize("element, model", RUNS)
def test_run_section_force_equals_origin_reaction(runs, element, model):
    iso = forces(runs, element, model, "isometric")
    scale = max(abs(a) for a, _ in iso)
    worst = max(abs(a - b) for a, b in iso) / scale
    assert worst < 1e-6, (f"{model}: mid-section force equals origin reaction "
                          f"(max relative difference {worst:.1e})")


@pytest.mark.parametrize("element, model", RUNS)
def test_run_free_carries_no_axial_force(runs, element, model):
    scale = max(abs(a) for a, _ in forces(runs, element, model, "isometric"))
    free = max(abs(a) for a, _ in forces(runs, element, model, "free")) / scale
    assert free < 1e-6, (f"{model}: free contraction carries no axial force "
                         f"(|F33| / F_iso = {free:.1e})")


# ---------------------------------------------------------------------------
# findings: the paper's, on a locking-free element (F-bar, as in the paper, or
# Q2), from the summaries the test_run_* tests left
# ---------------------------------------------------------------------------
FINDINGS = [pytest.param("fbar", id="fbar"), pytest.param("q2", id="q2", marks=pytest.mark.long)]


def findings(build, element):
    """Isometric force F33 and free stretch epsilon of every model."""
    summary = {(m, c): read_json(os.path.join(out_dir(build, element), f"{m}_{c}",
                                              "summary.json")) or {}
               for m in MODELS for c in CASES}
    forces = {m: summary[(m, "isometric")].get("final", {}).get("F33") for m in MODELS}
    eps = {m: summary[(m, "free")].get("final", {}).get("epsilon") for m in MODELS}
    missing = [f"{m}_{c}" for m, c in summary
               if (forces if c == "isometric" else eps)[m] is None]
    assert not missing, (f"all {element} runs present (run the fusiform_{element}_* tests "
                         f"first; missing {missing})")
    return forces, eps


@pytest.mark.parametrize("element", FINDINGS)
def test_findings_isometric_forces_close(build, record, element):
    forces, _ = findings(build, element)
    record(f"{element} isometric F33 [mN]: {forces}")
    spread = (max(forces.values()) - min(forces.values())) / min(forces.values())
    # paper: "the computed force maxima are close to equal"
    assert spread < FORCE_SPREAD, (f"isometric forces of the four models within "
                                   f"{100 * FORCE_SPREAD:.0f} % (spread {100 * spread:.2f} %; "
                                   f"F33 [mN] {forces})")


@pytest.mark.parametrize("element", FINDINGS)
def test_findings_ble_shortens_most(build, record, element):
    _, eps = findings(build, element)
    record(f"{element} free epsilon: {eps}")
    # paper: "we observe a higher shortening for the BLE-model"
    others = [eps[m] for m in ("wkm", "giant", "combi")]
    assert eps["ble"] < min(others), (f"BLE shortens most (epsilon {eps['ble']:.4f} < "
                                      f"{min(others):.4f}; epsilon {eps})")


@pytest.mark.parametrize("element", FINDINGS)
def test_findings_shortening_close(build, element):
    _, eps = findings(build, element)
    # paper: "for the GIANT-, WKM-, and COMBI-models, the total shortening is close to equal"
    shortening = [1 - eps[m] for m in ("wkm", "giant", "combi")]
    close = (max(shortening) - min(shortening)) / max(shortening)
    assert close < SHORTENING_SPREAD, (f"shortening of WKM, GIANT, COMBI within "
                                       f"{100 * SHORTENING_SPREAD:.0f} % of each other "
                                       f"({100 * close:.2f} %; epsilon {eps})")


# ---------------------------------------------------------------------------
# parity: same series on 1 and 2 MPI ranks (relative difference < 1e-8); a 2-rank run
# repeats to the last bit
# ---------------------------------------------------------------------------
@pytest.fixture(scope="module")
def parity_runs(build):
    @functools.lru_cache(maxsize=None)
    def get(case, ranks):
        out = os.path.join(build, "test_out", "parity", f"{case}_np{ranks}")
        return fusiform(build, out, ["--model", "giant", "--case", case, "--refinement", "1",
                                     "--t-end", "0.004"], ranks)
    return get


@pytest.mark.parametrize("ranks", [1, 2], ids=["1 rank", "2 ranks"])
@pytest.mark.parametrize("case", CASES)
def test_parity_completes(parity_runs, case, ranks):
    r = parity_runs(case, ranks)
    assert r.code == 0 and r.summary.get("ranks") == ranks, (
        f"giant {case} on {ranks} rank(s) completes (exit {r.code}, "
        f"ranks {r.summary.get('ranks')}) {r.output}")


# the free F33 is zero up to round-off: a relative difference means nothing; the
# isometric muscle has no stretch ratio
PARITY = [("isometric", "F33"), ("isometric", "volume_change"), ("free", "epsilon"),
          ("free", "volume_change")]


@pytest.mark.parametrize("case, column", PARITY)
def test_parity_series_agree(parity_runs, case, column):
    a, b = ([float(r[column]) for r in parity_runs(case, ranks).series] for ranks in (1, 2))
    assert a, f"giant {case} on 1 rank: no series rows"
    scale = max(max(abs(x) for x in a), 1e-300)
    diff = max(abs(x - y) for x, y in zip(a, b)) / scale if len(a) == len(b) else 1
    assert len(a) == len(b) and diff < 1e-8, (
        f"{case} {column}: 1 vs 2 ranks relative difference {diff:.1e} < 1e-8 "
        f"({len(a)} and {len(b)} rows)")


def test_parity_two_ranks_repeat(build):
    """The same run on two ranks, three times, must give the same result to the last bit.
    Threaded PT-Scotch partitioned the same mesh differently from run to run (three
    partitions in four runs), and with the partition GAMG's aggregates, the Krylov count
    and the last digits of F33.  GAMG (not MUMPS, whose own scheduling reorders sums) and
    a soft kappa keep each run about a second.  With SCOTCH_PTHREAD_NUMBER=2 set it fails
    unless the race happens to give one partition three times."""
    runs = [fusiform(build, os.path.join(build, "test_out", "parity", f"repeat_{k}"),
                     ["--model", "combi", "--case", "isometric", "--refinement", "1", "--fbar",
                      "--linear-solver", "gmres-gamg", "--dt", "0.05", "--t-end", "0.05",
                      "--set", "kappa=10"], 2) for k in range(3)]
    for k, r in enumerate(runs):
        assert r.code == 0 and r.summary.get("completed"), (
            f"run {k + 1} of 3 completes (exit {r.code}) {r.output}")
    seen = {(repr(r.summary["final"]["F33"]), r.summary["linear_iterations"]) for r in runs}
    assert len(seen) == 1, (
        f"three runs on 2 ranks give one (F33, Krylov iterations), not {sorted(seen)}")


def test_parity_sparse_schur(build):
    """The penalty split's sparse Schur approximation (-penalty_split_schur sparse) is a
    matrix over the cells of all ranks.  With both solves exact (MUMPS) the preconditioner
    is the same on one and two ranks, so the Krylov counts must agree up to round-off, not
    only the state (a reused product C C^T kept stale values on two ranks, and GMRES failed;
    a wrong column numbering would converge slower)."""
    exact = ["-soft_pc_type", "lu", "-soft_pc_factor_mat_solver_type", "mumps",
             "-schur_pc_type", "lu", "-schur_pc_factor_mat_solver_type", "mumps"]
    runs = [fusiform(build, os.path.join(build, "test_out", "parity", f"sparse_schur_np{n}"),
                     ["--model", "combi", "--case", "isometric", "--refinement", "1", "--fbar",
                      "--linear-solver", "gmres-schur", "--dt", "0.05", "--t-end", "0.05",
                      "-penalty_split_schur", "sparse", *exact], n) for n in (1, 2)]
    for n, r in zip((1, 2), runs):
        assert r.code == 0 and r.series, (
            f"sparse Schur on {n} rank(s) completes (exit {r.code}) {r.output}")
    a, b = (float(r.series[-1]["F33"]) for r in runs)
    assert abs(a / b - 1) < 1e-8, f"F33 on 1 and 2 ranks: {a} and {b} mN"
    k1, k2 = (int(r.series[-1]["linear_iterations"]) for r in runs)
    assert abs(k2 - k1) <= 0.05 * k1, f"Krylov iterations on 1 and 2 ranks: {k1} and {k2}"


# ---------------------------------------------------------------------------
# failure: a Newton failure cuts the step back; at the limit the run stops with a
# message (what, where, what to try), exit status 3, and its last converged
# state written
# ---------------------------------------------------------------------------
@pytest.fixture(scope="module")
def failed(build):
    """One Newton iteration per attempt cannot converge: every attempt fails."""
    out = os.path.join(build, "test_out", "failure")
    command = [os.path.join(build, "fusiform"), "--model", "combi", "--case", "free",
               "--refinement", "1", "--dt", "0.05", "--max-cutbacks", "2", "--out", out,
               "--quiet", "-snes_max_it", "1"]
    result = subprocess.run(command, capture_output=True, text=True)
    try:
        with open(os.path.join(out, "series.csv")) as f:
            reader = csv.DictReader(f)
            rows, fieldnames = list(reader), reader.fieldnames
    except OSError:
        rows, fieldnames = None, None
    return dict(code=result.returncode, stderr=result.stderr, message=result.stderr.strip(),
                summary=read_json(os.path.join(out, "summary.json")), rows=rows,
                fieldnames=fieldnames, fields=os.path.exists(os.path.join(out, "fields.xdmf")))


def test_failure_exit_status_3(failed):
    assert failed["code"] == 3, (f"exit status 3 for a failed solve (got {failed['code']}) "
                                 f"{failed['message'][-500:]}")


@pytest.mark.parametrize("part", ["Newton failed at step 1", "t = 0", "Try:", "cell"])
def test_failure_message_names(failed, part):
    assert part in failed["message"], f"the message names '{part}': {failed['message']}"


def test_failure_no_petsc_stack_trace(failed):
    assert "PETSC ERROR" not in failed["stderr"] and "Traceback" not in failed["stderr"], (
        f"no PETSc stack trace: {failed['stderr'][-1000:]}")


def test_failure_summary_written_not_completed(failed):
    summary = failed["summary"] or {}
    assert summary.get("completed") is False, (
        f"summary.json written with completed = false (got {failed['summary']})")


def test_failure_counts_failed_attempts(failed):
    # --max-cutbacks 2: the step and its two halvings, each failed
    failure = (failed["summary"] or {}).get("failure", {})
    assert failure.get("cutbacks") == 3 and failure.get("t_converged") == 0.0, (
        f"the failure counts 3 failed attempts from t = 0 (got {failure})")


def test_failure_fields_of_last_converged_state(failed):
    assert failed["fields"], "fields of the last converged state (fields.xdmf)"


def test_failure_series_header(failed):
    names = failed["fieldnames"]
    assert names is not None and "t" in names and "F33" in names, (
        f"series.csv has its header (got {names})")


def test_failure_one_row_per_converged_step(failed):
    # no step converged: a header and no rows, one row per converged step
    rows, steps = failed["rows"], (failed["summary"] or {}).get("steps")
    assert rows is not None and len(rows) == steps == 0, (
        f"one row per converged step ({rows and len(rows)} rows, {steps} steps)")


def test_failure_summary_finite(failed):
    assert failed["summary"] is not None and finite_json(failed["summary"]), (
        f"no NaN (null) in summary.json ({failed['summary']})")


def stopped_run(build, name, options):
    """fusiform with options that make it stop: (exit status, stop message)."""
    out = os.path.join(build, "test_out", name)
    result = subprocess.run([os.path.join(build, "fusiform"), *options, "--out", out, "--quiet",
                             "--no-fields"], capture_output=True, text=True)
    return result.returncode, result.stderr.strip()


@pytest.fixture(scope="module")
def linear_failure(build):
    """A stalled iterative linear solver."""
    return stopped_run(build, "failure_linear",
                       ["--model", "combi", "--refinement", "1", "--dt", "0.05",
                        "--max-cutbacks", "1", "--linear-solver", "gmres-gamg", "-ksp_max_it", "2"])


def test_failure_linear_solver_reported(linear_failure):
    code, message = linear_failure
    assert code == 3 and "DIVERGED_LINEAR_SOLVE" in message, (
        f"a linear-solver failure is reported as such (exit {code}): {message}")


def test_failure_linear_advice_names_direct_solver(linear_failure):
    # advice about the linear solver, not the step
    assert "--linear-solver lu" in linear_failure[1], (
        f"the advice names the direct solver: {linear_failure[1]}")


@pytest.fixture(scope="module")
def line_search_failure(build):
    """A line search that may not shorten the step (minimum step length 0.99)."""
    return stopped_run(build, "failure_line_search",
                       ["--model", "combi", "--case", "free", "--refinement", "1", "--no-fbar",
                        "--dt", "0.15", "--max-cutbacks", "0", "--line-search", "bt",
                        "-snes_linesearch_minlambda", "0.99"])


def test_failure_line_search_named_in_the_advice(line_search_failure):
    code, message = line_search_failure
    assert code == 3 and "DIVERGED_LINE_SEARCH" in message, (
        f"a line-search failure is reported as such (exit {code}): {message}")
    advice = message.split("Try:")[-1]
    assert "the line search (bt)" in advice and "--line-search" in advice, (
        f"the advice names the line search: {advice}")


@pytest.mark.parametrize("option, value", [("--linear-solver", "auto"), ("--line-search", "newton"),
                                           ("--case", "relaxed"), ("--cell", "prism")])
def test_failure_option_value_refused(build, option, value):
    """Options with a fixed set of values are checked where they are read."""
    result = subprocess.run([os.path.join(build, "fusiform"), option, value, "--out",
                             os.path.join(build, "test_out", "failure_option")],
                            capture_output=True, text=True)
    assert (result.returncode == 2 and value in result.stderr
            and "PETSC ERROR" not in result.stderr), (
        f"fusiform {option} {value}: exit {result.returncode}, {result.stderr.strip()[-120:]}")


def mesh_nodes(tmp_path, **numbers):
    """The node coordinates of meshes/fusiform.geo meshed by Gmsh with these numbers."""
    geo = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(
        os.path.abspath(__file__)))), "meshes", "fusiform.geo")
    out = os.path.join(tmp_path, "_".join(f"{k}{v}" for k, v in numbers.items()) + ".msh")
    setnumbers = [a for k, v in numbers.items() for a in ("-setnumber", k, str(v))]
    subprocess.run(["gmsh", "-3", *setnumbers, geo, "-format", "msh2", "-o", out],
                   check=True, capture_output=True)
    with open(out) as f:
        block = f.read().split("$Nodes")[1].split("$EndNodes")[0].split("\n")[2:-1]
    return [tuple(float(t) for t in line.split()[1:]) for line in block]


def meridian_z(nodes):
    """z of the nodes on the mantle's meridian at 45 degrees, sorted."""
    return sorted(z for x, y, z in nodes if x > 0 and abs(x - y) < 1e-9
                  and abs(math.hypot(x, y) - rim_radius(z)) < 0.05)


def rim_radius(z):
    """The fusiform's profile r(z) (fusiform.geo's closed form; Gmsh's spline through its
    stations every 5 mm follows it to about 0.01 mm, the outer blocks' cells are thicker)."""
    z = min(z, 100 - z)
    if z <= 25:
        return 10 + z / 5
    t = (z - 25) / 25
    return 15 + 5 * t + 5 * t ** 2 - 5 * t ** 3


def progression(t, ratio):
    """Where node i of N lies on an edge graded in geometric progression towards its end,
    t = i / N (the first cell `ratio`^(1 - 1/N) times the last): the same at every N."""
    return t if ratio == 1 else (1 - ratio ** -t) / (1 - 1 / ratio)


@pytest.mark.parametrize("grade, grade_radial", [(1, 1), (4, 6)])
def test_mesh_grading(tmp_path, grade, grade_radial):
    """A graded mesh family: the cells shrink towards the end faces (grade) and the mantle
    (grade_radial) in geometric progression, n = 1's nodes are n = 2's even nodes along the
    meridian, and the radial nodes lie at the same fractions at n = 1, 2, 4 (similar
    meshes, what Richardson extrapolation assumes)."""
    assert shutil.which("gmsh"), "the gmsh program is not on PATH (apt: gmsh)"
    meshes = {n: mesh_nodes(tmp_path, refinement=n, grade=grade, grade_radial=grade_radial)
              for n in (1, 2, 4)}
    z1, z2 = meridian_z(meshes[1]), meridian_z(meshes[2])
    assert len(z1) == 21 and len(z2) == 41, (len(z1), len(z2))
    # (Gmsh integrates a graded size along the curve: 0.002 mm off, 0.2 % of the end cell)
    assert max(abs(a - b) for a, b in zip(z1, z2[::2])) < 0.01, "n = 1 nodes not on n = 2's"
    assert max(abs(a + b - 100) for a, b in zip(z2, reversed(z2))) < 1e-5, "not symmetric"
    # cell lengths along the meridian in progression grade^(1/20) (arc length; the profile's
    # slope 1/5 at the end and 0 at mid-length make the z-lengths differ by 2 %)
    first, middle = z2[1] - z2[0], z2[20] - z2[19]
    assert middle / first == pytest.approx(grade ** (19 / 20) * math.sqrt(1 + 1 / 25),
                                           rel=0.01)
    # radially at z = 0 on the 45-degree line, from the core corner (radius 5) to the rim
    # (radius 10): the closed form at every n
    for n, nodes in meshes.items():
        radii = sorted(math.hypot(x, y) for x, y, z in nodes if abs(z) < 1e-9 and x > 0
                       and abs(x - y) < 1e-9 and math.hypot(x, y) >= 5 - 1e-9)
        cells = math.ceil(2.5 * n)
        expected = [5 + 5 * progression(i / cells, grade_radial) for i in range(cells + 1)]
        assert len(radii) == cells + 1 and max(
            abs(r - e) for r, e in zip(radii, expected)) < 1e-6, (n, radii, expected)


def main():
    """The command line of the former driver: runs the matching tests through pytest."""
    parser = argparse.ArgumentParser()
    parser.add_argument("command", choices=["run", "findings", "parity", "failure"])
    parser.add_argument("--build", required=True)
    parser.add_argument("--model", choices=MODELS)
    parser.add_argument("--element", choices=sorted(ELEMENT_OPTIONS), default="fbar")
    parser.add_argument("--dt", type=float)
    args = parser.parse_args()
    if args.command == "run" and not args.model:
        parser.error("run needs --model")
    selection = {"run": f"test_run and {args.element}_{args.model}",
                 "findings": f"test_findings and [{args.element}]",
                 "parity": "test_parity", "failure": "test_failure"}[args.command]
    options = [os.path.abspath(__file__), "-q", "-p", "no:cacheprovider", "-k", selection,
               "--build", args.build]
    if args.dt:
        options += ["--fusiform-dt", str(args.dt)]
    sys.dont_write_bytecode = True
    return int(pytest.main(options))


if __name__ == "__main__":
    sys.exit(main())
