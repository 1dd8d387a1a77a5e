#!/usr/bin/python3
"""Issue 7: the performance benchmarks and the speed-accuracy map, as one command.

    benchmarks/run_benchmarks.py [PHASE ...] [--build DIR] [--work DIR] [--reuse]

Phases (default: all but restore, in this order; each is cheap to rerun with --reuse):
  assembly  build/bench-assembly: Jacobian / residual / kernel time of every model
            against compressible Neo-Hooke (same mesh, element, quadrature; Q1F: the
            models on F-bar against plain-Q1 Neo-Hooke)
  instructions  the same under callgrind: instruction counts per operation, which
            do not depend on the load of a shared machine
  e2e       isometric COMBI contraction 0..0.15 s, Q1 hex, n = 1, 2 (MUMPS, one rank)
  solvers   MUMPS vs GMRES+GAMG vs GMRES+BoomerAMG; 1 vs 2 MPI ranks
  map       speed-accuracy map (COMBI): element (Q1, Q2, P1, P2), refinement, time
            step, penalty kappa; isometric F33 and free epsilon at t = 0.15 s; in groups
            map-cheap, map-q2 (reference), map-n2-isometric, map-n2-free, map-late
            (P2 n = 1, P1 n = 2, --map-extra); map-quadrature (Q1 degree 4, Q2 degrees
            2 and 6: run with --build of a build tree configured with
            -DMUSCLE_EXTRA_VARIANTS="combi:hex:1:4;combi:hex:2:2;combi:hex:2:6")
  knobs     BLE's anti-locking Q1 against plain Q1 and Q2; the activation root
            finder's tolerance (GIANT, WKM)
  fbar      the F-bar hexahedron (three-field Newton): accuracy at n = 1, 2, penalty
            sweep, MUMPS / GAMG / BoomerAMG on 1 and 2 ranks, n = 4 with GAMG at kappa = 100,
            the four models at n = 1
  linesearch  every SNES line search (cp, bt, basic, l2) and the trust region on the
            four models' fusiform runs (F-bar, n = 1) and the block demo scenes
  fresh     `tools/muscle run` in a new build tree: build (configure, FFCx, compile)
            and run (apt: --apt-seconds, timed on a fresh machine)
  kappa     preconditioners against the penalty: COMBI isometric F-bar, kappa = 10 ...
            10^4, MUMPS / GAMG / GAMG with SOR levels / BoomerAMG for systems / the
            penalty split (gmres-schur; full, lower, upper factor; lower with SSOR
            levels; lower with A_s^-1 by MUMPS, a diagnosis); n = 1 on one rank
            and n = 2 on two (--kappa-refinements, --kappa-candidates, --kappas); and
            Taylor-Hood with its Schur field split (GAMG or BoomerAMG on the
            displacement block), n = 1 on one rank and n = 2 on two (n = 3, on two,
            only when --kappa-refinements names it)
  kappa-n4  the penalty split at n = 4, kappa = 1000, isometric and free, two ranks
            (full factor at linear rtol 1e-6, lower at 1e-4, lower with SSOR levels at 1e-4)
  kappa-free  the plain and the stars Taylor-Hood splits (the stars with MUMPS or Chebyshev
            on q) on the free contraction, kappa = 1000, n = 1 on one rank and 2 on two
            (--kappa-refinements)
  kappa-th4  Taylor-Hood n = 4 (3.3 M unknowns), kappa = 1000, isometric, two ranks,
            gmres-stars with full Newton steps (about 2.5 h)
  reference  the references of F33 and epsilon: F-bar at n = 3 and 6, isometric and free,
            with the n = 4 runs' settings (--reference-refinements; n = 2, 4, 6 are one
            family of similar meshes, n = 3 checks the extrapolation; n = 6 has 1.3 M
            unknowns), and the same on meshes graded towards the end faces (isometric)
            and the mantle (free), n = 2, 4, 6 (--reference-graded-refinements), whose
            extrapolations are the map's references
  taylor-hood  the bending cantilever, Q2 against Taylor-Hood (MUMPS, Schur split) by
            refinement, the Schur and the stars splits against lambda / mu and the mesh,
            and side by side by refinement (taylor_hood.py; taylor-hood-sweep and
            taylor-hood-splits: those two parts);
            map-taylor-hood: Taylor-Hood on the map, n = 1; map-taylor-hood-n2: its
            isometric n = 2 (418,693 unknowns) and n = 1 alike, Schur split, 2 ranks,
            linear rtol 1e-4 (not in the default list; n = 2 took 1090 s of the
            default --map-timeout 1800)
  restore   seed WORK with the run records saved in --results (earlier sessions)
  solvers-n1, solvers-n2   the solver comparison at one refinement
  report    benchmarks/results.json and docs/images/speed_accuracy*.png, preconditioners_kappa.png from
            everything measured in WORK (WORK's runs replace those of the same name,
            the others are kept), then BENCHMARKS.md from results.json
            (benchmarks/report.py)

Every fusiform run goes to WORK/runs/NAME (summary.json, series.csv, time.txt with
peak RSS, loadavg before/after); --reuse keeps completed runs.  Each phase stores its
records in WORK/records.json, so the report can be rebuilt at any time.
"""
import argparse
import datetime
import itertools
import json
import math
import os
import platform
import shlex
import subprocess
import sys
import time

import report
import stiffsoft
import taylor_hood
from report import (KAPPA_CANDIDATES, LINE_SEARCHES, STARS_CANDIDATE,
                    STARS_CHEBYSHEV_CANDIDATE, TH4_OPTIONS)

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
T_END = 0.15


def loadavg():
    with open("/proc/loadavg") as f:
        return [float(x) for x in f.read().split()[:3]]


def git_commit():
    try:
        commit = subprocess.run(["git", "-C", ROOT, "rev-parse", "HEAD"], capture_output=True,
                                text=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", ROOT, "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True).stdout.strip()
        return commit + ("+dirty" if dirty else "")
    except OSError:
        return "unknown"


def machine_info():
    info = {"hostname": platform.node(), "kernel": platform.release(),
            "python": platform.python_version()}
    try:
        lscpu = subprocess.run(["lscpu"], capture_output=True, text=True).stdout
        for line in lscpu.splitlines():
            key, _, value = line.partition(":")
            if key.strip() in ("Model name", "CPU(s)", "Thread(s) per core", "L2 cache",
                               "L3 cache", "CPU max MHz", "Architecture"):
                info[key.strip()] = value.strip()
    except OSError:
        pass
    with open("/proc/meminfo") as f:
        for line in f:
            if line.startswith("MemTotal"):
                info["MemTotal_GiB"] = round(int(line.split()[1]) / 2**20, 1)
    return info


# ---------------------------------------------------------------------------
# records
# ---------------------------------------------------------------------------
class Records:
    def __init__(self, path):
        self.path = path
        self.data = {}
        if os.path.exists(path):
            with open(path) as f:
                self.data = json.load(f)

    def put(self, phase, key, value):
        if os.path.exists(self.path):  # another driver may have written meanwhile
            with open(self.path) as f:
                on_disk = json.load(f)
            for p, entries in on_disk.items():
                for k, v in entries.items():
                    if k not in self.data.get(p, {}):
                        self.data.setdefault(p, {})[k] = v
        self.data.setdefault(phase, {})[key] = value
        self.save()

    def save(self):
        tmp = self.path + ".tmp"
        with open(tmp, "w") as f:
            json.dump(self.data, f, indent=1)
        os.replace(tmp, self.path)


def run_name(model, case, cell, degree, n, dt, solver="lu", np=1, sets=(), petsc=(),
             fbar=False, rtol=None, study=None, taylor_hood=False):
    kind = "fbar" if fbar else "th" if taylor_hood else ""
    name = f"{model}_{case}_{cell}{degree}{kind}_n{n}_dt{dt:g}_{solver}_np{np}"
    if study:  # a study's own runs, apart from the same settings in other phases
        name = f"{study}_{name}"
    if rtol is not None:
        name += f"_rtol{rtol:g}"
    for s in sets:
        name += "_" + s.replace("=", "")
    return report.short_name(name + report.options_suffix(petsc))


