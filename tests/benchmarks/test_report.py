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
