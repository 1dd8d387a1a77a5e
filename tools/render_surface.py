#!/usr/bin/python3
"""Render deformed muscle surfaces (surface.json written by the demos) side by
side, coloured by the cell value they carry (the fibre stretch), with one shared
colour scale -- a picture without ParaView.

    render_surface.py OUTPUT.png "TITLE=run/surface.json" ... [--label "fibre stretch"]
        [--field NAME] [--upright] [--view ELEV,AZIM] [--highlight] [--max V]
        [--box X0,X1,Y0,Y1,Z0,Z1]

--field colours by one of the surface's named fields (scenes write the post
fields, and contact_pressure / contact_gap with contact) instead of the fibre
stretch; --upright keeps z up (scenes) instead of laying the muscle axis
horizontal; --highlight draws facets whose value is zero faintly, so that a
contact patch shows through the body lying over it; --max ends the colour scale at V
(larger values in its top colour: stiff bones beside soft muscle); --box keeps the
facets whose centre lies in the box (reference coordinates, mm): a close look at a joint.
"""
import argparse
import json

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402


def load(path, field=None, upright=False, box=None):
    """Facets and their values (those in `box` only, if given); unless upright, the
    muscle axis (e3) is turned horizontal: plot (x, y, z) = (z, x, y)."""
    with open(path) as f:
        data = json.load(f)
    if field is None:
        values = data["values"]
    elif field in data.get("fields", {}):
        values = data["fields"][field]
    else:
        raise SystemExit(f"error: {path} has no field '{field}'; it has: "
                         + ", ".join(sorted(data.get("fields", {}))))
    facets, values = [np.asarray(p) for p in data["facets"]], np.asarray(values)
    if box is not None:
        inside = [k for k, f in enumerate(facets)
                  if all(box[2 * d] <= f[:, d].mean() <= box[2 * d + 1] for d in range(3))]
        if not inside:
            raise SystemExit(f"error: --box {box}: no facet of {path} in it")
        facets, values = [facets[k] for k in inside], values[inside]
    axes = [0, 1, 2] if upright else [2, 0, 1]
    return [f[:, axes] for f in facets], values


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("output")
    parser.add_argument("surfaces", nargs="+", help="TITLE=surface.json (split at the last =)")
    parser.add_argument("--label", default=r"fibre stretch $\lambda$")
    parser.add_argument("--field", help="a named field of surface.json (default: fibre stretch)")
    parser.add_argument("--upright", action="store_true", help="keep z up")
    parser.add_argument("--view", default="20,-80", help="elevation,azimuth in degrees")
    parser.add_argument("--highlight", action="store_true",
                        help="draw facets with value 0 faint (a contact patch shows through)")
    parser.add_argument("--max", type=float, help="upper end of the colour scale")
    parser.add_argument("--box", help="X0,X1,Y0,Y1,Z0,Z1: only the facets in this box")
    args = parser.parse_args()
    box = [float(v) for v in args.box.split(",")] if args.box else None
    if box is not None and len(box) != 6:
        raise SystemExit("error: --box takes six numbers X0,X1,Y0,Y1,Z0,Z1")
    elev, azim = (float(v) for v in args.view.split(","))

    panels = [(s.rsplit("=", 1)[0], load(s.rsplit("=", 1)[1], args.field, args.upright, box))
              for s in args.surfaces]
    values = np.concatenate([v for _, (_, v) in panels])
    norm = matplotlib.colors.Normalize(vmin=values.min(),
                                       vmax=values.max() if args.max is None else args.max,
                                       clip=True)
    cmap = plt.get_cmap("viridis")
    # one light direction so that the spindle reads as a solid
    light = np.array([0.4, -0.8, 0.45])
    light /= np.linalg.norm(light)

    points = np.concatenate([np.concatenate(f) for _, (f, _) in panels])
    low, high = points.min(axis=0), points.max(axis=0)
    # long muscles lie in rows, upright bodies stand side by side
    rows, cols = (1, len(panels)) if args.upright else (len(panels), 1)
    fig = plt.figure(figsize=(3 * cols + 1, 6) if args.upright else (9, 2.6 * rows))
    for i, (title, (facets, vals)) in enumerate(panels):
        ax = fig.add_subplot(rows, cols, i + 1, projection="3d")
        colours = cmap(norm(vals))
        shade = []
        for quad in facets:
            n = np.cross(quad[1] - quad[0], quad[2] - quad[0])
            length = np.linalg.norm(n)
            shade.append(0.55 + 0.45 * abs(n @ light) / length if length > 0 else 1.0)
        colours[:, :3] *= np.asarray(shade)[:, None]
        if args.highlight:
            faint = vals == 0
            colours[faint] = (0.6, 0.6, 0.6, 0.06)
            # the patch last, so that it is drawn over the faint body
            order = np.argsort(~faint, kind="stable")
            facets = [facets[k] for k in order]
            colours = colours[order]
        ax.add_collection3d(Poly3DCollection(facets, facecolors=colours, edgecolors="none"))
        # equal scaling, the same box for every panel so sizes compare
        for setter, lo, hi in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), low, high):
            setter(lo, hi)
        ax.set_box_aspect(high - low, zoom=1.1)
        ax.view_init(elev=elev, azim=azim)
        ax.set_axis_off()
        ax.set_title(title, fontsize=10)
    if args.upright:
        fig.subplots_adjust(left=0, right=0.86, wspace=0, top=0.95, bottom=0.02)
    else:
        fig.subplots_adjust(left=-0.1, right=0.95, hspace=0, top=0.95, bottom=0.02)
    bar = fig.add_axes([0.88, 0.15, 0.02, 0.7])
    fig.colorbar(matplotlib.cm.ScalarMappable(norm=norm, cmap=cmap), cax=bar,
                 label=args.label, extend="neither" if args.max is None else "max")
    fig.savefig(args.output, dpi=130, bbox_inches="tight")
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