def fusiform(args, model="combi", case="isometric", cell="hex", degree=1, n=1, dt=0.05,
             solver="lu", np=1, sets=(), petsc=(), timeout=None, group=None, fbar=False,
             rtol=None, study=None, taylor_hood=False):
    """One fusiform run (cached with --reuse); returns a flat record.  fbar: the F-bar
    hexahedron (three-field Newton); taylor_hood: the mixed element (degree 2); rtol:
    --linear-rtol of the iterative solvers."""
    name = run_name(model, case, cell, degree, n, dt, solver, np, sets, petsc, fbar, rtol, study,
                    taylor_hood)
    element = element_name(cell, degree, fbar, taylor_hood)
    out = os.path.join(args.work, "runs", name)
    summary_path = os.path.join(out, "summary.json")
    record_path = os.path.join(out, "record.json")
    if args.reuse and os.path.exists(record_path):
        with open(record_path) as f:
            record = json.load(f)
        if record.get("completed") or record.get("final_failure"):
            print(f"  reuse {name}" + ("" if record.get("completed") else " (failed)"),
                  flush=True)
            return record
    while args.reuse and running_elsewhere(out):  # a run left by a stopped driver
        time.sleep(5)
    if args.reuse and not os.path.exists(record_path) and os.path.exists(summary_path):
        adopted = adopt(name, out, dict(model=model, case=case, cell=cell, degree=degree,
                                        element=element, fbar=fbar,
                                        n=n, dt=dt, solver=solver, ranks=np, sets=list(sets),
                                        petsc=list(petsc), group=group, linear_rtol=rtol))
        if adopted:
            return adopted
    os.makedirs(out, exist_ok=True)
    if args.deadline:
        left = (args.deadline - datetime.datetime.now(datetime.timezone.utc)).total_seconds()
        if left < 60:
            print(f"  skip {name}: past the deadline", flush=True)
            return {"name": name, "skipped": "deadline", "completed": False, "model": model,
                    "case": case, "cell": cell, "degree": degree, "n": n, "dt": dt,
                    "solver": solver, "ranks": np, "sets": list(sets), "fbar": fbar,
                    "element": element}
        timeout = min(timeout or left, left)
    command = [os.path.join(args.build, "fusiform"), "--model", model, "--case", case,
               "--refinement", str(n), "--cell", cell, "--degree", str(degree),
               "--dt", repr(dt), "--linear-solver", solver, "--no-fields", "--quiet",
               "--out", out]
    if fbar:
        command.append("--fbar")
    elif taylor_hood:
        command.append("--taylor-hood")
    elif cell == "hex" and degree == 1:
        command.append("--no-fbar")  # plain Q1 (F-bar is the default there)
    if rtol is not None:
        command += ["--linear-rtol", repr(rtol)]
    for s in sets:
        command += ["--set", s]
    for p in petsc:
        command += shlex.split(p)
    if np > 1:
        command = ["mpirun", "--allow-run-as-root", "--oversubscribe", "-n", str(np), *command]
    time_file = os.path.join(out, "time.txt")
    command = ["/usr/bin/time", "-f", "%M %e %U %S", "-o", time_file, *command]
    before = loadavg()
    print("  " + " ".join(command[5:]), flush=True)
    start = time.time()
    for attempt in range(6):  # build/fusiform may be being relinked by someone else
        if os.path.exists(os.path.join(args.build, "fusiform")):
            break
        time.sleep(20)
    returncode, stderr = stiffsoft.run_with_timeout(command, timeout)
    elapsed = time.time() - start
    after = loadavg()
    record = {"name": name, "model": model, "case": case, "cell": cell, "degree": degree,
              "element": element, "n": n, "dt": dt, "solver": solver,
              "ranks": np, "sets": list(sets), "petsc": list(petsc), "group": group,
              "fbar": fbar, "linear_rtol": rtol,
              **near_null_space_markers(solver, case),
              "command": " ".join(shlex.quote(c) for c in command[5:]),
              "elapsed": elapsed, "loadavg_before": before, "loadavg_after": after,
              "binary_mtime": binary_mtime(args), "cpu": machine_info().get("Model name"),
              "returncode": returncode, "completed": False}
    if os.path.exists(summary_path) and os.path.getmtime(summary_path) >= start - 1:
        with open(summary_path) as f:
            summary = json.load(f)
        record.update(measured(summary))
    if os.path.exists(time_file):
        try:
            with open(time_file) as f:
                last = f.read().strip().splitlines()[-1].split()
            record["peak_rss_MiB"] = round(int(last[0]) / 1024, 1)
            if len(last) >= 4:  # user + system CPU seconds (all processes, all ranks)
                record["cpu_time"] = float(last[2]) + float(last[3])
        except (ValueError, IndexError):
            pass
    if record.get("newton_iterations"):
        record["newton_per_step"] = record["newton_iterations"] / max(1, record["steps"])
        record["krylov_per_newton"] = record["linear_iterations"] / record["newton_iterations"]
    if returncode != 0:
        record["error"] = stderr.strip()[-800:]
        # a solver failure (exit 3) is a result, not to be retried by --reuse
        record["final_failure"] = returncode == 3 or returncode == "timeout"
        print(f"    FAILED ({returncode}): {record['error'][-300:]}", flush=True)
    print(f"    {elapsed:.1f} s  load {before[0]:.2f}->{after[0]:.2f}  "
          f"F33={record.get('F33')} eps={record.get('epsilon')} "
          f"newton={record.get('newton_iterations')} lin={record.get('linear_iterations')} "
          f"rss={record.get('peak_rss_MiB')} MiB", flush=True)
    with open(record_path, "w") as f:
        json.dump(record, f, indent=1)
    return record


def measured(summary):
    """What a fusiform run's summary.json (the scene runner's) measured, as a record's
    keys: the final series values, Newton's unknowns and the counts."""
    final = summary.get("final", {})
    return {"F33": final.get("F33"), "epsilon": final.get("epsilon"),
            "volume_change": final.get("volume_change"),
            "unknowns": summary.get("built", {}).get("unknowns"),
            **{k: summary.get(k) for k in ("wall_time", "newton_iterations", "linear_iterations",
                                           "cutbacks", "steps", "cells", "nodes", "completed")}}


def binary_mtime(args):
    """When build/fusiform was linked (others may rebuild it between runs)."""
    try:
        return datetime.datetime.fromtimestamp(
            os.path.getmtime(os.path.join(args.build, "fusiform")),
            datetime.timezone.utc).isoformat(timespec="seconds")
    except OSError:
        return None


def running_elsewhere(out):
    """Is a fusiform process writing to `out` (left by a stopped driver)?"""
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        try:
            with open(f"/proc/{pid}/cmdline", "rb") as f:
                words = f.read().split(b"\0")
        except OSError:
            continue
        if words and words[0].endswith(b"fusiform") and out.encode() in words:
            return True
    return False


def near_null_space_markers(solver, case):
    """Which GAMG fixes a run has: before 2026-12-01 the rigid-body vectors dangled, and
    until that afternoon the free case (uniform-axial constraint) had none at all."""
    return {"near_null_space_fixed": solver == "gmres-gamg",
            "reduced_near_null_space": solver == "gmres-gamg" and case == "free"}


def adopt(name, out, base):
    """A run whose driver was stopped but which finished by itself: its summary and
    /usr/bin/time output are kept; the load average is the one at adoption.  `base`:
    the run's settings (model, case, element, ..., as the driver asked for them)."""
    with open(os.path.join(out, "summary.json")) as f:
        summary = json.load(f)
    if not summary.get("completed") or not os.path.exists(os.path.join(out, "time.txt")):
        return None
    record = {"name": name, **base, **near_null_space_markers(base["solver"], base["case"]),
              "elapsed": summary["wall_time"], "cpu": machine_info().get("Model name"),
              "loadavg_before": loadavg(),
              "loadavg_after": loadavg(), "adopted": True, **measured(summary)}
    with open(os.path.join(out, "time.txt")) as f:
        words = f.read().split()
    record["peak_rss_MiB"] = round(int(words[0]) / 1024, 1)
    if len(words) >= 4:
        record["cpu_time"] = float(words[2]) + float(words[3])
    record["newton_per_step"] = record["newton_iterations"] / max(1, record["steps"])
    record["krylov_per_newton"] = record["linear_iterations"] / record["newton_iterations"]
    with open(os.path.join(out, "record.json"), "w") as f:
        json.dump(record, f, indent=1)
    print(f"  adopted {name}", flush=True)
    return record


# the benchmark's elements: Q1F is the muscle models on F-bar, Neo-Hooke on plain Q1
ELEMENT_CELLS = {"Q1": ("hex", 1), "Q2": ("hex", 2), "P1": ("tet", 1), "P2": ("tet", 2),
                 "Q1F": ("hex", 1)}


def element_name(cell, degree, fbar=False, taylor_hood=False):
    """Q1, Q1F (F-bar), Q2, Q2TH (Taylor-Hood), P1, ..."""
    return ({"hex": "Q", "tet": "P"}[cell] + str(degree) + ("F" if fbar else "")
            + ("TH" if taylor_hood else ""))


# ---------------------------------------------------------------------------
# phases
# ---------------------------------------------------------------------------
def phase_assembly(args, records):
    binary = os.path.join(args.build, "bench-assembly")
    for element in args.assembly_elements:
        cell, degree = ELEMENT_CELLS[element]
        out = os.path.join(args.work, f"assembly_{element}_n{args.assembly_n}.json")
        if args.reuse and os.path.exists(out):
            with open(out) as f:
                records.put("assembly", element, json.load(f))
            print(f"  reuse {out}")
            continue
        command = [binary, "--refinement", str(args.assembly_n), "--cell", cell, "--degree",
                   str(degree), "--repetitions", str(args.repetitions), "--json", out]
        if element == "Q1F":  # the muscle models on F-bar, Neo-Hooke on plain Q1
            command.append("--fbar")
        print("  " + " ".join(command), flush=True)
        result = subprocess.run(command, capture_output=True, text=True)
        print(result.stdout, end="", flush=True)
        if result.returncode != 0:
            print(f"    FAILED: {result.stderr[-600:]}", flush=True)
            continue
        with open(out) as f:
            records.put("assembly", element, json.load(f))


