#!/usr/bin/python3
"""Fusiform-muscle tests (issue: fusiform muscle).  Each subcommand is one ctest:

    test_fusiform.py run      --build B --model M --element E [--dt DT]  both cases finish
    test_fusiform.py findings --build B [--element E]                    the paper's findings
    test_fusiform.py parity   --build B                                   1 vs 2 MPI ranks
    test_fusiform.py failure  --build B                                   failure without loss

E is q1, q2 or fbar (the paper's F-bar hexahedron).  `run` leaves its summaries
under B/test_out/fusiform_<E>/ for `findings`.
References are independent of the code under test: the isometric force is
computed twice (section force at mid-length and reaction at the origin, two
different integrals that equilibrium makes equal); a free muscle carries no net
axial force; the findings are the paper's (section "Fusiform muscle
contraction"); parity compares two parallel decompositions.
"""
import argparse
import csv
import json
import os
import subprocess
import sys

MODELS = ["ble", "wkm", "giant", "combi"]
sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                                "support"))
from checks import all_finite, check, failures, finite_json  # noqa: E402


def fusiform(build, out, options, ranks=1):
    command = [os.path.join(build, "fusiform"), *options, "--out", out, "--quiet",
               "--no-fields"]
    if ranks > 1:
        command = ["mpirun", "--allow-run-as-root", "--oversubscribe", "-n", str(ranks),
                   *command]
    result = subprocess.run(command, capture_output=True, text=True)
    if result.returncode != 0:
        print(result.stdout[-2000:], result.stderr[-2000:])
    summary_path = os.path.join(out, "summary.json")
    summary = json.load(open(summary_path)) if os.path.exists(summary_path) else {}
    with open(os.path.join(out, "series.csv")) as f:
        series = list(csv.DictReader(f))
    return result.returncode, summary, series


ELEMENT_OPTIONS = {"q1": ["--degree", "1", "--no-fbar"], "q2": ["--degree", "2"],
                   "fbar": ["--fbar"]}


def out_dir(build, element):
    return os.path.join(build, "test_out", f"fusiform_{element}")


def run(args):
    """Both cases of one model finish; forces are consistent."""
    options = ["--model", args.model, "--refinement", "1", *ELEMENT_OPTIONS[args.element]]
    if args.dt:
        options += ["--dt", str(args.dt)]
    forces = {}
    for case in ("isometric", "free"):
        out = os.path.join(out_dir(args.build, args.element), f"{args.model}_{case}")
        code, summary, series = fusiform(args.build, out, options + ["--case", case])
        check(code == 0 and summary.get("completed"), f"{args.model} {case}: run completes "
              f"(exit {code}, {summary.get('steps')} steps, {summary.get('cutbacks')} cutbacks)")
        check(series and abs(float(series[-1]["t"]) - 0.15) < 1e-9,
              f"{args.model} {case}: series reaches t = 0.15 s")
        finite = all_finite(series)
        check(finite, f"{args.model} {case}: every value in series.csv is finite")
        forces[case] = [(float(r["F33"]), float(r["F33_origin"])) for r in series]
    iso = forces["isometric"]
    scale = max(abs(a) for a, _ in iso)
    worst = max(abs(a - b) for a, b in iso) / scale
    check(worst < 1e-6, f"{args.model}: mid-section force equals origin reaction "
          f"(max relative difference {worst:.1e})")
    free = max(abs(a) for a, _ in forces["free"]) / scale
    check(free < 1e-6, f"{args.model}: free contraction carries no axial force "
          f"(|F33| / F_iso = {free:.1e})")


def findings(args):
    """The paper's findings, on a locking-free element (F-bar, as in the paper, or Q2)."""
    summary = {}
    for model in MODELS:
        for case in ("isometric", "free"):
            path = os.path.join(out_dir(args.build, args.element), f"{model}_{case}",
                                "summary.json")
            summary[(model, case)] = json.load(open(path)) if os.path.exists(path) else {}
    forces = {m: summary[(m, "isometric")].get("F33") for m in MODELS}
    eps = {m: summary[(m, "free")].get("epsilon") for m in MODELS}
    print("F33 [mN]:", forces)
    print("epsilon:", eps)
    if None in forces.values() or None in eps.values():
        check(False, f"all {args.element} runs present "
              f"(run the fusiform_{args.element}_* tests first)")
        return
    spread = (max(forces.values()) - min(forces.values())) / min(forces.values())
    # paper: "the computed force maxima are close to equal"
    check(spread < args.force_spread, f"isometric forces of the four models within "
          f"{100 * args.force_spread:.0f} % (spread {100 * spread:.2f} %)")
    # paper: "we observe a higher shortening for the BLE-model"
    others = [eps[m] for m in ("wkm", "giant", "combi")]
    check(eps["ble"] < min(others), f"BLE shortens most (epsilon {eps['ble']:.4f} < "
          f"{min(others):.4f})")
    # paper: "for the GIANT-, WKM-, and COMBI-models, the total shortening is close to equal"
    shortening = [1 - e for e in others]
    close = (max(shortening) - min(shortening)) / max(shortening)
    check(close < args.shortening_spread, f"shortening of WKM, GIANT, COMBI within "
          f"{100 * args.shortening_spread:.0f} % of each other ({100 * close:.2f} %)")


