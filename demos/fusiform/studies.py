#!/usr/bin/python3
"""The fusiform studies of the paper, each a command that reruns the demo and
regenerates its table (Markdown + CSV) and PNG.

    studies.py compare   [--refinement N] [--models ...]  F33(t), epsilon(t) of the four models
    studies.py mesh      [--refinements 1 2 4]            F33, epsilon at t_end against n
    studies.py penalty   [--scales ...]                   volume change, condition number against s
    studies.py locking                                    Q1 n = 1, 2 against Q2 n = 1

Common options: --build DIR (where the fusiform binary is), --out DIR, --np N
(MPI ranks), --reuse (keep runs whose summary.json says completed), and
--extra "..." (more fusiform options, e.g. "--t-end 0.05").
Every run writes its own directory under --out; the tables name them.
"""
import argparse
import csv
import json
import os
import shlex
import subprocess
import sys
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
MODELS = ["ble", "wkm", "giant", "combi"]
NAMES = {"ble": "BLE", "wkm": "WKM", "giant": "GIANT", "combi": "COMBI"}
COLOURS = {"ble": "tab:blue", "wkm": "tab:orange", "giant": "tab:green", "combi": "tab:red"}
# The paper's reference penalties (section "Influence of the incompressibility")
KAPPA_REF = {"ble": 10000.0, "wkm": 1000.0, "giant": 1000.0, "combi": 1000.0}


def read_summary(path):
    """summary.json with its final series values (F33, epsilon, ...) at the top level."""
    with open(path) as f:
        summary = json.load(f)
    return {**summary, **summary.get("final", {})}


def run(args, name, options):
    """Run the demo once into OUT/name; return its summary (and the series)."""
    out = os.path.join(args.out, name)
    summary_path = os.path.join(out, "summary.json")
    if args.reuse and os.path.exists(summary_path):
        summary = read_summary(summary_path)
        if summary.get("completed"):
            print(f"  reuse {out}")
            return summary, read_series(out)
    # the state at t_end of a quasi-static hyperelastic run does not depend on the
    # path: studies of end values take large steps unless --dt is given
    extra = shlex.split(args.extra)
    if args.study != "compare":
        extra += ["--no-fields"] + ([] if "--dt" in extra else ["--dt", "0.05"])
    command = [os.path.join(args.build, "fusiform"), *options, "--out", out, "--quiet",
               *extra]
    if args.np > 1:
        command = ["mpirun", "--allow-run-as-root", "--oversubscribe", "-n", str(args.np),
                   *command]
    print("  " + " ".join(command), flush=True)
    start = time.time()
    result = subprocess.run(command, capture_output=True, text=True)
    if result.returncode != 0:
        print(f"    failed ({result.returncode}): {result.stderr.strip()[-600:]}", flush=True)
    print(f"    {time.time() - start:.1f} s", flush=True)
    if not os.path.exists(summary_path):
        return {"completed": False}, None
    return read_summary(summary_path), read_series(out)


def read_series(out):
    path = os.path.join(out, "series.csv")
    if not os.path.exists(path):
        return None
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return {k: [float(r[k]) for r in rows] for k in rows[0]} if rows else None


def save(fig, args, name):
    fig.tight_layout()
    png = os.path.join(args.out, name)
    fig.savefig(png, dpi=130)
    print(f"wrote {png}")