def phase_instructions(args, records):
    """Instruction counts per operation (callgrind; independent of the machine's load)."""
    import glob
    binary = os.path.join(args.build, "bench-assembly")
    for element in args.instruction_elements:
        cell, degree = ELEMENT_CELLS[element]
        if args.reuse and element in records.data.get("instructions", {}):
            print(f"  reuse instructions {element}")
            continue
        folder = os.path.join(args.work, f"callgrind_{element}")
        os.makedirs(folder, exist_ok=True)
        for old in glob.glob(os.path.join(folder, "callgrind.out*")):
            os.remove(old)
        command = ["valgrind", "--tool=callgrind", "--instr-atstart=no",
                   f"--callgrind-out-file={folder}/callgrind.out.%p", binary,
                   "--refinement", "1", "--cell", cell, "--degree", str(degree),
                   "--repetitions", "1"] + (["--fbar"] if element == "Q1F" else [])
        print("  " + " ".join(command), flush=True)
        start = time.time()
        result = subprocess.run(command, capture_output=True, text=True)
        if result.returncode != 0:
            print(f"    FAILED: {result.stderr[-600:]}", flush=True)
            continue
        table = parse_callgrind(folder, verbose=True)
        with open(os.path.join(folder, "seconds.txt"), "w") as f:
            f.write(f"{time.time() - start:.1f}\n")
        records.put("instructions", element, {"cell": cell, "degree": degree, "refinement": 1,
                                              "seconds": time.time() - start,
                                              "counts": table})


def parse_callgrind(folder, verbose=False):
    """Instruction counts per "MODEL:OPERATION" dump of one bench-assembly run."""
    import glob
    counts = {}
    for path in glob.glob(os.path.join(folder, "callgrind.out*")):
        label, total = None, None
        with open(path) as f:
            for line in f:
                if line.startswith("desc: Trigger: Client Request:"):
                    label = line.split(":", 3)[3].strip()
                elif line.startswith("totals:"):
                    total = int(line.split()[1])
        if label and total is not None:
            counts[label] = total
    if "neohooke:jacobian" not in counts:
        return None
    # only models whose Jacobian and residual are both in (a run still going has not)
    models = sorted(m for m in {k.split(":")[0] for k in counts}
                    if f"{m}:jacobian" in counts and f"{m}:residual" in counts)
    nh = counts["neohooke:jacobian"] + counts["neohooke:residual"]
    table = {}
    for m in models:
        jac, res, ker = (counts.get(f"{m}:{op}", 0) for op in ("jacobian", "residual",
                                                               "kernel"))
        table[m] = {"jacobian": jac, "residual": res, "kernel": ker,
                    "jacobian_ratio": jac / counts["neohooke:jacobian"],
                    "residual_ratio": res / counts["neohooke:residual"],
                    "newton_ratio": (jac + res + ker) / nh}
        if verbose:
            print(f"    {m:9s} J {jac:.3e}  r {res:.3e}  k {ker:.3e}  J/NH "
                  f"{table[m]['jacobian_ratio']:.2f}  r/NH {table[m]['residual_ratio']:.2f}  "
                  f"(J+r+k)/NH {table[m]['newton_ratio']:.2f}", flush=True)
    return table


def collect(args):
    """Everything measured so far, from the files on disk (robust against several
    drivers writing records.json at once)."""
    import glob
    data = {"assembly": {}, "instructions": {}, "e2e": {}, "solvers": {}, "map": {},
            "knobs": {}, "fbar": {}, "linesearch": {},
            "kappa": {}}
    for element in ("Q1", "Q2", "P1", "P2", "Q1F"):
        path = os.path.join(args.work, f"assembly_{element}_n{args.assembly_n}.json")
        if os.path.exists(path):
            with open(path) as f:
                data["assembly"][element] = json.load(f)
        folder = os.path.join(args.work, f"callgrind_{element}")
        table = parse_callgrind(folder) if os.path.isdir(folder) else None
        if table:
            cell, degree = ELEMENT_CELLS[element]
            data["instructions"][element] = {"cell": cell, "degree": degree, "refinement": 1,
                                             "counts": table}
    for path in sorted(glob.glob(os.path.join(args.work, "assembly_*_n[2-9].json"))):
        with open(path) as f:  # extra refinements, e.g. bench-assembly --refinement 4
            data["assembly"][os.path.basename(path)[9:-5]] = json.load(f)
    for path in sorted(glob.glob(os.path.join(args.work, "runs", "*", "record.json"))):
        with open(path) as f:
            r = json.load(f)
        if r.get("group") == "linesearch" or "scene" in r:  # fusiform and scene runs
            if "method" not in r:  # a fusiform run's record: from the options it ran with
                options = " ".join(r.get("petsc", []))
                r["method"] = "tr" if "newtontr" in options else options.split()[-1]
            data["linesearch"][r["name"]] = r
            continue
        r.setdefault("petsc", [])
        r.setdefault("fbar", False)
        if r.get("group") == "kappa":
            data["kappa"][r["name"]] = r
            continue
        if r["fbar"] or r.get("group") == "fbar":
            data["fbar"][r["name"]] = r
            # a discretisation like the others on the map (LU, one rank)
            if r["model"] == "combi" and r["solver"] == "lu" and r["ranks"] == 1 \
                    and not r["petsc"]:
                data["map"][r["name"]] = r
            continue
        if r.get("group") == "knobs":
            data["knobs"][r["name"]] = r
            continue
        plain = not r["sets"] and not r["petsc"]
        if r["model"] == "combi" and r["case"] == "isometric" and r["element"] == "Q1" \
                and r["dt"] == args.e2e_dt and not r["petsc"] \
                and (plain or (r["solver"] != "lu" or r["ranks"] > 1)
                     or r["sets"] == ["kappa=100"]):
            data["solvers"][r["name"]] = r
            if r["solver"] == "lu" and r["ranks"] == 1 and plain:
                data["e2e"][r["name"]] = r
        if r["model"] == "combi" and r["solver"] == "lu" and r["ranks"] == 1:
            data["map"][r["name"]] = r
    path = os.path.join(args.work, "fresh.json")
    if os.path.exists(path):
        with open(path) as f:
            data["fresh"] = json.load(f)
    data["stiffsoft"] = stiffsoft.collect(args.work)
    data["taylor_hood"] = taylor_hood.collect(args.work)
    path = os.path.join(args.work, "experiment_fno_math_errno.json")
    if os.path.exists(path):  # hand-made experiment, see BENCHMARKS.md
        with open(path) as f:
            data["experiments"] = {"fno_math_errno": json.load(f)}
    return data


def fbar_runs(args):
    """The F-bar hexahedron (three-field Newton): map points at the preset penalty (LU),
    the penalty sweep, and the scaling study n = 1, 2, 4 at kappa = 100, where the
    multigrid-preconditioned GMRES converges (BENCHMARKS.md: why not at kappa = 1000)."""
    dt, soft = args.e2e_dt, ("kappa=100",)
    amg = dict(rtol=1e-6, sets=soft)
    runs = [dict(n=4, solver="gmres-gamg", np=2, **amg)]  # the 385k-unknown target
    for n in (1, 2):  # map points, preset kappa
        runs += [dict(case=c, n=n) for c in ("isometric", "free")]
    runs += [dict(n=1, sets=(f"kappa={k}",)) for k in (30, 100, 300)]
    runs += [dict(case="free", n=1, sets=soft)]
    runs += [dict(n=1, petsc=("--fbar-displacement-newton",))]
    for n in (1, 2):  # solvers and ranks at kappa = 100
        runs += [dict(n=n, solver="lu", np=np, sets=soft) for np in (1, 2)]
        runs += [dict(n=n, solver="gmres-gamg", np=np, **amg) for np in (1, 2)]
        runs += [dict(n=n, solver="gmres-hypre", np=1, **amg)]
    # preset kappa: does multigrid cope?
    runs += [dict(n=1, solver="gmres-gamg", np=1, rtol=1e-6),
             dict(n=2, solver="gmres-gamg", np=2, rtol=1e-6)]
    # free: the rigid-body modes on the constraint's reduced unknowns (479 Krylov its per
    # Newton its at n = 2 without them); n = 4 is the free reference at kappa = 100
    runs += [dict(case="free", n=n, solver="gmres-gamg", np=2, **amg) for n in (2, 4)]
    # a second element at kappa = 100 to judge the F-bar sequence against (Q2 n = 2 with
    # GAMG did not fit: displacement Newton, first step ~50 iterations at n = 1 already)
    runs += [dict(fbar=False, degree=2, n=1, sets=soft)]
    # the four models on F-bar, n = 1 (end values: 0.05 s steps suffice for all)
    runs += [dict(model=m, case=c, n=1) for m in ("ble", "wkm", "giant") for c in
             ("isometric", "free")]
    for r in runs:
        r.setdefault("dt", dt)
        r.setdefault("fbar", True)
        r.setdefault("model", "combi")
    return runs


def phase_fbar(args, records):
    for kw in fbar_runs(args):
        r = fusiform(args, timeout=args.map_timeout, group="fbar", **kw)
        records.put("fbar", r["name"], r)


# Candidates on another element than F-bar: element options, refinements run (n = 2 has
# 418,693 unknowns, n = 3 1.4 M: only what --kappa-refinements names) and the n = 1
# timeout in place of --kappa-timeout.  Taylor-Hood's Schur split is PETSc's field split
# on (u | theta, p), the inf-sup stable pair.
KAPPA_ELEMENTS = {label: (dict(degree=2, taylor_hood=True), (1, 2, 3), 900)
                  for label in KAPPA_CANDIDATES if label.startswith("Taylor-Hood")}
