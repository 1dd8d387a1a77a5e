"""compile_forms.py: what it lists and what it refuses, without running FFCx (quick).

--elements: a build for one job compiles only its elements; that a left-out element stops
a run with an input error is tested in C++ (test_anti_locking.cpp, ElementsOfTheBuild).

Broken law files (test_broken_law_*): the configure step (--cmake) checks every law file
before anything is compiled and stops with one line "error: FILE:LINE: what is wrong" and
exit status 1; CMakeLists.txt prints that line as its FATAL_ERROR."""
import os
import pathlib
import re
import subprocess
import sys
import textwrap

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
COMPILE = ROOT / "forms" / "compile_forms.py"
sys.path.insert(0, str(ROOT / "forms"))
from muscleforms import law as law_module  # noqa: E402


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


# ---------------------------------------------------------------- broken law files --

GOOD = """\
\"\"\"A user's law.\"\"\"
from muscleforms.law import PASSIVE_LAW, positive

PARAMETERS = [positive("c1", 1.0, "kPa", "modulus")]
ACTIVATION = PASSIVE_LAW


def energy(kin, p, drive):
    return p["c1"] * kin.I1_m3
"""

EHRET = """\
\"\"\"A user's active-strain law.\"\"\"
from muscleforms.law import omega_kernel
from muscleforms.parts import EHRET_ACTIVE_PARAMETERS, EHRET_MATRIX_PARAMETERS, ehret_energy

PARAMETERS = EHRET_MATRIX_PARAMETERS + EHRET_ACTIVE_PARAMETERS
ACTIVATION = omega_kernel("wkm", taylor_order=1)
PASSIVE = "ehret_passive"


def energy(kin, p, drive):
    return ehret_energy(kin, p, drive.omega)
"""


def line_of(text, fragment):
    return next(i for i, line in enumerate(text.splitlines(), 1) if fragment in line)


# (id, file text, (the line's fragment or None), words the message has)
BROKEN = [
    ("syntax error", GOOD.replace('"modulus")]', '"modulus")'), "PARAMETERS =",
     ["syntax error", "never closed"]),
    ("undeclared parameter", GOOD.replace('p["c1"] * kin', 'p["c1"] * kin.J + p["bfs"] * kin'),
     'p["bfs"]', ["parameter 'bfs' is used but not declared; declared: c1"]),
    ("undeclared parameter in a shared part",
     GOOD.replace("import PASSIVE_LAW, positive", "import PASSIVE_LAW, positive\n"
                  "from muscleforms.parts import ehret_energy")
         .replace('return p["c1"] * kin.I1_m3', "return ehret_energy(kin, p, None)"),
     "return ehret_energy", ["parameter '", "is used but not declared; declared: c1",
                              "parts.py:"]),
    ("unknown omega kernel", EHRET.replace('omega_kernel("wkm"', 'omega_kernel("hill"'),
     "ACTIVATION =", ["omega kernel 'hill' is not a C++ kernel; registered: giant, wkm",
                      "MUSCLE_OMEGA_KERNEL in cpp/material/activation_kernels.cpp"]),
    ("bad taylor order", EHRET.replace("taylor_order=1", "taylor_order=3"), "ACTIVATION =",
     ["taylor_order 3"]),
    ("omega kernel without its parameters",
     EHRET.replace("EHRET_MATRIX_PARAMETERS + EHRET_ACTIVE_PARAMETERS", "EHRET_MATRIX_PARAMETERS"),
     "ACTIVATION =", ["the wkm omega kernel reads lambda_min, lambda_opt, P_opt"]),
    ("energy missing", GOOD[:GOOD.index("def energy")], None,
     ["a law file declares PARAMETERS, ACTIVATION and energy(); energy is missing"]),
    ("activation missing", GOOD.replace("ACTIVATION = PASSIVE_LAW\n", ""), None,
     ["ACTIVATION is missing"]),
    ("parameters not a list", GOOD.replace('[positive("c1", 1.0, "kPa", "modulus")]', '"c1"'),
     "PARAMETERS =", ["PARAMETERS is a list of parameters"]),
    ("activation not an activation", GOOD.replace("= PASSIVE_LAW", '= "passive"'),
     "ACTIVATION =", ["ACTIVATION is PASSIVE_LAW, TANH_LEVEL or omega_kernel(...)"]),
    ("parameter twice", GOOD.replace('"modulus")]', '"modulus"), positive("c1", 2.0, "-", "x")]'),
     "PARAMETERS =", ["parameters declared twice: c1"]),
    ("preset outside its range", GOOD.replace("1.0,", "-1.0,"), "PARAMETERS =",
     ["parameter c1: preset -1.0 outside"]),
    ("error while the file runs", GOOD.replace("ACTIVATION = PASSIVE_LAW", "ACTIVATION = PASIVE_LAW"),
     "ACTIVATION =", ["NameError", "PASIVE_LAW"]),
    ("unknown kinematic quantity", GOOD.replace("kin.I1_m3", "kin.I7"), "kin.I7",
     ["the kinematics have no 'I7'", "I1_m3"]),
    ("fit parameter not declared", GOOD.replace("ACTIVATION = PASSIVE_LAW",
                                                'ACTIVATION = PASSIVE_LAW\nFIT_PARAMETERS = ["c2"]'),
     "FIT_PARAMETERS", ["FIT_PARAMETERS: c2 not declared; declared: c1"]),
    ("unknown role", GOOD.replace("ACTIVATION = PASSIVE_LAW",
                                  'ACTIVATION = PASSIVE_LAW\nDEFAULT_FOR = ("musle",)'),
     "DEFAULT_FOR", ["DEFAULT_FOR: unknown role 'musle'; roles: muscle, fit, paper"]),
    ("role as a string", GOOD.replace("ACTIVATION = PASSIVE_LAW",
                                      'ACTIVATION = PASSIVE_LAW\nDEFAULT_FOR = "muscle"'),
     "DEFAULT_FOR", ["DEFAULT_FOR is a tuple of roles"]),
    ("second muscle default", GOOD.replace("ACTIVATION = PASSIVE_LAW",
                                           'ACTIVATION = PASSIVE_LAW\nDEFAULT_FOR = ("muscle",)'),
     "DEFAULT_FOR", ['DEFAULT_FOR "muscle" names one law', "combi.py:"]),
    ("passive names no law", EHRET.replace('PASSIVE = "ehret_passive"', 'PASSIVE = "ehret"'),
     "PASSIVE =", ["PASSIVE = 'ehret' is not a law"]),
]