def write_table(path, header, rows):
    """Write OUT/path.csv and OUT/path.md and print the Markdown."""
    with open(path + ".csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        w.writerows(rows)
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    with open(path + ".md", "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))


def fmt(x, spec):
    return "-" if x is None else format(x, spec)


def compare(args):
    """Paper figure fusiform_plot_iso_free: F33(t) isometric, epsilon(t) free."""
    rows, series = [], {}
    for model in args.models:
        for case in ("isometric", "free"):
            s, data = run(args, f"{model}_{case}_n{args.refinement}",
                          ["--model", model, "--case", case,
                           "--refinement", str(args.refinement)])
            series[(model, case)] = data
            rows.append([NAMES[model], case, fmt(s.get("F33") if case == "isometric" else None,
                                                 ".1f"),
                         fmt(s.get("epsilon") if case == "free" else None, ".4f"),
                         s.get("steps", "-"), s.get("newton_iterations", "-"),
                         s.get("cutbacks", "-"), fmt(s.get("wall_time"), ".1f"),
                         "yes" if s.get("completed") else "NO"])
    write_table(os.path.join(args.out, f"compare_n{args.refinement}"),
                ["model", "case", "F33 [mN]", "epsilon", "steps", "Newton its", "cutbacks",
                 "wall [s]", "completed"], rows)
    fig, axes = plt.subplots(1, 2, figsize=(10.4, 3.8))
    for (model, case), data in series.items():
        if data is None:
            continue
        ax, column, start = (axes[0], "F33", 0.0) if case == "isometric" else \
            (axes[1], "epsilon", 1.0)
        scale = 1e-3 if column == "F33" else 1.0
        ax.plot([0.0] + data["t"], [start] + [v * scale for v in data[column]],
                color=COLOURS[model], label=NAMES[model], lw=1.4)
    axes[0].set_ylabel("muscle force $F_{33}$ [N]")
    axes[0].set_title("isometric contraction")
    axes[1].set_ylabel(r"stretch ratio $\epsilon$ [-]")
    axes[1].set_title("free contraction")
    for ax in axes:
        ax.set_xlabel("time $t$ [s]")
        ax.grid(alpha=0.3)
        ax.legend(frameon=False)
    fig.suptitle(f"fusiform muscle, n = {args.refinement}")
    save(fig, args, f"compare_n{args.refinement}.png")


def mesh(args):
    """Paper figure resolution_influence: F33 and epsilon at t_end against n."""
    results = {}
    for model in args.models:
        for case in ("isometric", "free"):
            for n in args.refinements:
                s, _ = run(args, f"{model}_{case}_n{n}",
                           ["--model", model, "--case", case, "--refinement", str(n)])
                results[(model, case, n)] = s
    rows = []
    for model in args.models:
        for case, key in (("isometric", "F33"), ("free", "epsilon")):
            values = [results[(model, case, n)].get(key) if results[(model, case, n)]
                      .get("completed") else None for n in args.refinements]
            first, last = values[0], values[-1]
            change = abs(last - first) / abs(last) * 100 if first and last else None
            rows.append([NAMES[model], key] + [fmt(v, ".5g") for v in values]
                        + [fmt(change, ".2f")]
                        + [fmt(results[(model, case, n)].get("wall_time"), ".0f")
                           for n in args.refinements])
    n_labels = [f"n={n}" for n in args.refinements]
    write_table(os.path.join(args.out, "mesh_study"),
                ["model", "quantity"] + n_labels
                + [f"change n={args.refinements[0]}..{args.refinements[-1]} [%]"]
                + [f"wall {n} [s]" for n in n_labels], rows)
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.6))
    for model in args.models:
        for ax, case, key, scale in ((axes[0], "isometric", "F33", 1e-3),
                                     (axes[1], "free", "epsilon", 1.0)):
            ns = [n for n in args.refinements if results[(model, case, n)].get("completed")]
            ax.plot(ns, [results[(model, case, n)][key] * scale for n in ns], "o-",
                    color=COLOURS[model], label=NAMES[model])
    axes[0].set_ylabel("$F_{33}$ at $t_{end}$ [N]")
    axes[1].set_ylabel(r"$\epsilon$ at $t_{end}$ [-]")
    for ax in axes:
        ax.set_xlabel("refinement n")
        ax.set_xticks(args.refinements)
        ax.grid(alpha=0.3)
        ax.legend(frameon=False)
    save(fig, args, "mesh_study.png")