# n = 1, 2; n = 4 is phase kappa-th4 (other options)
KAPPA_ELEMENTS[STARS_CHEBYSHEV_CANDIDATE] = (dict(degree=2, taylor_hood=True), (1, 2), 900)


def kappa_runs(args):
    """COMBI isometric at kappa = 10 ... 10^4 with every candidate (on F-bar unless
    KAPPA_ELEMENTS names another element): n = 1 on one rank, n = 2 on two ranks
    (--kappa-refinements)."""
    runs = []
    for n in args.kappa_refinements:
        for label in args.kappa_candidates:
            solver, petsc = KAPPA_CANDIDATES[label]
            _, refinements, timeout = KAPPA_ELEMENTS.get(label, (None, (n,), args.kappa_timeout))
            if n not in refinements:
                continue
            for kappa in args.kappas:
                runs.append(dict(label=label, solver=solver, petsc=petsc, n=n,
                                 np=1 if n == 1 else 2, sets=(f"kappa={kappa:g}",),
                                 rtol=None if solver == "lu" else 1e-6,
                                 timeout=timeout * n ** 3))
    return runs


def kappa_run(args, records, label, **kw):
    element = KAPPA_ELEMENTS.get(label, (dict(fbar=True),))[0]
    r = fusiform(args, dt=args.e2e_dt, group="kappa", study="kappa", **element, **kw)
    r["candidate"] = label
    if "skipped" not in r:
        with open(os.path.join(args.work, "runs", r["name"], "record.json"), "w") as f:
            json.dump(r, f, indent=1)
        records.put("kappa", r["name"], r)
    return r


def phase_kappa(args, records):
    """The candidates against kappa and n; a candidate that failed at n = 1 is not run
    at n = 2 (a failure burns every cutback)."""
    failed = set()
    for kw in kappa_runs(args):
        label = kw.pop("label")
        if kw["n"] > 1 and label in failed:
            print(f"  skip {label} n={kw['n']}: failed at n = 1", flush=True)
            continue
        r = kappa_run(args, records, label, **kw)
        if not r.get("completed"):
            failed.add(label)


def phase_kappa_n4(args, records):
    """Issue 18's target: n = 4 (385,155 unknowns) at the preset kappa on two ranks with
    the penalty split, isometric and free: the full block factorisation at linear
    tolerance 1e-6, and the lower triangular one (one V-cycle per Krylov iteration) at
    1e-4 (the default; Newton's own tolerance sets the answer), also with SSOR levels."""
    for label, rtol in (("penalty split", 1e-6), ("penalty split, lower", 1e-4),
                        ("penalty split, lower, SOR levels", 1e-4)):
        for case in ("isometric", "free"):
            kappa_run(args, records, label, case=case, n=4, np=2, solver="gmres-schur",
                      sets=("kappa=1000",), petsc=KAPPA_CANDIDATES[label][1], rtol=rtol,
                      timeout=args.map_timeout)


def phase_kappa_free(args, records):
    """The Taylor-Hood splits on the free contraction (the uniform-axial constraint: the
    shell's blocks on T^T A T's reduced unknowns) at the preset kappa, n = 1 on one rank
    and 2 on two (--kappa-refinements); those of the three in --kappa-candidates."""
    for n in args.kappa_refinements:
        for label in ("Taylor-Hood, Schur split", STARS_CANDIDATE, STARS_CHEBYSHEV_CANDIDATE):
            if label not in args.kappa_candidates:
                continue
            kappa_run(args, records, label, case="free", n=n, np=1 if n == 1 else 2,
                      solver="gmres-schur", sets=("kappa=1000",),
                      petsc=KAPPA_CANDIDATES[label][1], rtol=1e-6,
                      timeout=KAPPA_ELEMENTS[label][2] * n ** 3)


def phase_kappa_th4(args, records):
    """Taylor-Hood n = 4 (3,271,173 unknowns, 20.7 GiB over two ranks) at the preset
    kappa, isometric, with `gmres-stars` (the Chebyshev candidate's options); about 2.5 h.
    Full Newton steps: the scene's cp line search creeps there, accepting 0.1 % of each
    Newton step from the first step's fourth iteration on. GMRES restarts every 60
    iterations (26 MB a basis vector: 5.2 GB at NonlinearSolver's 200) and gives up after
    400, so that a hard linear system cuts the time step instead of running for hours."""
    kappa_run(args, records, STARS_CHEBYSHEV_CANDIDATE, case="isometric", n=4, np=2,
              solver="gmres-stars", sets=("kappa=1000",), petsc=TH4_OPTIONS, rtol=1e-6,
              timeout=5 * 3600)


def phase_reference(args, records):
    """References of F33 and epsilon by Richardson extrapolation need meshes of one
    family: the fusiform's radial count ceil(2.5 n) is proportional to n only for even
    n, so n = 2, 4, 6 are similar meshes (h in the ratios 3 : 1.5 : 1) and n = 3 lies
    off the family, a check of the extrapolated law rather than one of its points.  The
    graded families (report.REFERENCE_GRADINGS, n = 2, 4, 6; the map's reference) alike."""
    runs = [(n, case, ()) for n, case in
            itertools.product(args.reference_refinements, ("isometric", "free"))]
    runs += [(n, case, (report.REFERENCE_GRADINGS[case],)) for case, n in
             itertools.product(("isometric", "free"), args.reference_graded_refinements)]
    for n, case, grading in runs:
        kappa_run(args, records, "penalty split, lower", case=case, n=n, np=2,
                  solver="gmres-schur", sets=("kappa=1000", *grading),
                  petsc=KAPPA_CANDIDATES["penalty split, lower"][1], rtol=1e-4,
                  timeout=args.map_timeout * max(1, n / 4) ** 3)


def phase_restore(args, records):
    """Seed WORK with the records saved in --results (runs of earlier sessions), so that
    the report keeps them; GAMG runs from before the near-null-space fixes (2026-12-01:
    dangling vectors; none under the uniform-axial constraint) are dropped."""
    with open(args.results) as f:
        saved = json.load(f)
    stale = lambda r: r.get("solver") == "gmres-gamg" and (
        not r.get("near_null_space_fixed")
        or (r.get("case") == "free" and not r.get("reduced_near_null_space")))
    count = 0
    for key in ("end_to_end", "solvers", "map_runs", "knob_runs", "fbar_runs", "kappa_runs"):
        for r in saved.get(key) or []:
            folder = os.path.join(args.work, "runs", r["name"])
            path = os.path.join(folder, "record.json")
            if os.path.exists(path) or stale(r):
                continue
            os.makedirs(folder, exist_ok=True)
            with open(path, "w") as f:
                json.dump(r, f, indent=1)
            count += 1
    for r in saved.get("taylor_hood_runs") or []:  # phase taylor-hood's, in their own folder
        folder = os.path.join(args.work, "taylor_hood", r["name"])
        path = os.path.join(folder, "record.json")
        if not os.path.exists(path):
            os.makedirs(folder, exist_ok=True)
            with open(path, "w") as f:
                json.dump(r, f, indent=1)
            count += 1
    for element, data in saved.get("assembly", {}).items():
        name = element if "_n" in element else f"{element}_n{data.get('refinement', 1)}"
        path = os.path.join(args.work, f"assembly_{name}.json")
        if not os.path.exists(path):
            with open(path, "w") as f:
                json.dump(data, f, indent=1)
    print(f"  restored {count} run records from {args.results}", flush=True)


def phase_e2e(args, records):
    for n in args.e2e_refinements:
        for model in args.e2e_models:
            r = fusiform(args, model=model, n=n, dt=args.e2e_dt)
            records.put("e2e", r["name"], r)


def failed_before(args, solver, n_max, sets=()):
    """Did this iterative solver already fail on a run at refinement <= n_max?"""
    for n in range(1, n_max + 1):
        path = os.path.join(args.work, "runs", run_name("combi", "isometric", "hex", 1, n,
                                                        args.e2e_dt, solver, 1, sets),
                            "record.json")
        if os.path.exists(path):
            with open(path) as f:
                if not json.load(f).get("completed"):
                    return True
    return False


def phase_solvers(args, records, refinements=None):
    """MUMPS against GMRES + GAMG / BoomerAMG, 1 and 2 ranks.  An iterative solver that
    failed on one rank is not retried on two ranks or on a finer mesh (each failure
    burns every cutback: about 4 minutes at n = 1); instead it is tried once with a
    softer penalty (kappa = 100), where the system is better conditioned."""
    for n in refinements or args.solver_refinements:
        for solver in ("lu", "gmres-hypre", "gmres-gamg"):
            for np in (1, 2):
                if solver != "lu" and failed_before(args, solver, n if np == 2 else n - 1):
                    print(f"  skip {solver} n={n} ranks={np}: failed before", flush=True)
                    continue
                if n > 1 and np == 2 and solver != "lu":
                    continue  # n = 2: the iterative solvers on one rank only (time)
                r = fusiform(args, model="combi", n=n, dt=args.e2e_dt, solver=solver, np=np)
                records.put("solvers", r["name"], r)
        if n == 1:
            for solver in ("gmres-hypre", "gmres-gamg"):
                if failed_before(args, solver, 1):
                    r = fusiform(args, model="combi", n=1, dt=args.e2e_dt, solver=solver,
                                 sets=("kappa=100",))
                    records.put("solvers", r["name"], r)


