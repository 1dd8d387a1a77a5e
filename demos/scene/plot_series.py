#!/usr/bin/python3
"""Every series quantity of a muscle-run output against time, one panel each.

    plot_series.py OUTPUT.png series.csv [TITLE] [--columns NAME,NAME,...]

--columns: these quantities only, in this order.
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

SOLVER_COLUMNS = {"newton_iterations", "linear_iterations", "cutbacks", "residual", "wall_time"}


def main(output, path, title="", columns=None):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    if not rows:
        return
    quantities = [k for k in rows[0] if k != "t" and k not in SOLVER_COLUMNS]
    if columns:
        unknown = [c for c in columns if c not in quantities]
        if unknown:
            sys.exit(f"--columns: {', '.join(unknown)} not in {path} (it has {', '.join(quantities)})")
        quantities = columns
    t = [float(r["t"]) for r in rows]
    fig, axes = plt.subplots(len(quantities) + 1, 1, sharex=True,
                             figsize=(6, 1.8 * (len(quantities) + 1)), squeeze=False)
    for ax, q in zip(axes[:, 0], quantities):
        ax.plot(t, [float(r[q]) for r in rows], marker=".", markersize=3)
        ax.set_ylabel(q)
        ax.grid(alpha=0.3)
    ax = axes[-1, 0]
    ax.bar(t, [int(r["newton_iterations"]) for r in rows], width=0.8 * (t[1] - t[0]) if len(t) > 1 else 0.01)
    ax.set_ylabel("Newton its")
    ax.set_xlabel("t [s]")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(output, dpi=120)


if __name__ == "__main__":
    args = sys.argv[1:]
    columns = None
    if "--columns" in args:
        i = args.index("--columns")
        columns = args[i + 1].split(",") if i + 1 < len(args) else []
        del args[i:i + 2]
    if len(args) not in (2, 3):
        sys.exit(__doc__)
    main(*args, columns=columns)
