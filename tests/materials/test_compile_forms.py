"""compile_forms.py --elements: a build for one job compiles only its elements.

Only the lists and the registry are written here (no FFCx run), so this is quick;
that a left-out element stops a run with an input error is tested in C++
(test_anti_locking.cpp, ElementsOfTheBuild)."""
import pathlib
import re
import subprocess
import sys

import pytest

COMPILE = pathlib.Path(__file__).resolve().parents[2] / "forms" / "compile_forms.py"


def compile_forms(tmp_path, *args):
    return subprocess.run([sys.executable, str(COMPILE), "--out", str(tmp_path), *args],
                          capture_output=True, text=True)


def cmake_lists(tmp_path, elements):
    assert compile_forms(tmp_path, "--cmake", str(tmp_path / "laws.cmake"),
                         "--elements", elements).returncode == 0
    text = (tmp_path / "laws.cmake").read_text()
    return set(re.findall(r"(\w+)\.c\b", text))


def test_element_subset_lists(tmp_path):
    every = cmake_lists(tmp_path / "all", "all")
    hex1 = cmake_lists(tmp_path / "hex1", "hex1")
    assert hex1 < every
    assert {"combi_hex1_q2", "combi_hex1_q2_fbar", "ble_hex1_q2_v1", "mp_combi",
            "fibre_hex", "loads_hex1"} <= hex1
    # nothing of another element is compiled, every file of hex1 is
    assert not [f for f in hex1 if re.search(r"hex2|tet", f)]
    assert {f for f in every if not re.search(r"hex2|tet", f)} == hex1
    tets = cmake_lists(tmp_path / "tet", "tet1,tet2")
    assert "fibre_tet" in tets and "fibre_hex" not in tets
    assert not [f for f in tets if "hex" in f]


def test_element_subset_registry(tmp_path):
    assert compile_forms(tmp_path, "--registry", "--elements", "hex1,hex2").returncode == 0
    text = (tmp_path / "form_registry.cpp").read_text()
    assert 'compiled_elements() { return "hex1,hex2"; }' in text
    assert '"tetrahedron"' not in text and "_tet" not in text
    assert "combi_hex2_q4.h" in text


@pytest.mark.parametrize("elements", ["hex3", "", "hex1,prism1"])
def test_element_subset_bad_input(tmp_path, elements):
    result = compile_forms(tmp_path, "--cmake", str(tmp_path / "laws.cmake"),
                           "--elements", elements)
    assert result.returncode != 0
    assert "expected all or a list of hex1, hex2, tet1, tet2" in result.stderr


MAIN_JOB = "_hex1_q2$|^combi_hex1_q2_fbar$"  # tools/muscle run's selection


def test_element_subset_variants(tmp_path):
    assert compile_forms(tmp_path, "--cmake", str(tmp_path / "laws.cmake"), "--elements",
                         "hex1", f"--variants={MAIN_JOB}").returncode == 0
    files = set(re.findall(r"(\w+)\.c\b", (tmp_path / "laws.cmake").read_text()))
    assert {"combi_hex1_q2_fbar", "ble_hex1_q2", "giant_hex1_q2", "wkm_hex1_q2",
            "mp_ble"} <= files
    assert not {"ble_hex1_q2_fbar", "ble_hex1_q2_v1", "combi_hex2_q4"} & files
    assert compile_forms(tmp_path, "--registry", "--elements", "hex1",
                         f"--variants={MAIN_JOB}").returncode == 0
    text = (tmp_path / "form_registry.cpp").read_text()
    assert 'compiled_variants() { return "_hex1_q2$|^combi_hex1_q2_fbar$"; }' in text


def test_element_subset_bad_regex(tmp_path):
    result = compile_forms(tmp_path, "--cmake", str(tmp_path / "l.cmake"), "--variants=(")
    assert result.returncode != 0 and "not a regular expression" in result.stderr