def map_runs(args, group):
    """kwargs of the speed-accuracy map (COMBI), by group, cheapest first."""
    dt = args.map_dt
    both = lambda **kw: [dict(case=c, **kw) for c in ("isometric", "free")]
    if group == "cheap":  # Q1 and P1 at n = 1, time step and penalty sweeps
        runs = both(cell="hex", degree=1, n=1, dt=dt) + both(cell="tet", degree=1, n=1, dt=dt)
        for step in (0.15, 0.01):
            runs += both(cell="hex", degree=1, n=1, dt=step)
        for kappa in (100, 300, 3000, 10000):
            runs += both(cell="hex", degree=1, n=1, dt=dt, sets=(f"kappa={kappa}",))
        return runs
    if group == "q2":  # the reference; failing first-step attempts stopped after 10
        # Newton iterations in the free case (the end state does not depend on it)
        return [dict(case="isometric", cell="hex", degree=2, n=1, dt=dt),
                dict(case="free", cell="hex", degree=2, n=1, dt=dt, petsc=("-snes_max_it 10",))]
    if group == "n2-isometric":
        return [dict(case="isometric", cell="hex", degree=1, n=2, dt=dt)]
    if group == "n2-free":  # as q2: failing attempts stopped after 10 iterations
        return [dict(case="free", cell="hex", degree=1, n=2, dt=dt, petsc=("-snes_max_it 10",))]
    if group == "quadrature":  # needs a build with MUSCLE_EXTRA_VARIANTS (BENCHMARKS.md)
        q = lambda d: (f"--quadrature-degree {d}",)
        return (both(cell="hex", degree=1, n=1, dt=dt, petsc=q(4))
                + both(cell="hex", degree=2, n=1, dt=dt, petsc=q(2) + ("-snes_max_it 10",))
                + both(cell="hex", degree=2, n=1, dt=dt, petsc=q(6) + ("-snes_max_it 10",)))
    if group == "taylor-hood":  # the mixed element, MUMPS and its Schur split
        return (both(cell="hex", degree=2, n=1, dt=dt, taylor_hood=True)
                + both(cell="hex", degree=2, n=1, dt=dt, taylor_hood=True, solver="gmres-schur"))
    if group == "taylor-hood-n2":  # the isometric force's second Taylor-Hood mesh: MUMPS's
        # 3-D fill would exceed this machine's memory (estimate), so the Schur split on two
        # ranks; Newton's tolerance sets F33, the looser linear one the Krylov count and a
        # few Newton iterations (n = 1 alike, for the count's growth in n)
        return [dict(case="isometric", cell="hex", degree=2, n=n, dt=dt, taylor_hood=True,
                     solver="gmres-schur", np=2, rtol=1e-4) for n in (2, 1)]
    if group == "late":
        runs = both(cell="tet", degree=2, n=1, dt=dt) + both(cell="tet", degree=1, n=2, dt=dt)
        return runs + [dict(case=case, **extra) for extra in args.map_extra
                       for case in ("isometric", "free")]
    raise ValueError(group)


def phase_map(args, records, groups=("cheap", "q2", "n2-isometric", "n2-free", "late")):
    for group in groups:
        for kw in map_runs(args, group):
            r = fusiform(args, timeout=args.map_timeout, group="fbar", **kw)
            records.put("map", r["name"], r)


def knob_runs(args):
    """Settings outside the COMBI map: BLE's anti-locking Q1 against plain Q1 and Q2, and
    the activation root finder's tolerance (GIANT, WKM; 0.01 s steps, end values do not
    depend on the step)."""
    runs = []
    for case in ("isometric", "free"):
        runs += [dict(model="ble", case=case, degree=1),
                 dict(model="ble", case=case, degree=1, petsc=("--anti-locking",)),
                 dict(model="ble", case=case, degree=2, petsc=("-snes_max_it 10",))]
    for model, tolerances in (("giant", (1e-15, 1e-9, 1e-6, 1e-4, 1e-2)),
                              ("wkm", (1e-15, 1e-6, 1e-2))):
        runs += [dict(model=model, case="isometric", dt=0.01,
                      petsc=(f"--root-tolerance {t:g}",)) for t in tolerances]
    return runs


def phase_knobs(args, records):
    for kw in knob_runs(args):
        kw.setdefault("dt", args.map_dt)
        r = fusiform(args, timeout=args.map_timeout, group="knobs", **kw)
        records.put("knobs", r["name"], r)


# ---------------------------------------------------------------------------
# line searches: the default chosen by measurement
# ---------------------------------------------------------------------------
# scene: the horizon (None: the scene's time.end).  Cut short, as every step repeats
# the first ones: the cantilever (3 of its 10 load steps), the humerus (its first
# contact; the line searches that stall there do so early), the swinging beam (one
# period).  hertz is left out: 200 s and more per run for 2 load steps.
LINE_SEARCH_SCENES = {"block_graded": None, "block_wave": None, "block_cell_data": None,
                      "block_muscle_tendon": None, "fusiform_passive_stretch": None,
                      "cantilever_pressure": 0.3, "humerus_deltoid": 0.1,
                      "beam_vibration": 0.04}


def line_search_options(method):
    return ["-snes_type", "newtontr"] if method == "tr" else ["--line-search", method]


def scene_run(args, scene, method, timeout, t_end=None):
    """One muscle-run of a demo scene with a line search, to `t_end` if given (cached
    with --reuse)."""
    name = f"scene_{scene}_{method}"
    out = os.path.join(args.work, "runs", name)
    record_path = os.path.join(out, "record.json")
    if args.reuse and os.path.exists(record_path):
        with open(record_path) as f:
            return json.load(f)
    os.makedirs(out, exist_ok=True)
    options = (["-snes_type", "newtontr"] if method == "tr"
               else ["--set", f"solver.line_search={method}"])
    if t_end is not None:
        options += ["--t-end", repr(t_end)]
    if args.deadline:
        left = (args.deadline - datetime.datetime.now(datetime.timezone.utc)).total_seconds()
        if left < 60:
            print(f"  skip {name}: past the deadline", flush=True)
            return {"name": name, "scene": scene, "method": method, "skipped": "deadline",
                    "completed": False}
        timeout = min(timeout, left)
    command = [os.path.join(args.build, "muscle-run"),
               os.path.join(ROOT, "demos", "scenes", scene + ".yaml"), "--out", out, "--quiet",
               "--set", "output.fields=false", "--set", "output.plots=false", *options]
    before = loadavg()
    print("  " + " ".join(command), flush=True)
    start = time.time()
    returncode, stderr = stiffsoft.run_with_timeout(command, timeout)
    record = {"name": name, "scene": scene, "method": method, "t_end": t_end,
              "returncode": returncode,
              "elapsed": time.time() - start, "loadavg_before": before,
              "command": " ".join(shlex.quote(c) for c in command), "completed": False}
    summary_path = os.path.join(out, "summary.json")
    if os.path.exists(summary_path) and os.path.getmtime(summary_path) >= start - 1:
        with open(summary_path) as f:
            summary = json.load(f)
        record.update({k: summary.get(k) for k in (
            "completed", "newton_iterations", "cutbacks", "steps", "wall_time", "failure")})
    if returncode != 0:
        record["error"] = stderr.strip()[-400:]
    print(f"    {record['elapsed']:.1f} s  newton={record.get('newton_iterations')} "
          f"cutbacks={record.get('cutbacks')} exit {returncode}", flush=True)
    with open(record_path, "w") as f:
        json.dump(record, f, indent=1)
    return record


def phase_linesearch(args, records):
    """Every line search (and the trust region) on the four models' fusiform runs (F-bar,
    n = 1, both cases) and on the block demo scenes; the default follows the table."""
    for method in LINE_SEARCHES:
        for model in ("ble", "wkm", "giant", "combi"):
            for case in ("isometric", "free"):
                r = fusiform(args, model=model, case=case, fbar=True, dt=args.map_dt,
                             petsc=(" ".join(line_search_options(method)),),
                             timeout=args.map_timeout, group="linesearch")
                r["method"] = method
                records.put("linesearch", r["name"], r)
        for scene, t_end in LINE_SEARCH_SCENES.items():
            r = scene_run(args, scene, method, args.map_timeout, t_end)
            records.put("linesearch", r["name"], r)


# ---------------------------------------------------------------------------
# report
# ---------------------------------------------------------------------------
def extrapolate(records):
    """Power-law fit t = a N^p of the n = 1, 2 runs (COMBI isometric, LU, one rank),
    evaluated at n = 4 (385,155 unknowns); the same for peak memory."""
    runs = [r for r in records.get("e2e", {}).values()
            if r.get("completed") and r["solver"] == "lu" and r["ranks"] == 1]
    by_n = {r["n"]: r for r in runs}
    out = {}
    if 1 in by_n and 2 in by_n:
        a, b = by_n[1], by_n[2]
        N4 = 385155
        for key in ("cpu_time", "wall_time", "peak_rss_MiB"):
            if a.get(key) and b.get(key):
                p = math.log(b[key] / a[key]) / math.log(b["unknowns"] / a["unknowns"])
                out[key] = {"exponent": p,
                            "n4_estimate": b[key] * (N4 / b["unknowns"]) ** p}
        # CPU time where both runs have it: the wall time depends on the load
        key = "cpu_time" if a.get("cpu_time") and b.get("cpu_time") else "wall_time"
        out["per_newton_basis"] = key
        per_it = [r[key] / r["newton_iterations"] for r in (a, b)]
        p = math.log(per_it[1] / per_it[0]) / math.log(b["unknowns"] / a["unknowns"])
        out["seconds_per_newton"] = {"exponent": p, "n1": per_it[0], "n2": per_it[1],
                                  "n4_estimate": per_it[1] * (N4 / b["unknowns"]) ** p}
    return out


