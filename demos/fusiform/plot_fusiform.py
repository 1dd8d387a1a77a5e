#!/usr/bin/python3
"""Muscle force F33(t) (isometric) and stretch ratio epsilon(t) (free) of fusiform runs,
like the paper's figure fusiform_plot_iso_free.

    plot_fusiform.py OUTPUT.png "LABEL=series.csv" ...

A label containing "isometric" goes to the force panel, one containing "free" to the
stretch-ratio panel; the first word of the label (ble, wkm, giant, combi) picks the colour.
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

COLOURS = {"ble": "tab:blue", "wkm": "tab:orange", "giant": "tab:green", "combi": "tab:red"}
NAMES = {"ble": "BLE", "wkm": "WKM", "giant": "GIANT", "combi": "COMBI"}


def read(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return {k: [float(r[k]) for r in rows] for k in rows[0]} if rows else None


def main(output, series):
    panels = []
    if any("isometric" in label for label, _ in series):
        panels.append(("isometric", "F33", "muscle force $F_{33}$ [mN]"))
    if any("free" in label for label, _ in series):
        panels.append(("free", "epsilon", r"stretch ratio $\epsilon$ [-]"))
    fig, axes = plt.subplots(1, len(panels), figsize=(5.2 * len(panels), 3.8), squeeze=False)
    for ax, (kind, column, ylabel) in zip(axes.flat, panels):
        for label, path in series:
            if kind not in label:
                continue
            data = read(path)
            if data is None:
                continue
            model = label.split()[0]
            ax.plot([0.0] + data["t"], [0.0 if column == "F33" else 1.0] + data[column],
                    color=COLOURS.get(model, "k"), label=NAMES.get(model, model), lw=1.4)
        ax.set_xlabel("time $t$ [s]")
        ax.set_ylabel(ylabel)
        ax.set_title(f"{kind} contraction")
        ax.grid(alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(frameon=False)
    fig.tight_layout()
    fig.savefig(output, dpi=130)


if __name__ == "__main__":
    main(sys.argv[1], [tuple(a.split("=", 1)) for a in sys.argv[2:]])
