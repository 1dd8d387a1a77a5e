"""Phase stiffsoft of run_benchmarks.py: GAMG's near-null space and block size on tied
bodies of growing stiffness contrast (demos/scenes/stiff_soft.yaml), and the shoulder's
first steps (demos/scenes/shoulder.yaml), against MUMPS.  Runs go to WORK/stiffsoft/NAME
(summary.json, series.csv, time.txt, record.json); --reuse keeps completed ones."""
import glob
import json
import os
import shlex
import signal
import subprocess
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

# the bone's E per unit contrast: the muscle's C_1111 at rest (COMBI, Table fitting_all,
# kappa = 10: 309.77 kPa) over SVK's C_1111 / E at nu = 0.3 (1.346154)
E_PER_CONTRAST = 309.77 / 1.346154
CONTRASTS = (1, 10, 100, 1e3, 1e4, 1e5)
# name: (linear solver, near-null space, reduced block size 3 where whole nodes)
CONFIGS = {
    "lu": ("lu", None, None),
    "gamg-global-bs1": ("gmres-gamg", "global", False),   # before: global modes, scalar
    "gamg-global": ("gmres-gamg", "global", True),
    "gamg-bodies-bs1": ("gmres-gamg", "bodies", False),
    "gamg-bodies": ("gmres-gamg", "bodies", True),        # the default
}
SHOULDER_CONFIGS = ("lu", "gamg-global-bs1", "gamg-global", "gamg-bodies")
SHOULDER_END = 0.001  # 4 steps of 2.5e-4 s
BLOCKS_END = 0.02     # 2 steps of the scene's 0.01 s


def loadavg():
    with open("/proc/loadavg") as f:
        return [float(x) for x in f.read().split()[:3]]


def run_with_timeout(command, timeout):
    """(exit status or "timeout", stderr) of a command.  On the timeout its whole process
    group is killed: killing only the child (/usr/bin/time) left mpirun's ranks running,
    loading the machine under the runs that followed."""
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True, start_new_session=True)
    try:
        _, stderr = process.communicate(timeout=timeout)
        return process.returncode, stderr
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        process.communicate()
        return "timeout", f"killed after {timeout} s"
    except BaseException:  # Ctrl-C no longer reaches the new session: take it down too
        os.killpg(process.pid, signal.SIGKILL)
        raise


def config_sets(config):
    solver, nns, blocks = CONFIGS.get(config, (None, None, None))
    sets = [f"solver.linear={solver}"]
    if nns:
        sets += [f"solver.near_null_space={nns}",
                 f"solver.reduced_blocks={'true' if blocks else 'false'}"]
    return sets


def run(args, study, config, scene, sets, name, extra, timeout=1800, folder="stiffsoft"):
    """One muscle-run (one rank) of `scene` with `sets` and the config's solver options
    (config None: the scene's and the sets' own), into WORK/folder/name."""
    out = os.path.join(args.work, folder, name)
    record_path = os.path.join(out, "record.json")
    if args.reuse and os.path.exists(record_path):
        with open(record_path) as f:
            print(f"  reuse {name}", flush=True)
            return json.load(f)
    os.makedirs(out, exist_ok=True)
    command = [os.path.join(args.build, "muscle-run"), scene, "--out", out, "--quiet"]
    for s in list(sets) + (config_sets(config) if config else []):
        command += ["--set", s]
    time_file = os.path.join(out, "time.txt")
    timed = ["/usr/bin/time", "-f", "%M %e %U %S", "-o", time_file, *command]
    before = loadavg()
    print("  " + " ".join(shlex.quote(c) for c in command), flush=True)
    start = time.time()
    returncode, stderr = run_with_timeout(timed, timeout)
    solver, nns, blocks = CONFIGS.get(config, (None, None, None))
    record = {"name": name, "study": study, "config": config, "solver": solver,
              "near_null_space": nns, "reduced_blocks": blocks, "ranks": 1, **extra,
              "command": " ".join(shlex.quote(c) for c in command),
              "elapsed": time.time() - start, "loadavg_before": before,
              "loadavg_after": loadavg(), "returncode": returncode, "completed": False}
    summary_path = os.path.join(out, "summary.json")
    if os.path.exists(summary_path) and os.path.getmtime(summary_path) >= start - 1:
        with open(summary_path) as f:
            summary = json.load(f)
        record.update({k: summary.get(k) for k in (
            "completed", "steps", "newton_iterations", "linear_iterations", "cutbacks",
            "wall_time", "final")})
        built = summary.get("built", {})
        record.update(unknowns=built.get("unknowns"), bodies=built.get("bodies"),
                      solve_s=summary.get("timings", {}).get("solve_s"))
    if os.path.exists(time_file):
        try:
            with open(time_file) as f:
                record["peak_rss_MiB"] = round(int(f.read().split()[-4]) / 1024, 1)
        except (ValueError, IndexError):
            pass
    if returncode != 0:
        record["error"] = stderr.strip()[-400:]
    print(f"    {record['elapsed']:.1f} s  load {before[0]:.2f}  "
          f"newton={record.get('newton_iterations')} krylov={record.get('linear_iterations')} "
          f"exit {returncode}", flush=True)
    with open(record_path, "w") as f:
        json.dump(record, f, indent=1)
    return record


def phase(args, records, parts=("blocks", "shoulder")):
    scene = os.path.join(ROOT, "demos", "scenes", "stiff_soft.yaml")
    for contrast in CONTRASTS if "blocks" in parts else ():
        E = contrast * E_PER_CONTRAST
        for config in CONFIGS:
            r = run(args, "stiff_soft", config, scene,
                    [f"parts[0].material.parameters.E={E:.6g}", f"time.end={BLOCKS_END}"],
                    f"stiff_soft_c{contrast:g}_{config}", {"contrast": contrast, "E": E})
            records.put("stiffsoft", r["name"], r)
    scene = os.path.join(ROOT, "demos", "scenes", "shoulder.yaml")
    for config in SHOULDER_CONFIGS if "shoulder" in parts else ():
        r = run(args, "shoulder", config, scene,
                [f"time.end={SHOULDER_END}", "output.fields=false", "output.plots=false"],
                f"shoulder_t{SHOULDER_END:g}_{config}", {"t_end": SHOULDER_END}, timeout=3600)
        records.put("stiffsoft", r["name"], r)


def collect(work):
    """The records of this phase in WORK, by name."""
    out = {}
    for path in sorted(glob.glob(os.path.join(work, "stiffsoft", "*", "record.json"))):
        with open(path) as f:
            r = json.load(f)
        out[r["name"]] = r
    return out