def kappa100_runs(records):
    """One run per (case, element, n) at kappa = 100, from every phase: the finest
    meshes there need multigrid (and 2 ranks), so the map cannot be LU-only.  Among
    equal discretisations the fastest stands for the rest (their values agree to 1e-11;
    its label names solver and ranks)."""
    runs = {}
    for phase in ("map", "fbar", "solvers"):
        for r in records.get(phase, {}).values():
            if not r.get("completed") or r["sets"] != ["kappa=100"] or r.get("petsc") \
                    or r["model"] != "combi":
                continue
            key = (r["case"], r["element"], r["n"], r["dt"])
            rank = r["wall_time"]
            if key not in runs or rank < runs[key][0]:
                runs[key] = (rank, r)
    return {r["name"]: r for _, r in runs.values()}


def extrapolated_references(records):
    """F33 and epsilon at the preset kappa extrapolated through F-bar n = 2, 4, 6 (phase
    reference; similar meshes), for each case whose three runs exist: {case: reference}.
    epsilon through the shortening 1 - epsilon, against which the map measures errors."""
    by_name = {r["name"]: r for phase in records.values() if isinstance(phase, dict)
               for r in phase.values() if isinstance(r, dict) and "name" in r}
    out = {}
    for case, quantity in (("isometric", "F33"), ("free", "epsilon")):
        runs = [by_name.get(report.RUNS[a]) for a in report.reference_aliases(case)]
        if not all(r and r.get("completed") for r in runs):
            continue
        value = report.reference_quantity(case)
        x = report.richardson(*(value(r) for r in runs), h=[report.cell_size(r) for r in runs])
        if "value" not in x:
            continue
        limit = x["value"] if case == "isometric" else 1 - x["value"]
        out[case] = {"name": f"F-bar n = 2, 4, 6 {report.REFERENCE_FAMILY}, extrapolated",
                     "quantity": quantity,
                     "value": limit, "order": x["p"],
                     # Roache's GCI of n = 6, relative to the reference as the map is
                     "gci_finest": 1.25 * abs(value(runs[-1]) / x["value"] - 1),
                     "runs": [r["name"] for r in runs], "extrapolated": True}
    return out


def map_analysis(records, reference_choice, sets=()):
    """Errors against the reference per case, among the runs at the penalty `sets` (() =
    preset; other penalties are drawn as model changes): at the preset penalty the value
    extrapolated through F-bar n = 2, 4, 6 when phase reference has run, else the finest
    completed run (phase reference's runs are points and candidates too)."""
    if sets:
        runs = list(kappa100_runs(records).values())
        extrapolated = {}
    else:
        runs = [r for r in records.get("map", {}).values() if r.get("completed")]
        extrapolated = {} if reference_choice else extrapolated_references(records)
        family = [r for r in records.get("kappa", {}).values()
                  if r["name"] in {report.RUNS[a] for a in report.REFERENCE_POINTS}]
        runs += [r for r in family if r.get("completed")]
        for case in ("isometric", "free"):
            if case not in extrapolated:
                print(f"  map, {case}: no extrapolated reference (no completed n = 2, 4, 6"
                      f"{' or --reference given' if reference_choice else ''}); the finest "
                      "run is the reference", flush=True)
    out = {"points": [], "reference": {}, "sets": list(sets)}
    for case, quantity in (("isometric", "F33"), ("free", "epsilon")):
        if case in extrapolated:
            out["reference"][case] = extrapolated[case]
            add_map_points(out, runs, case, quantity, None, extrapolated[case]["value"], sets)
            continue
        # without an extrapolation: the finest discretisation (most unknowns; Q2 first;
        # Taylor-Hood stays a point, so that its error is shown)
        candidates = [r for r in runs if r["case"] == case and preset(r["sets"]) == list(sets)
                      and not any("--quadrature-degree" in a for a in r.get("petsc", []))
                      and r["element"] != "Q2TH"]
        if reference_choice:
            candidates = [r for r in candidates
                          if f"{r['element']}_n{r['n']}" == reference_choice] or candidates
        if not candidates:
            continue
        ref = max(candidates, key=lambda r: (r.get("unknowns") or 0, r["degree"],
                                             r.get("fbar", False), -r["dt"],
                                             not report.mesh_numbers(r["sets"])))
        out["reference"][case] = {"name": ref["name"], "quantity": quantity,
                                  "value": ref[quantity]}
        add_map_points(out, runs, case, quantity, ref["name"], ref[quantity], sets)
    out["levels"] = report.accuracy_levels(out)
    return out


def preset(sets):
    """A run's --set list without the preset kappa that some phases name explicitly and
    without mesh numbers (a mesh, not a model change)."""
    return [x for x in sets if x != "kappa=1000" and x not in report.mesh_numbers(sets)]


def add_map_points(out, runs, case, quantity, ref_name, reference, sets):
    """The runs of a case but the reference run (None: an extrapolated reference) as
    points of the map: value, error against the reference value; the preset kappa named
    explicitly is no model change."""
    for r in runs:
        if r["case"] != case or r["name"] == ref_name:
            continue
        value = r[quantity]
        # epsilon: error of the shortening 1 - epsilon (what the study measures)
        err = abs(value - reference) / abs(1 - reference if quantity == "epsilon" else reference)
        label = f"{r['element']} n={r['n']} dt={r['dt']:g}" + "".join(
            " " + s for s in r["sets"] + r.get("petsc", [])) + (
            f" ({r['solver']}, {r['ranks']} ranks)" if r["solver"] != "lu" or r["ranks"] > 1
            else "")
        out["points"].append({"case": case, "label": label, "name": r["name"],
                              "petsc": r.get("petsc", []),
                              "value": value, "error": err, "wall_time": r["wall_time"],
                              "cpu_time": r.get("cpu_time"),
                              "newton_iterations": r.get("newton_iterations"),
                              "cutbacks": r.get("cutbacks"),
                              "unknowns": r.get("unknowns"), "element": r["element"],
                              "n": r["n"], "dt": r["dt"], "sets": r["sets"],
                              "model_change": preset(r["sets"]) != list(sets),
                              "loadavg": r["loadavg_before"][0], "cpu": r.get("cpu")})


def pareto(points):
    front, best = [], math.inf
    for p in sorted(points, key=lambda p: (p["wall_time"], p["error"])):
        if p["error"] < best:
            front.append(p)
            best = p["error"]
    return front