def parity(args):
    """Same series on 1 and 2 MPI ranks (relative difference < 1e-8)."""
    for case in ("isometric", "free"):
        series = []
        for ranks in (1, 2):
            out = os.path.join(args.build, "test_out", "parity", f"{case}_np{ranks}")
            code, summary, rows = fusiform(args.build, out,
                                           ["--model", "giant", "--case", case,
                                            "--refinement", "1", "--t-end", "0.004"], ranks)
            check(code == 0 and summary.get("ranks") == ranks,
                  f"giant {case} on {ranks} rank(s) completes")
            series.append(rows)
        for column in ("F33", "epsilon", "volume_change"):
            a = [float(r[column]) for r in series[0]]
            b = [float(r[column]) for r in series[1]]
            scale = max(max(abs(x) for x in a), 1e-300)
            if case == "free" and column == "F33":
                continue  # zero up to round-off: a relative difference means nothing
            diff = max(abs(x - y) for x, y in zip(a, b)) / scale if len(a) == len(b) else 1
            check(len(a) == len(b) and diff < 1e-8,
                  f"{case} {column}: 1 vs 2 ranks relative difference {diff:.1e} < 1e-8")


def failure(args):
    """A Newton failure cuts the step back; at the limit the run stops with a message
    (what, where, what to try), exit status 3, and its last converged state written."""
    out = os.path.join(args.build, "test_out", "failure")
    # one Newton iteration per attempt cannot converge: every attempt fails
    command = [os.path.join(args.build, "fusiform"), "--model", "combi", "--case", "free",
               "--refinement", "1", "--dt", "0.05", "--max-cutbacks", "2", "--out", out,
               "--quiet", "-snes_max_it", "1"]
    result = subprocess.run(command, capture_output=True, text=True)
    message = result.stderr.strip()
    print(message)
    check(result.returncode == 3, f"exit status 3 for a failed solve (got {result.returncode})")
    for part in ("Newton failed at step 1", "t = 0", "Try:", "cell"):
        check(part in message, f"the message names '{part}'")
    check("PETSC ERROR" not in result.stderr and "Traceback" not in result.stderr,
          "no PETSc stack trace")
    summary = json.load(open(os.path.join(out, "summary.json")))
    check(summary.get("completed") is False, "summary.json written with completed = false")
    # --max-cutbacks 2: the step and its two halvings, each failed
    failure = summary.get("failure", {})
    check(failure.get("cutbacks") == 3 and failure.get("t_converged") == 0.0,
          f"the failure counts 3 failed attempts from t = 0 (got {failure})")
    check(os.path.exists(os.path.join(out, "fields.xdmf")), "fields of the last converged state")
    with open(os.path.join(out, "series.csv")) as f:
        reader = csv.DictReader(f)
        rows = list(reader)
    # no step converged: a header and no rows, one row per converged step
    check(reader.fieldnames is not None and "t" in reader.fieldnames and "F33" in reader.fieldnames,
          "series.csv has its header")
    check(len(rows) == summary.get("steps") == 0, f"one row per converged step ({len(rows)} rows)")
    check(finite_json(summary), "no NaN (null) in summary.json")
    # a stalled iterative linear solver gets advice about the linear solver, not the step
    command = [os.path.join(args.build, "fusiform"), "--model", "combi", "--refinement", "1",
               "--dt", "0.05", "--max-cutbacks", "1", "--linear-solver", "gmres-gamg",
               "--out", out + "_linear", "--quiet", "--no-fields", "-ksp_max_it", "2"]
    result = subprocess.run(command, capture_output=True, text=True)
    message = result.stderr.strip()
    print(message)
    check(result.returncode == 3 and "DIVERGED_LINEAR_SOLVE" in message,
          f"a linear-solver failure is reported as such (exit {result.returncode})")
    check("--linear-solver lu" in message, "the advice names the direct solver")
    # options with a fixed set of values are checked where they are read
    for option, value in (("--linear-solver", "auto"), ("--line-search", "newton"),
                          ("--case", "relaxed"), ("--cell", "prism")):
        result = subprocess.run([os.path.join(args.build, "fusiform"), option, value, "--out",
                                 out + "_option"], capture_output=True, text=True)
        check(result.returncode == 2 and value in result.stderr and "PETSC ERROR" not in result.stderr,
              f"fusiform {option} {value}: exit {result.returncode}, {result.stderr.strip()[-120:]}")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("command", choices=["run", "findings", "parity", "failure"])
    parser.add_argument("--build", required=True)
    parser.add_argument("--model", choices=MODELS)
    parser.add_argument("--element", choices=sorted(ELEMENT_OPTIONS), default="fbar")
    parser.add_argument("--dt", type=float)
    parser.add_argument("--force-spread", type=float, default=0.05)
    parser.add_argument("--shortening-spread", type=float, default=0.05)
    args = parser.parse_args()
    {"run": run, "findings": findings, "parity": parity, "failure": failure}[args.command](args)
    if failures:
        print(f"{len(failures)} check(s) failed")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
