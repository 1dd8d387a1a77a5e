"""Phase taylor-hood of run_benchmarks.py: the Taylor-Hood element (Q2-Q1) against plain Q2
on the bending-dominated, nearly incompressible cantilever under follower pressure
(demos/scenes/cantilever_pressure.yaml, lambda / mu = 1000, tip -0.41 L), by refinement:
tip deflection, wall time, Newton iterations, unknowns; the Schur split's and the stars
split's (the muscle's best) Krylov iterations against lambda / mu (9 ... 9999, through
Poisson's ratio) and the mesh, over the first three load steps; and the two splits side by
side by refinement up to 152,709 unknowns over the first two.  Runs go to WORK/taylor_hood/NAME (summary.json, series.csv,
time.txt, record.json); --reuse keeps completed ones."""
import glob
import json
import os

import stiffsoft
from report import KAPPA_CANDIDATES, STARS_CANDIDATE
from stiffsoft import ROOT

SCENE = os.path.join(ROOT, "demos", "scenes", "cantilever_pressure.yaml")
TAYLOR_HOOD = ["element.degree=2", "element.taylor_hood=true"]
# element: (scene keys, refinements); Q2 locks mildly, so it needs the finer meshes
ELEMENTS = {"Q2": (["element.degree=2"], (1, 2, 3)),
            "Q2TH": (TAYLOR_HOOD, (1, 2, 3)),
            "Q2TH-schur": (TAYLOR_HOOD + ["solver.linear=gmres-schur"], (1, 2))}
# the plain split against p-multigrid relaxing Q2 on vertex stars (the kappa phase's
# candidate of that name, the muscle's best), over the first two load steps by refinement
ELEMENTS["Q2TH-schur-stars"] = (
    TAYLOR_HOOD + ["solver.linear=gmres-schur",
                   "solver.petsc=" + " ".join(KAPPA_CANDIDATES[STARS_CANDIDATE][1])], ())
SPLITS = ("Q2TH-schur", "Q2TH-schur-stars")
SPLIT_REFINEMENTS = (1, 2, 4)
SPLIT_END = 0.2
# Poisson's ratio of the lambda / mu sweep: 2 nu / (1 - 2 nu) = 9, 99, 999 (the scene's),
# 9999; the first three of the ten load steps (tip -0.13 L)
SWEEP_NU = (0.45, 0.495, 0.4995, 0.49995)
# per split: the stars' third mesh would take about 12 minutes more
SWEEP_REFINEMENTS = {"Q2TH-schur": (1, 2, 3), "Q2TH-schur-stars": (1, 2)}
SWEEP_END = 0.3


def tip(out):
    """The last row's tip_z of a run's series.csv, or None."""
    path = os.path.join(out, "series.csv")
    if not os.path.exists(path):
        return None
    with open(path) as f:
        lines = [line.strip().split(",") for line in f if line.strip()]
    row = dict(zip(lines[0], lines[-1]))
    return float(row["tip_z"]) if len(lines) > 1 else None


def solver_of(element):
    return "gmres-schur" if "schur" in element else "lu"


def run(args, records, study, element, refinement, name, sets=(), extra=None):
    """One cantilever run of `element` at `refinement` with further scene keys `sets`."""
    r = stiffsoft.run(args, study, None, SCENE,
                      ELEMENTS[element][0] + [f"mesh.set.refinement={refinement}", *sets,
                                              "output.fields=false", "output.plots=false"],
                      name, {"element": element, "refinement": refinement,
                             "solver": solver_of(element), **(extra or {})},
                      timeout=2400, folder="taylor_hood")
    r["tip_z"] = tip(os.path.join(args.work, "taylor_hood", name)) or r.get("tip_z")
    records.put("taylor_hood", r["name"], r)


def phase(args, records, parts=("elements", "splits", "sweep")):
    if "elements" in parts:
        for element, (_, refinements) in ELEMENTS.items():
            for refinement in refinements:
                run(args, records, "cantilever", element, refinement,
                    f"cantilever_{element}_r{refinement}")
    if "splits" in parts:
        for refinement in SPLIT_REFINEMENTS:
            for element in SPLITS:
                run(args, records, "cantilever_split", element, refinement,
                    f"cantilever_{element}_r{refinement}_t{SPLIT_END:g}",
                    [f"time.end={SPLIT_END:g}"])
    if "sweep" not in parts:
        return
    for element, refinements in SWEEP_REFINEMENTS.items():
        for refinement in refinements:
            for nu in SWEEP_NU:
                run(args, records, "cantilever_sweep", element, refinement,
                    f"cantilever_{element}_r{refinement}_nu{nu:g}_t{SWEEP_END:g}",
                    [f"parts[0].material.parameters.nu={nu:g}", f"time.end={SWEEP_END:g}"],
                    {"nu": nu, "lambda_over_mu": 2 * nu / (1 - 2 * nu)})


def collect(work):
    """The records of this phase in WORK, by name."""
    out = {}
    for path in sorted(glob.glob(os.path.join(work, "taylor_hood", "*", "record.json"))):
        with open(path) as f:
            r = json.load(f)
        # a record restored from results.json has no series.csv beside it
        r["tip_z"] = tip(os.path.dirname(path)) or r.get("tip_z")
        r["solver"] = solver_of(r["element"])  # records written before it was kept
        out[r["name"]] = r
    return out
