#!/usr/bin/python3
"""Render deformed muscle surfaces (surface.json written by the demos) side by
side, coloured by the cell value they carry (the fibre stretch), with one shared
colour scale -- a picture without ParaView.

    render_surface.py OUTPUT.png "TITLE=run/surface.json" ... [--label "fibre stretch"]
"""
import argparse
import json

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402


def load(path):
    """Facets with the muscle axis (e3) turned horizontal: plot (x, y, z) = (z, x, y)."""
    with open(path) as f:
        data = json.load(f)
    return [np.asarray(p)[:, [2, 0, 1]] for p in data["facets"]], np.asarray(data["values"])


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("output")
    parser.add_argument("surfaces", nargs="+", help="TITLE=surface.json (split at the last =)")
    parser.add_argument("--label", default=r"fibre stretch $\lambda$")
    args = parser.parse_args()

    panels = [(s.rsplit("=", 1)[0], load(s.rsplit("=", 1)[1])) for s in args.surfaces]
    values = np.concatenate([v for _, (_, v) in panels])
    norm = matplotlib.colors.Normalize(vmin=values.min(), vmax=values.max())
    cmap = plt.get_cmap("viridis")
    # one light direction so that the spindle reads as a solid
    light = np.array([0.4, -0.8, 0.45])
    light /= np.linalg.norm(light)

    points = np.concatenate([np.concatenate(f) for _, (f, _) in panels])
    low, high = points.min(axis=0), points.max(axis=0)
    fig = plt.figure(figsize=(9, 2.6 * len(panels)))
    for i, (title, (facets, vals)) in enumerate(panels):
        ax = fig.add_subplot(len(panels), 1, i + 1, projection="3d")
        colours = cmap(norm(vals))
        shade = []
        for quad in facets:
            n = np.cross(quad[1] - quad[0], quad[2] - quad[0])
            length = np.linalg.norm(n)
            shade.append(0.55 + 0.45 * abs(n @ light) / length if length > 0 else 1.0)
        colours[:, :3] *= np.asarray(shade)[:, None]
        ax.add_collection3d(Poly3DCollection(facets, facecolors=colours, edgecolors="none"))
        # equal scaling, the same box for every panel so sizes compare
        for setter, lo, hi in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), low, high):
            setter(lo, hi)
        ax.set_box_aspect(high - low, zoom=1.1)
        ax.view_init(elev=20, azim=-80)
        ax.set_axis_off()
        ax.set_title(title, fontsize=10)
    fig.subplots_adjust(left=-0.1, right=0.95, hspace=0, top=0.95, bottom=0.02)
    bar = fig.add_axes([0.88, 0.15, 0.02, 0.7])
    fig.colorbar(matplotlib.cm.ScalarMappable(norm=norm, cmap=cmap), cax=bar,
                 label=args.label)
    fig.savefig(args.output, dpi=130, bbox_inches="tight")
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