def plot_map(analysis, path, runs):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    floor = 1e-5  # errors below this are drawn on the floor (equal to the reference)
    fig, axes = plt.subplots(1, 2, figsize=(13, 5.5))
    markers = {"Q1": "s", "Q2": "D", "P1": "^", "P2": "v", "Q1F": "o", "Q2TH": "P"}
    for ax, case, title in ((axes[0], "isometric", "isometric force F33"),
                            (axes[1], "free", "free shortening 1 - epsilon")):
        pts = [p for p in analysis["points"] if p["case"] == case]
        if case not in analysis["reference"]:
            continue
        ref = analysis["reference"][case]
        if ref.get("extrapolated"):
            # the reference is no run: its finest run's error bar (GCI) as a band
            ax.axhspan(floor, ref["gci_finest"], color="0.9", zorder=0,
                       label=f"below {report.REFERENCE_FAMILY} F-bar n = 6's GCI "
                             f"({ref['gci_finest']:.3%}): "
                             "not resolved")
            against = f"{ref['name']} ({ref['quantity']} = {ref['value']:.6g})"
        else:
            ref_run = next(r for r in runs if r["name"] == ref["name"])
            ax.loglog(ref_run["wall_time"], floor, "*", color="k", ms=14)
            ax.annotate(f"reference {ref_run['element']} n={ref_run['n']}",
                        (ref_run["wall_time"], floor), fontsize=7, xytext=(4, 4),
                        textcoords="offset points")
            against = (f"{ref_run['element']} n={ref_run['n']} "
                       f"({ref['quantity']} = {ref['value']:.6g})")
        for p in pts:
            colour = "tab:red" if p["model_change"] else (
                "tab:blue" if p["dt"] == 0.05 else "tab:gray")
            err = max(p["error"], floor)
            # wall times compare only within one CPU: hollow where the run did not record it
            ax.loglog(p["wall_time"], err, markers.get(p["element"], "o"), color=colour, ms=7,
                      mfc=colour if p.get("cpu") else "none")
            if p["model_change"]:
                text, offset = p["sets"][0].replace("kappa=", "k="), (2, -9)
            elif p["dt"] != 0.05:
                text, offset = f"dt={p['dt']:g}", (2, 5)
            else:
                quadrature = [a.split()[-1] for a in p.get("petsc", []) if "--quadrature-degree" in a]
                graded = [x.split("=")[0].replace("mesh.set.", "")
                          for x in report.mesh_numbers(p["sets"]) if "grade" in x]
                text = (f"{p['element']} n={p['n']}" + "".join(f" q{q}" for q in quadrature)
                        + "".join(f" {g}" for g in graded)
                        + ("*" if any("-snes_max_it" in a for a in p.get("petsc", [])) else ""))
                offset = (4, 2)
            ax.annotate(text, (p["wall_time"], err), fontsize=6.5, xytext=offset,
                        textcoords="offset points", color=colour)
        front = pareto([p for p in pts if not p["model_change"]])
        penalty = "preset kappa" if not analysis["sets"] else ", ".join(analysis["sets"])
        ax.loglog([p["wall_time"] for p in front], [max(p["error"], floor) for p in front],
                  "k--", lw=1, label=f"Pareto front (discretisation, {penalty})")
        for level, name in ((0.05, "5 %"), (0.01, "1 %"), (0.001, "0.1 %")):
            ax.axhline(level, color="0.6", lw=0.8, ls=":")
            ax.text(ax.get_xlim()[0] if False else 0.99, level, name, fontsize=7,
                    transform=ax.get_yaxis_transform(), ha="right", va="bottom")
        ax.set_title(f"COMBI {title} at t = 0.15 s ({penalty})\nerror against {against}",
                     fontsize=9)
        ax.set_xlabel("wall time [s] (2 cores; load, ranks, CPU: results.json)")
        ax.set_ylabel(f"relative error (floor {floor:g} = same as reference)")
        ax.grid(True, which="both", lw=0.3)
        ax.legend(fontsize=7, loc="lower left")
    fig.text(0.01, 0.01, "squares Q1, circles Q1 F-bar (Q1F; grade, grade_radial: graded meshes), diamonds Q2, plus Q2 Taylor-Hood (Q2TH), triangles P1/P2; blue: dt = 0.05 s; grey: "
             "other time steps (end state is path-independent); red: penalty kappa (a model\n"
             "change, error = distance from the preset-kappa reference); qN: quadrature degree N; *: -snes_max_it 10; "
             "filled: the run recorded its CPU, hollow: it did not (older runs; BENCHMARKS.md, section Machine)",
             fontsize=7)
    fig.tight_layout(rect=(0, 0.05, 1, 1))
    os.makedirs(os.path.dirname(path), exist_ok=True)
    fig.savefig(path, dpi=110)


def timed(command, env=None, log=None):
    """Run a command; (wall, CPU user + system of it and its children) in seconds."""
    before = os.times()
    start = time.time()
    with open(log or os.devnull, "w") as out:
        result = subprocess.run(command, env=env, stdout=out, stderr=subprocess.STDOUT)
    after = os.times()
    if result.returncode != 0:
        sys.exit(f"error: {' '.join(command)} failed (exit {result.returncode}); see {log}")
    return time.time() - start, (after.children_user - before.children_user
                                 + after.children_system - before.children_system)


def phase_fresh(args, records):
    """`tools/muscle run` in a new build tree, as on a fresh machine whose packages are
    installed: its build (configure, FFCx, compile) and the job.  FFCx is timed by a
    wrapper around the Python that CMake calls, the build's end is when its last program
    was linked; apt cannot be repeated on a machine that has the packages, so its time is
    the one given by --apt-seconds."""
    import shutil
    folder = os.path.join(args.work, "fresh")
    shutil.rmtree(folder, ignore_errors=True)
    os.makedirs(folder)
    build, out, python_log = (os.path.join(folder, x) for x in ("build", "out", "python.log"))
    wrapper = os.path.join(folder, "python3")
    with open(wrapper, "w") as f:  # one line per call: wall, user, system, command
        f.write(f'#!/bin/sh\nexec /usr/bin/time -a -o {python_log} -f "%e %U %S %C" '
                '/usr/bin/python3 "$@"\n')
    os.chmod(wrapper, 0o755)
    env = dict(os.environ, BUILD_DIR=build, OUT=out,
               MUSCLE_CMAKE_OPTIONS=f"-DMUSCLE_PYTHON={wrapper}")
    load = loadavg()
    start = time.time()
    wall, cpu = timed([os.path.join(ROOT, "tools", "muscle"), "run"], env=env,
                      log=os.path.join(folder, "run.log"))
    linked = max(os.path.getmtime(os.path.join(build, p)) for p in ("loadcases", "muscle-run"))
    with open(python_log) as f:
        calls = [line.split(maxsplit=3) for line in f if "compile_forms.py" in line]
    with open(os.path.join(build, "CMakeCache.txt")) as f:
        selection = [line.strip() for line in f
                     if line.startswith(("MUSCLE_ELEMENTS:", "MUSCLE_VARIANTS:"))]
    record = {"command": "benchmarks/run_benchmarks.py fresh", "cores": os.cpu_count(),
              "loadavg_before": load, "loadavg_after": loadavg(), "selection": selection,
              "apt_seconds": args.apt_seconds, "wall": wall, "cpu": cpu,
              "build_wall": linked - start, "run_wall": start + wall - linked,
              "ffcx": {"calls": len(calls), "cpu": sum(float(c[1]) + float(c[2]) for c in calls),
                       "wall_sum": sum(float(c[0]) for c in calls)},
              "generated_c_files": len([n for n in os.listdir(os.path.join(build, "generated"))
                                        if n.endswith(".c")]),
              "git_commit": git_commit()}
    with open(os.path.join(args.work, "fresh.json"), "w") as f:
        json.dump(record, f, indent=1)
    print(f"  build {record['build_wall']:.0f} s (FFCx CPU {record['ffcx']['cpu']:.0f} s), "
          f"run {record['run_wall']:.0f} s, CPU {cpu:.0f} s, load {load[0]:.2f}", flush=True)


def phase_report(args, records):
    """results.json from the runs in WORK (if any), then BENCHMARKS.md from results.json."""
    data = collect(args)
    if any(data.values()):
        update_results(args, data)
    else:  # e.g. a fresh machine: the page from the committed measurements
        print(f"  no runs in {args.work}: {args.results} kept as it is")
    try:
        report.write(args.results, args.markdown)
    except report.TemplateError as e:
        sys.exit(f"error: {e}")
    print(f"wrote {args.markdown}")


def update_results(args, data):
    """Rewrite results.json and the speed-accuracy maps from everything measured in WORK;
    what WORK lacks (e.g. instruction counts not re-measured, hand-made entries) is kept
    from the old results.json."""
    analysis = analysis_100 = None
    if data.get("map"):
        analysis = map_analysis(data, args.reference)
        plot_map(analysis, os.path.join(ROOT, "docs", "images", "speed_accuracy.png"),
                 list(data["map"].values()) + list(data.get("kappa", {}).values()))
        analysis_100 = map_analysis(data, None, sets=("kappa=100",))
        if analysis_100["reference"]:
            plot_map(analysis_100, os.path.join(ROOT, "docs", "images",
                                                "speed_accuracy_kappa100.png"),
                     list(kappa100_runs(data).values()))
    results = {"date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
               "git_commit": git_commit(), "machine": machine_info(), "loadavg_at_report": loadavg(),
               "note": "2-core machine shared with other builds/tests: every timing carries the "
                       "load average before/after it",
               "assembly": data.get("assembly", {}),
               "end_to_end": list(data.get("e2e", {}).values()),
               "solvers": list(data.get("solvers", {}).values()),
               "map_runs": list(data.get("map", {}).values()),
               "speed_accuracy": analysis,
               "speed_accuracy_kappa100": analysis_100,
               "instructions": data.get("instructions", {}),
               "extrapolations": extrapolate(data),
               "knob_runs": list(data.get("knobs", {}).values()),
               "fbar_runs": list(data.get("fbar", {}).values()),
               "line_search_runs": list(data.get("linesearch", {}).values()),
               "fresh_machine": data.get("fresh", {}),
               "stiff_soft_runs": list(data.get("stiffsoft", {}).values()),
               "kappa_runs": list(data.get("kappa", {}).values()),
               "taylor_hood_runs": list(data.get("taylor_hood", {}).values()),
               "experiments": data.get("experiments", {})}
    if os.path.exists(args.results):  # hand-made entries (e.g. assembly_after_fno_math_errno)
        with open(args.results) as f:
            old = json.load(f)
        for key, value in old.items():
            if not results.get(key):  # e.g. instruction counts not re-measured
                results[key] = value
            elif key == "machine" and all(value.get(k) == results[key].get(k)
                                          for k in ("Model name", "CPU(s)", "hostname")):
                # the same machine: what lscpu did not print this time (caches) stays
                results[key] = {**value, **results[key]}
            elif isinstance(value, list) and all(isinstance(r, dict) and "name" in r
                                                 for r in value + results[key]):
                # runs by name: WORK's replace the old ones, the others stay (a WORK
                # that holds only a few new runs keeps every earlier one)
                merged = {r["name"]: r for r in value}
                merged.update({r["name"]: r for r in results[key]})
                results[key] = list(merged.values())
        # the old file's order first: a diff shows what changed, not what moved
        results = {**{k: results[k] for k in old}, **results}
    with open(args.results, "w") as f:
        json.dump(results, f, indent=1)
    print(f"wrote {args.results}")
    if results.get("kappa_runs"):
        plot_kappa(results["kappa_runs"], os.path.join(ROOT, "docs", "images",
                                                      "preconditioners_kappa.png"))


