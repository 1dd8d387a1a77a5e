"""What the Python tests share: reading what a run wrote, and its finiteness
(nlohmann writes NaN and inf as null)."""
import json
import math
import os


def read_json(path):
    """A JSON file's content (None if there is none, or it is not JSON)."""
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError):
        return None


def finite_json(value):
    """No NaN, inf or null anywhere in a parsed JSON value."""
    if isinstance(value, dict):
        return all(finite_json(v) for v in value.values())
    if isinstance(value, list):
        return all(finite_json(v) for v in value)
    return value is not None and (not isinstance(value, float) or math.isfinite(value))


def all_finite(rows):
    """Every value of every row of a series.csv (csv.DictReader rows) is a finite number."""
    return all(math.isfinite(float(v)) for r in rows for v in r.values())


def muscle_run(build, scene, out, sets=(), ranks=1, timeout=1200, options=()):
    """build/muscle-run SCENE --out OUT OPTIONS --set S ... (under mpirun for ranks > 1)."""
    import subprocess
    command = [os.path.join(build, "muscle-run"), scene, "--out", out, *options]
    for s in sets:
        command += ["--set", s]
    if ranks > 1:
        command = ["mpirun", "--allow-run-as-root", "--oversubscribe", "-n", str(ranks)] + command
    return subprocess.run(command, capture_output=True, text=True, timeout=timeout)


def series_rows(out):
    """The rows of OUT/series.csv as dicts of floats."""
    with open(os.path.join(out, "series.csv")) as f:
        lines = [line.strip().split(",") for line in f if line.strip()]
    return [dict(zip(lines[0], map(float, row))) for row in lines[1:]]


def kill_after(build, scene, out, step, ranks=1, extra=()):
    """Start build/muscle-run SCENE --out OUT and kill it once its checkpoint has reached
    output step `step`; the checkpoint state it saw last."""
    import json
    import signal
    import subprocess
    import time
    command = [os.path.join(build, "muscle-run"), scene, "--out", out, "--quiet"] + list(extra)
    if ranks > 1:
        command = ["mpirun", "--allow-run-as-root", "--oversubscribe", "-n", str(ranks)] + command
    p = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                         start_new_session=True)
    state = None
    while p.poll() is None:
        try:
            with open(os.path.join(out, "checkpoint.json")) as f:
                state = json.load(f)
            if state["step"] >= step:
                break
        except (OSError, ValueError):
            pass
        time.sleep(0.02)
    os.killpg(p.pid, signal.SIGKILL)
    p.wait()
    return state