def configure(tmp_path, *law_files, env=None):
    return subprocess.run([sys.executable, str(COMPILE), "--out", str(tmp_path / "gen"),
                           "--cmake", str(tmp_path / "laws.cmake"),
                           *[a for f in law_files for a in ("--material", str(f))]],
                          capture_output=True, text=True, env=env, timeout=120)


@pytest.mark.parametrize("case", BROKEN, ids=[c[0] for c in BROKEN])
def test_broken_law_stops_the_configure(tmp_path, case):
    what, text, fragment, words = case
    law = tmp_path / "users_law.py"
    law.write_text(text)
    result = configure(tmp_path, law)
    message = result.stderr.strip()
    assert result.returncode == 1, f"{what}: exit {result.returncode}, stderr: {result.stderr}"
    assert len(message.splitlines()) == 1, f"{what}: not one line:\n{message}"
    where = f"{law}:{line_of(text, fragment)}: " if fragment else f"{law}: "
    assert message.startswith("error: " + where), f"{what}: expected {where!r} in {message!r}"
    for word in words:
        assert word in message, f"{what}: {word!r} not in {message!r}"
    assert "python3-ffcx" not in message, f"{what}: the FFCx hint is for a failed import only"
    assert not (tmp_path / "laws.cmake").exists(), f"{what}: the lists were written"


def test_broken_law_good_file_passes(tmp_path):
    # the cases above differ from this file by their mistake only
    law = tmp_path / "users_law.py"
    law.write_text(GOOD)
    result = configure(tmp_path, law)
    assert result.returncode == 0, result.stderr
    assert "users_law_hex1_q2.c" in (tmp_path / "laws.cmake").read_text()
    ehret = tmp_path / "users_ehret.py"
    ehret.write_text(EHRET)
    assert configure(tmp_path, ehret).returncode == 0


def test_broken_law_missing_ffcx_is_the_only_hint(tmp_path):
    # a UFL that cannot be imported: the message says so and asks for python3-ffcx
    fake = tmp_path / "fake" / "ufl"
    fake.mkdir(parents=True)
    (fake / "__init__.py").write_text("raise ImportError('no UFL here')\n")
    env = dict(os.environ, PYTHONPATH=str(fake.parent))
    result = configure(tmp_path, env=env)
    assert result.returncode == 1, result.stderr
    message = result.stderr.strip()
    assert len(message.splitlines()) == 1 and "no UFL here" in message, message
    assert "is python3-ffcx installed?" in message, message


def test_broken_law_kernel_registered_twice(tmp_path):
    source = tmp_path / "kernels.cpp"
    source.write_text(textwrap.dedent("""\
        OmegaTaylor a(double, double, const EhretParameters&, double);
        MUSCLE_OMEGA_KERNEL("wkm", a);
        // MUSCLE_OMEGA_KERNEL("in a comment", a); is not at the start of a line
        MUSCLE_OMEGA_KERNEL("giant", b);
          MUSCLE_OMEGA_KERNEL("wkm", c);
        """))
    with pytest.raises(law_module.LawError, match=r"kernels.cpp:5: omega kernel 'wkm' is "
                                                  r"registered twice \(first at line 2\)"):
        law_module.omega_kernels(source)
    source.write_text('MUSCLE_OMEGA_KERNEL("wkm", a);\n\nMUSCLE_OMEGA_KERNEL( "giant", b);\n')
    assert law_module.omega_kernels(source) == {"wkm": 1, "giant": 3}


def test_broken_law_kernels_of_the_tree():
    # the names the build reads from activation_kernels.cpp (C++: OmegaKernels.*)
    assert set(law_module.omega_kernels()) == {"wkm", "giant"}