# the preconditioners drawn against kappa and n: (candidate, element, colour, style)
KAPPA_PLOTTED = (
    ("GAMG", "Q1F", "tab:gray", "--"),
    ("BoomerAMG, systems", "Q1F", "tab:brown", "--"),
    ("penalty split, lower", "Q1F", "tab:blue", "-"),
    ("Taylor-Hood, Schur split", "Q2TH", "tab:orange", "-"),
    (STARS_CANDIDATE, "Q2TH", "tab:green", "-"),
    (STARS_CHEBYSHEV_CANDIDATE, "Q2TH", "tab:olive", "-."))


def plot_kappa(runs, path):
    """Krylov iterations per Newton iteration against kappa (n = 1 and 2) and against n
    (kappa = 1000) for the main preconditioners, isometric COMBI on uniform meshes; a run
    that did not finish is a cross at the top."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.6))
    ceiling = 700
    for candidate, element, colour, style in KAPPA_PLOTTED:
        mine = [r for r in runs if r.get("candidate") == candidate and r.get("element") == element
                and r.get("case") == "isometric" and r.get("model") == "combi"
                and len(r.get("sets", [])) == 1]
        label = candidate.replace("Taylor-Hood, Schur split, augmented Lagrangian, ",
                                  "Taylor-Hood, AL, ") + f" ({element})"
        # one line per Krylov tolerance (the reference study's n = 3, 4, 6 ran at 1e-4)
        for rtol in sorted({r.get("linear_rtol") for r in mine}, key=lambda t: -(t or 0)):
            same = [r for r in mine if r.get("linear_rtol") == rtol]
            suffix = ("" if rtol == 1e-6 else ", direct" if rtol is None
                      else f", linear rtol {rtol:g}")
            kappa = lambda r: float(r["sets"][0].split("=")[1])
            # against kappa: n = 1 as the line, n = 2 (where run at two kappas or more)
            # thin with triangles beside it
            for ax, chosen, x, n2 in (
                    (axes[0], [r for r in same if r.get("n") == 1], kappa, False),
                    (axes[0], [r for r in same if r.get("n") == 2], kappa, True),
                    (axes[1], [r for r in same if r["sets"] == ["kappa=1000"]
                               and r.get("unknowns") and r.get("n")],
                     lambda r: r["unknowns"], False)):
                chosen = sorted(chosen, key=x)
                done = [r for r in chosen if r.get("completed") and r.get("krylov_per_newton")]
                if n2 and len(chosen) < 2:
                    continue
                ax.plot([x(r) for r in done], [r["krylov_per_newton"] for r in done],
                        ":" if suffix else style, marker="^" if n2 else "s" if suffix else "o",
                        color=colour, lw=0.8 if n2 else 1.5, ms=4.5 if n2 else 6,
                        label=None if n2 or not done else label + suffix)
                failed = [r for r in chosen if r not in done]
                ax.plot([x(r) for r in failed], [ceiling] * len(failed), "x", color=colour,
                        ms=9)
                if ax is axes[1]:
                    for r in done:
                        ax.annotate(f"n={r['n']}", (x(r), r["krylov_per_newton"]), fontsize=6.5,
                                    xytext=(3, -9), textcoords="offset points", color=colour)
    axes[0].set_xscale("log")
    axes[0].set_xlabel("penalty kappa (circles n = 1 on one rank, triangles n = 2 on two)")
    axes[1].set_xscale("log")
    axes[1].set_xlabel("unknowns (kappa = 1000; n = 1 on one rank, larger n on two)")
    for ax, title in ((axes[0], "against kappa"), (axes[1], "against the mesh")):
        ax.set_yscale("log")
        ax.set_ylim(10, ceiling * 1.3)
        ax.set_ylabel("Krylov iterations per Newton iteration")
        ax.set_title(f"COMBI isometric, 0 -> 0.15 s: {title}", fontsize=9)
        ax.grid(True, which="both", lw=0.3)
    axes[1].legend(fontsize=7, loc="upper right")
    fig.text(0.01, 0.01, "Q1F: F-bar Q1; Q2TH: Taylor-Hood Q2-Q1; crosses at the top: the "
             "run did not finish (solve failure or timeout); phase kappa, results.json",
             fontsize=7)
    fig.tight_layout(rect=(0, 0.04, 1, 1))
    os.makedirs(os.path.dirname(path), exist_ok=True)
    fig.savefig(path, dpi=110)


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("phases", nargs="*", default=[
        "assembly", "instructions", "map-cheap", "map-n2-isometric", "e2e", "solvers-n1",
        "map-q2", "solvers-n2", "map-n2-free", "map-late", "fbar", "report"])
    parser.add_argument("--build", default=os.path.join(ROOT, "build"))
    parser.add_argument("--work", default="/tmp/muscle-bench")
    parser.add_argument("--results", default=os.path.join(HERE, "results.json"))
    parser.add_argument("--markdown", default=os.path.join(ROOT, "BENCHMARKS.md"),
                        help="where report writes the page (default: BENCHMARKS.md)")
    parser.add_argument("--reuse", action="store_true")
    parser.add_argument("--repetitions", type=int, default=7)
    parser.add_argument("--assembly-n", type=int, default=1)
    parser.add_argument("--assembly-elements", nargs="+",
                        default=["Q1", "Q2", "P1", "P2", "Q1F"])
    parser.add_argument("--instruction-elements", nargs="+", default=["Q1", "Q2", "Q1F"])
    parser.add_argument("--e2e-models", nargs="+", default=["combi"])
    parser.add_argument("--e2e-refinements", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--e2e-dt", type=float, default=0.05)
    parser.add_argument("--apt-seconds", type=float, default=None,
                        help="fresh: the time of `tools/muscle deps` on a fresh machine")
    parser.add_argument("--deadline", default=None,
                        help="UTC HH:MM: start no run after it and stop a running one there")
    parser.add_argument("--solver-refinements", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--map-dt", type=float, default=0.05)
    parser.add_argument("--map-timeout", type=float, default=1800)
    parser.add_argument("--map-extra", type=json.loads, nargs="*", default=[],
                        help='more map runs as JSON, e.g. \'{"cell": "hex", "degree": 2, '
                             '"n": 2, "dt": 0.15}\'')
    parser.add_argument("--kappas", type=float, nargs="+", default=[10, 100, 1000, 10000])
    parser.add_argument("--kappa-candidates", nargs="+", default=list(KAPPA_CANDIDATES),
                        choices=list(KAPPA_CANDIDATES))
    parser.add_argument("--kappa-refinements", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--reference-refinements", type=int, nargs="+", default=[3, 6])
    parser.add_argument("--reference-graded-refinements", type=int, nargs="+",
                        default=[2, 4, 6])
    parser.add_argument("--kappa-timeout", type=float, default=300,
                        help="seconds for an n = 1 run of phase kappa (n^3 times that at n)")
    parser.add_argument("--reference", default=None,
                        help="map reference as ELEMENT_nN (default: most unknowns)")
    args = parser.parse_args()
    if args.deadline:
        now = datetime.datetime.now(datetime.timezone.utc)
        hh, mm = (int(x) for x in args.deadline.split(":"))
        args.deadline = now.replace(hour=hh, minute=mm, second=0, microsecond=0)
    os.makedirs(os.path.join(args.work, "runs"), exist_ok=True)
    records = Records(os.path.join(args.work, "records.json"))
    records.data.setdefault("meta", {})["started"] = datetime.datetime.now(
        datetime.timezone.utc).isoformat(timespec="seconds")
    phases = {"assembly": phase_assembly, "e2e": phase_e2e, "solvers": phase_solvers,
              "map": phase_map,
              "solvers-n1": lambda a, r: phase_solvers(a, r, [1]),
              "solvers-n2": lambda a, r: phase_solvers(a, r, [2]),
              **{f"map-{g}": (lambda g: lambda a, r: phase_map(a, r, (g,)))(g)
                 for g in ("cheap", "q2", "n2-isometric", "n2-free", "late", "quadrature",
                           "taylor-hood", "taylor-hood-n2")},
              "knobs": phase_knobs, "fbar": phase_fbar, "restore": phase_restore,
              "linesearch": phase_linesearch, "fresh": phase_fresh, "stiffsoft": stiffsoft.phase,
              "stiffsoft-blocks": lambda a, r: stiffsoft.phase(a, r, ("blocks",)),
              "stiffsoft-shoulder": lambda a, r: stiffsoft.phase(a, r, ("shoulder",)),
              "kappa": phase_kappa, "kappa-n4": phase_kappa_n4, "kappa-free": phase_kappa_free,
              "kappa-th4": phase_kappa_th4,
              "reference": phase_reference,
              "taylor-hood": taylor_hood.phase,
              "taylor-hood-splits": lambda a, r: taylor_hood.phase(a, r, ("splits",)),
              "taylor-hood-sweep": lambda a, r: taylor_hood.phase(a, r, ("sweep",)),
              "instructions": phase_instructions, "report": phase_report}
    for phase in args.phases:
        print(f"== {phase}", flush=True)
        phases[phase](args, records)


if __name__ == "__main__":
    sys.exit(main())
