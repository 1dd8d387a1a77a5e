#!/usr/bin/python3
"""Hertz contact under mesh refinement: demos/scenes/hertz.yaml with the element size
of the contact zone (mesh.set.fine, mm) halved step by step; contact radius sqrt(A/pi)
and largest facet-mean pressure against Hertz's formulas for the measured force.

    demos/scene/hertz_refinement.py [--build build] [--out out/hertz_refinement]
        [--fine 0.5 0.35 0.25 0.18]

Prints a Markdown table and writes OUT/hertz_refinement.json.
"""
import argparse
import json
import math
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "tests", "support"))
from checks import series_rows  # noqa: E402


def hertz(F, R, E, nu):
    """Two equal bodies: 1/E* = 2 (1 - nu^2) / E."""
    E_star = E / (2 * (1 - nu**2))
    a = (3 * F * R / (4 * E_star)) ** (1 / 3)
    return a, 3 * F / (2 * math.pi * a * a)


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--build", default="build")
    parser.add_argument("--out", default="out/hertz_refinement")
    parser.add_argument("--fine", type=float, nargs="+", default=[0.5, 0.35, 0.25, 0.18])
    args = parser.parse_args()
    scene = os.path.join(HERE, "..", "scenes", "hertz.yaml")
    rows = []
    for fine in args.fine:
        out = os.path.join(args.out, f"fine_{fine}")
        start = time.time()
        r = subprocess.run([os.path.join(args.build, "muscle-run"), scene, "--out", out,
                            "--quiet", "--set", "output.fields=false", "--set", f"mesh.set.fine={fine}"],
                           capture_output=True, text=True)
        wall = time.time() - start
        if r.returncode != 0:
            sys.exit(f"fine = {fine}: muscle-run failed (exit {r.returncode}): {r.stderr}")
        last = series_rows(out)[-1]
        with open(os.path.join(out, "summary.json")) as f:
            nodes = json.load(f)["nodes"]
        a, p0 = hertz(last["contact_force"], 10.0, 1000.0, 0.3)
        radius = math.sqrt(last["contact_area"] / math.pi)
        rows.append({"fine": fine, "nodes": nodes, "force": last["contact_force"],
                     "radius": radius, "hertz_radius": a, "pressure": last["max_pressure"],
                     "hertz_pressure": p0, "radius_error": radius / a - 1,
                     "pressure_error": last["max_pressure"] / p0 - 1, "wall": wall})
        print(f"fine {fine}: done in {wall:.0f} s", file=sys.stderr)
    print("| contact-zone element (mm) | nodes | force (mN) | contact radius: FE / Hertz "
          "| peak pressure: FE / Hertz | wall (s) |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['fine']} | {r['nodes']:,} | {r['force']:.1f} | {r['radius']:.3f} / "
              f"{r['hertz_radius']:.3f} mm ({100 * r['radius_error']:+.1f} %) | "
              f"{r['pressure']:.1f} / {r['hertz_pressure']:.1f} kPa "
              f"({100 * r['pressure_error']:+.1f} %) | {r['wall']:.0f} |")
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "hertz_refinement.json"), "w") as f:
        json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
