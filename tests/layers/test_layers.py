"""The libraries' layers: a file includes only its own layer and the ones below.

The order, lowest first, is LAYERS; docs/architecture.md draws it.  A failure names the
file, the line and the include that points upwards.
"""
import os
import re

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CPP = os.path.join(ROOT, "cpp")

# lowest first; a folder of cpp/ (or of cpp/fem) is one layer
LAYERS = [
    "common", "forms", "material", "io",
    "fem/geometry", "fem/elements", "fem/terms", "fem/constraints", "fem/contact",
    "fem/linear", "fem/newton", "fem/time", "fem/analysis",
    "loadcases", "scene", "fit",
]
# the libraries beside each other at the top see nothing of each other
SIBLINGS = {frozenset({"scene", "fit"}), frozenset({"loadcases", "scene"}),
            frozenset({"loadcases", "fit"})}
INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"')


def layer_of(path):
    """The layer of a path relative to cpp/ (the longest matching folder)."""
    best = None
    for layer in LAYERS:
        if path.startswith(layer + "/") and (best is None or len(layer) > len(best)):
            best = layer
    return best


def sources():
    for folder, _, files in os.walk(CPP):
        for name in sorted(files):
            if name.endswith((".h", ".cpp")):
                path = os.path.join(folder, name)
                yield os.path.relpath(path, CPP), path


def test_every_file_has_a_layer():
    unplaced = [rel for rel, _ in sources() if layer_of(rel) is None]
    assert not unplaced, f"files of cpp/ outside every layer of LAYERS: {unplaced}"


def upward_includes():
    for rel, path in sources():
        own = layer_of(rel)
        with open(path) as f:
            for number, line in enumerate(f, 1):
                m = INCLUDE.match(line)
                if not m or not os.path.exists(os.path.join(CPP, m.group(1))):
                    continue  # a system or generated header
                target = layer_of(m.group(1))
                if target is None or target == own:
                    continue
                if (LAYERS.index(target) > LAYERS.index(own)
                        or frozenset({own, target}) in SIBLINGS):
                    yield f"cpp/{rel}:{number}: #include \"{m.group(1)}\" ({own} -> {target})"


def test_includes_point_downwards():
    wrong = list(upward_includes())
    assert not wrong, "includes from a lower layer into a higher one:\n" + "\n".join(wrong)


def test_the_check_sees_an_upward_include(tmp_path, monkeypatch):
    # the check itself must be able to fail: a geometry file that includes newton
    fem = tmp_path / "fem"
    (fem / "geometry").mkdir(parents=True)
    (fem / "newton").mkdir()
    (fem / "newton" / "solver.h").write_text("#pragma once\n")
    (fem / "geometry" / "bad.cpp").write_text('#include "fem/newton/solver.h"\n')
    monkeypatch.setattr(__import__(__name__), "CPP", str(tmp_path))
    assert [w.split(": ", 1)[0] for w in upward_includes()] == ["cpp/fem/geometry/bad.cpp:1"]