def penalty(args):
    """Paper figure incomp_influence: volume change and condition number against s."""
    results = {}
    for model in args.models:
        for case in ("isometric", "free"):
            for s in args.scales:
                kappa = KAPPA_REF[model] * s
                summary, _ = run(args, f"{model}_{case}_kappa{s:g}",
                                 ["--model", model, "--case", case, "--refinement", "1",
                                  "--set", f"kappa={kappa:g}", "--condition-number"])
                results[(model, case, s)] = summary
    rows = []
    for (model, case, s), r in results.items():
        rows.append([NAMES[model], case, f"{s:g}", f"{KAPPA_REF[model] * s:g}",
                     fmt(r.get("volume_change", None) and 100 * r["volume_change"], ".2f"),
                     fmt(r.get("condition_number"), ".3g"), r.get("cutbacks", "-"),
                     "yes" if r.get("completed") else "NO"])
    write_table(os.path.join(args.out, "penalty_study"),
                ["model", "case", "s", "kappa", "dV at t_end [%]", "cond(K)", "cutbacks",
                 "completed"], rows)
    fig, axes = plt.subplots(2, 2, figsize=(10, 7), sharex=True)
    for j, case in enumerate(("isometric", "free")):
        for model in args.models:
            ss = [s for s in args.scales if results[(model, case, s)].get("completed")]
            axes[0, j].semilogx(ss, [100 * results[(model, case, s)]["volume_change"]
                                     for s in ss], "o-", color=COLOURS[model],
                                label=NAMES[model])
            cs = [s for s in ss if results[(model, case, s)].get("condition_number")]
            axes[1, j].loglog(cs, [results[(model, case, s)]["condition_number"] for s in cs],
                              "o-", color=COLOURS[model], label=NAMES[model])
        axes[0, j].axhspan(-5, 5, color="0.9", zorder=0)
        axes[0, j].set_title(f"{case} contraction")
        axes[0, j].set_ylabel(r"$\Delta V$ at $t_{end}$ [%]")
        axes[1, j].set_ylabel("condition number of K")
        axes[1, j].set_xlabel(r"penalty scale $s$ ($\kappa = s\,\kappa_{ref}$)")
        for ax in axes[:, j]:
            ax.grid(alpha=0.3, which="both")
            ax.legend(frameon=False)
    save(fig, args, "penalty_study.png")


def locking(args):
    """Q1 against Q2 (locking-free choice), both against a fine Q2 reference."""
    results = {}
    # Q2 at n = 2 (about 400k unknowns) is beyond a 2-core budget: the reference
    # is Q2 at n = 1, which the mesh study shows to be converged where Q1 is not.
    variants = [("Q1", ["--degree", "1", "--no-fbar"], 1), ("Q1", ["--degree", "1", "--no-fbar"], 2),
                ("Q2 reference", ["--degree", "2"], 1)]
    for model in args.models:
        for case in ("isometric", "free"):
            for label, options, n in variants:
                name = f"{model}_{case}_{label.split()[0].lower()}_n{n}"
                summary, _ = run(args, name, ["--model", model, "--case", case,
                                              "--refinement", str(n), *options])
                results[(model, case, label, n)] = summary
    rows = []
    for model in args.models:
        for case, key in (("isometric", "F33"), ("free", "epsilon")):
            ref = results[(model, case, "Q2 reference", 1)]
            ref_value = ref.get(key) if ref.get("completed") else None
            for label, _, n in variants[:-1]:
                r = results[(model, case, label, n)]
                value = r.get(key) if r.get("completed") else None
                err = abs(value - ref_value) / abs(ref_value) * 100 \
                    if value is not None and ref_value else None
                rows.append([NAMES[model], key, f"{label} n={n}", fmt(value, ".5g"),
                             fmt(ref_value, ".5g"), fmt(err, ".2f"),
                             fmt(r.get("wall_time"), ".0f")])
    write_table(os.path.join(args.out, "locking_study"),
                ["model", "quantity", "discretisation", "value", "Q2 n=1 reference",
                 "error [%]", "wall [s]"], rows)


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("study", choices=["compare", "mesh", "penalty", "locking"])
    parser.add_argument("--build", default=os.path.join(ROOT, "build"))
    parser.add_argument("--out", default=os.path.join(ROOT, "out", "fusiform"))
    parser.add_argument("--models", nargs="+", default=MODELS, choices=MODELS)
    parser.add_argument("--refinement", type=int, default=1)
    parser.add_argument("--refinements", type=int, nargs="+", default=[1, 2, 4])
    parser.add_argument("--scales", type=float, nargs="+",
                        default=[0.001, 0.003, 0.01, 0.1, 1, 10])
    parser.add_argument("--np", type=int, default=1)
    parser.add_argument("--reuse", action="store_true")
    parser.add_argument("--extra", default="")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    {"compare": compare, "mesh": mesh, "penalty": penalty, "locking": locking}[args.study](args)


if __name__ == "__main__":
    sys.exit(main())
