#!/usr/bin/python3
"""Stability report: the fusiform free contraction (n = 1) at the extremes, for
every model.  Each run either converges (possibly after cutbacks) or stops with
a message, a nonzero exit status and its last converged state written.

    stability_report.py [--build DIR] [--out DIR] [--doc docs/stability.md] [--models ...]

Writes OUT/stability.json and the Markdown page --doc (the table a user reads
before choosing parameters), and checks that no output file holds a NaN.
"""
import argparse
import csv
import json
import math
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
MODELS = ["ble", "wkm", "giant", "combi"]
NAMES = {"ble": "BLE", "wkm": "WKM", "giant": "GIANT", "combi": "COMBI"}
KAPPA = {"ble": 10000.0, "wkm": 1000.0, "giant": 1000.0, "combi": 1000.0}
# what doubles the tetanic active stress of each model
DOUBLE_ACTIVATION = {"ble": "sigma_max=2.29", "wkm": "N_a=0.9238", "giant": "N_a=0.9238",
                     "combi": "P_opt=129.3618"}


def extremes(model):
    """(name, options) of every extreme tried; quasi-static, so large steps are legitimate."""
    base = ["--dt", "0.05"]
    return [
        ("reference (dt 0.05 s)", base),
        ("one step of 0.15 s", ["--dt", "0.15"]),
        ("penalty x1000", base + ["--set", f"kappa={1000 * KAPPA[model]:g}"]),
        ("penalty x0.001", base + ["--set", f"kappa={0.001 * KAPPA[model]:g}"]),
        ("activation 2x tetanic", base + ["--set", DOUBLE_ACTIVATION[model]]),
        ("nearly degenerate elements (core 0.95)", base + ["--mesh-set", "core=0.95"]),
        ("penalty x1000, one step, no cutbacks", ["--dt", "0.15", "--max-cutbacks", "0",
                                                  "--set", f"kappa={1000 * KAPPA[model]:g}"]),
    ]


def all_finite(path):
    if not os.path.exists(path):
        return True
    with open(path) as f:
        for row in csv.reader(f):
            for v in row:
                try:
                    if not math.isfinite(float(v)):
                        return False
                except ValueError:
                    pass  # header
    return True


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--build", default=os.path.join(ROOT, "build"))
    parser.add_argument("--out", default=os.path.join(ROOT, "out", "stability"))
    parser.add_argument("--doc", default=os.path.join(ROOT, "docs", "stability.md"))
    parser.add_argument("--models", nargs="+", default=MODELS, choices=MODELS)
    parser.add_argument("--case", default="free", choices=["free", "isometric"])
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)

    records = []
    for model in args.models:
        for index, (name, options) in enumerate(extremes(model)):
            out = os.path.join(args.out, f"{model}_{index}")
            command = [os.path.join(args.build, "fusiform"), "--model", model, "--case",
                       args.case, "--refinement", "1", "--out", out, "--quiet",
                       "--no-fields", "--no-fbar", *options]
            start = time.time()
            result = subprocess.run(command, capture_output=True, text=True)
            wall = time.time() - start
            summary_path = os.path.join(out, "summary.json")
            summary = json.load(open(summary_path)) if os.path.exists(summary_path) else {}
            final = summary.get("final", {})
            message = (result.stderr.strip().splitlines() or [""])[-1]
            record = {
                "model": model, "extreme": name, "options": " ".join(options),
                "exit": result.returncode, "completed": bool(summary.get("completed")),
                # a stopped run's counts include the attempts on the step that failed
                "steps": summary.get("steps"),
                "newton": (summary.get("newton_iterations") or 0)
                + summary.get("failure", {}).get("newton_iterations", 0),
                "cutbacks": (summary.get("cutbacks") or 0) + summary.get("failure", {}).get("cutbacks", 0), "epsilon": final.get("epsilon"),
                "volume_change": final.get("volume_change"), "wall": wall,
                "message": message if result.returncode else "",
                "outputs_finite": all_finite(os.path.join(out, "series.csv"))
                and all(math.isfinite(v) for v in [*summary.values(), *final.values()]
                        if isinstance(v, float)),
            }
            records.append(record)
            print(f"{NAMES[model]:6s} {name:42s} exit {result.returncode}  "
                  f"{'converged' if record['completed'] else 'FAILED':9s} newton {record['newton']}"
                  f"  cutbacks {record['cutbacks']}  {wall:.0f} s", flush=True)
            if result.returncode:
                print("       " + message, flush=True)

    with open(os.path.join(args.out, "stability.json"), "w") as f:
        json.dump(records, f, indent=1)
    write_page(args, records)
    bad = [r for r in records if not r["outputs_finite"]
           or (r["exit"] == 0) != r["completed"] or (r["exit"] != 0 and not r["message"])]
    for r in bad:
        print(f"INCONSISTENT: {r}")
    return 1 if bad else 0


def write_page(args, records):
    lines = [
        "# Stability report",
        "",
        f"The fusiform muscle, {args.case} contraction, refinement n = 1, Q1 hexahedra, 0 to "
        "0.15 s, at the extremes. Every run either converges (possibly after halving its "
        "time step: *cutbacks*) or stops with a message and a nonzero exit status, having "
        "written its last converged state; no output file holds a NaN (checked for each "
        "run). For a stopped run, epsilon and dV are those of the last converged state, and the "
        "Newton iterations and cutbacks include the failed attempts. Regenerate with",
        "",
        "```sh",
        "/usr/bin/python3 demos/fusiform/stability_report.py   # writes this page",
        "```",
        "",
        "| model | extreme | outcome | steps | Newton its | cutbacks | epsilon | dV [%] | "
        "wall [s] |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in records:
        outcome = "converged" if r["completed"] else f"stopped (exit {r['exit']})"
        eps = f"{r['epsilon']:.4f}" if r["epsilon"] is not None else "-"
        dv = f"{100 * r['volume_change']:.2f}" if r["volume_change"] is not None else "-"
        lines.append(f"| {NAMES[r['model']]} | {r['extreme']} | {outcome} | {r['steps']} | "
                     f"{r['newton']} | {r['cutbacks']} | {eps} | {dv} | {r['wall']:.0f} |")
    failures = [r for r in records if not r["completed"]]
    if failures:
        lines += ["", "Messages of the runs that stopped:", ""]
        for r in failures:
            lines.append(f"* {NAMES[r['model']]}, {r['extreme']}: `{r['message']}`")
    lines += ["", "Options of each extreme (added to `fusiform --model M --case "
              f"{args.case} --refinement 1`):", ""]
    seen = set()
    for r in records:
        key = (r["extreme"], r["options"] if "kappa" not in r["options"] else r["model"])
        if key in seen:
            continue
        seen.add(key)
        lines.append(f"* {r['extreme']} ({NAMES[r['model']]}): `{r['options']}`")
    os.makedirs(os.path.dirname(args.doc), exist_ok=True)
    with open(args.doc, "w") as f:
        f.write("\n".join(lines) + "\n")
    print(f"wrote {args.doc}")


if __name__ == "__main__":
    sys.exit(main())
