#!/usr/bin/python3
"""Grid of stress-stretch curves, one panel per load case (like the paper's figures
fitting_passive / fitting_all_active): P_exact as lines, P_paper dashed, P_fe as markers.

    plot_loadcases.py MANIFEST.json OUTPUT.png
"""
import csv
import json
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

ORDER = ["UTCAF", "PSAF", "SAF", "UTCTF", "PSTF", "PSTIF"]
COLOURS = {"ble": "tab:blue", "wkm": "tab:orange", "giant": "tab:green", "combi": "tab:red"}
LABELS = {"ble": "BLE", "wkm": "WKM", "giant": "GIANT", "combi": "COMBI"}


def read(path):
    columns = {"stretch": [], "P_exact": [], "P_paper": [], "P_fe": []}
    with open(path) as f:
        for row in csv.DictReader(f):
            for key in columns:
                columns[key].append(float(row[key]) if row[key] != "" else float("nan"))
    return columns


def main(manifest_path, output):
    manifest = json.load(open(manifest_path))
    curves = manifest["curves"]
    cases = [c for c in ORDER if any(curve["case"] == c for curve in curves)]
    ncols = min(3, len(cases))
    nrows = (len(cases) + ncols - 1) // ncols
    fig, axes = plt.subplots(nrows, ncols, figsize=(4.2 * ncols, 3.4 * nrows), squeeze=False)
    for ax, case in zip(axes.flat, cases):
        for curve in (c for c in curves if c["case"] == case):
            data = read(curve["csv"])
            colour = COLOURS.get(curve["model"], "k")
            label = LABELS.get(curve["model"], curve["model"])
            ax.plot(data["stretch"], data["P_exact"], "-", color=colour, label=f"{label} exact")
            if any(v == v for v in data["P_paper"]):
                ax.plot(data["stretch"], data["P_paper"], "--", color="k", lw=0.8)
            if any(v == v for v in data["P_fe"]):
                ax.plot(data["stretch"], data["P_fe"], "o", color=colour, ms=3.5, mfc="none")
        ax.set_title(case)
        ax.set_xlabel("shear" if case == "SAF" else "stretch")
        ax.set_ylabel("nominal stress [kPa]")
        ax.axhline(0, color="0.7", lw=0.5)
        ax.grid(alpha=0.3)
    for ax in list(axes.flat)[len(cases):]:
        ax.axis("off")
    handles, labels = axes.flat[0].get_legend_handles_labels()
    handles += [plt.Line2D([], [], ls="--", color="k", lw=0.8),
                plt.Line2D([], [], ls="", marker="o", mfc="none", color="0.3")]
    labels += ["paper closed form", "FE, one hexahedron"]
    fig.legend(handles, labels, loc="lower center", ncol=min(6, len(labels)), frameon=False)
    fig.suptitle(f"{manifest['state']} muscle: lines exact, dashed paper, markers FE")
    fig.tight_layout(rect=(0, 0.07, 1, 0.96))
    fig.savefig(output, dpi=130)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
