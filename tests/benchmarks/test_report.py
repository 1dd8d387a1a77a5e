"""BENCHMARKS.md is generated: it must equal what `run_benchmarks.py report` writes
from the committed benchmarks/results.json and benchmarks/BENCHMARKS.md.in, so that
an edit by hand (or a template change without the regenerated page) fails here."""
import difflib
import os
import shutil
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DRIVER = os.path.join(ROOT, "benchmarks", "run_benchmarks.py")
PAGE = os.path.join(ROOT, "BENCHMARKS.md")


def test_report_equals_committed_page(tmp_path):
    # a copy of results.json and an empty WORK: the report rewrites nothing in the tree
    results = tmp_path / "results.json"
    shutil.copy(os.path.join(ROOT, "benchmarks", "results.json"), results)
    page = tmp_path / "BENCHMARKS.md"
    run = subprocess.run([sys.executable, DRIVER, "report", "--work", str(tmp_path / "work"),
                          "--results", str(results), "--markdown", str(page)],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr
    generated, committed = page.read_bytes(), open(PAGE, "rb").read()
    if generated != committed:
        diff = difflib.unified_diff(committed.decode().splitlines(),
                                    generated.decode().splitlines(), "BENCHMARKS.md (committed)",
                                    "BENCHMARKS.md (report)", lineterm="", n=1)
        lines = list(diff)
        raise AssertionError(
            "BENCHMARKS.md differs from the report; edit benchmarks/BENCHMARKS.md.in, not the "
            "page, then run `/usr/bin/python3 benchmarks/run_benchmarks.py report` and commit "
            "BENCHMARKS.md:\n" + "\n".join(lines[:40])
            + (f"\n... ({len(lines) - 40} more lines)" if len(lines) > 40 else ""))


def test_richardson_recovers_a_power_law():
    # f = f0 + C h^p sampled on meshes in the ratios 3 : 1.5 : 1 (the fusiform's n = 2,
    # 4, 6) and 4 : 2 : 1: the extrapolation must return p, f0 and the law between them
    sys.path.insert(0, os.path.join(ROOT, "benchmarks"))
    from report import richardson
    for h, p, f0, c in (((3.0, 1.5, 1.0), 1.1, 34_400.0, 120.0),
                        ((4.0, 2.0, 1.0), 2.0, 1.0, -0.5),
                        ((3.0, 1.5, 1.0), 0.3, -2.0, 7.0)):
        law = lambda size: f0 + c * size ** p
        x = richardson(*(law(s) for s in h), h=h)
        assert x["verdict"] == "monotone"
        assert abs(x["p"] - p) < 1e-9 and abs(x["value"] - f0) < 1e-9 * max(1, abs(f0))
        assert abs(x["at"](2.0) - law(2.0)) < 1e-8 * max(1, abs(f0))
        assert abs(x["gci"] - 1.25 * abs(c * h[2] ** p / law(h[2]))) < 1e-9
    # differences that do not shrink, and an oscillation, have no extrapolation
    assert richardson(3.0, 2.0, 1.0, h=(3.0, 1.5, 1.0))["verdict"].startswith("not converging")
    # changes that shrink (120, then 80) but by less than h's ratios allow at any p > 0
    assert richardson(210.0, 90.0, 10.0, h=(3.0, 1.5, 1.0))["verdict"].startswith("no positive")
    assert richardson(1.0, 2.0, 1.0)["verdict"] == "oscillating"
