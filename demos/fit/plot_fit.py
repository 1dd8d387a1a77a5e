#!/usr/bin/python3
"""Data points and fitted P_exact curves of a parameter fit, one panel per load case
(passive blue, active red).

    plot_fit.py fit_points.csv fit_curves.csv OUTPUT.png [TITLE]
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

ORDER = ["UTCAF", "PSAF", "SAF", "UTCTF", "PSTF", "PSTIF"]
COLOURS = {"passive": "tab:blue", "active": "tab:red"}


def read(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def main(points_path, curves_path, output, title=""):
    points, curves = read(points_path), read(curves_path)
    cases = [c for c in ORDER if any(p["case"] == c for p in points)]
    ncols = min(3, len(cases))
    nrows = (len(cases) + ncols - 1) // ncols
    fig, axes = plt.subplots(nrows, ncols, figsize=(4.2 * ncols, 3.4 * nrows), squeeze=False)
    for ax, case in zip(axes.flat, cases):
        for state, colour in COLOURS.items():
            p = [r for r in points if r["case"] == case and r["state"] == state]
            c = [r for r in curves if r["case"] == case and r["state"] == state]
            if not p:
                continue
            ax.plot([float(r["stretch"]) for r in c], [float(r["P_exact"]) for r in c],
                    "-", color=colour, label=f"{state}: fitted P_exact")
            ax.plot([float(r["stretch"]) for r in p], [float(r["stress"]) for r in p],
                    "o", color=colour, mfc="none", label=f"{state}: data")
        ax.set_title(case)
        ax.set_xlabel("shear" if case == "SAF" else "stretch")
        ax.set_ylabel("nominal stress [kPa]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    for ax in list(axes.flat)[len(cases):]:
        ax.axis("off")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(output, dpi=110)


if __name__ == "__main__":
    main(*sys.argv[1:])
