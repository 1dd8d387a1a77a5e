"""pytest set-up shared by the Python tests (tests/scenes, tests/fusiform).

--build DIR names the CMake build directory whose binaries (muscle-run, fusiform)
are tested; ctest passes its own.  Measured values a test reports through
`record` are printed in a section "measured" at the end of the run, whether the
test passed or not.
"""
import os
import tempfile

import pytest

# OpenMPI refuses root unless told; the tests that launch mpirun inherit this
os.environ.setdefault("OMPI_ALLOW_RUN_AS_ROOT", "1")
os.environ.setdefault("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")


def pytest_addoption(parser):
    parser.addoption("--build", metavar="DIR",
                     help="CMake build directory with the binaries under test (muscle-run, fusiform)")
    parser.addoption("--fusiform-dt", type=float, metavar="DT",
                     help="time step of the fusiform test_run_* runs (default: fusiform's own, "
                          "0.01 s on Q2)")


@pytest.fixture(scope="session")
def build(request):
    """The build directory given by --build (absolute)."""
    path = request.config.getoption("--build")
    if not path:
        pytest.fail("give the build directory: --build DIR", pytrace=False)
    if not os.path.isdir(path):
        pytest.fail(f"--build {path}: no such directory", pytrace=False)
    return os.path.abspath(path)


@pytest.fixture
def scratch():
    """A temporary directory for one test, removed afterwards."""
    with tempfile.TemporaryDirectory(prefix="muscle-test-") as path:
        yield path


@pytest.fixture(scope="module")
def module_scratch():
    """A temporary directory shared by the tests of one module (runs made once)."""
    with tempfile.TemporaryDirectory(prefix="muscle-test-") as path:
        yield path


_measured = []


@pytest.fixture(scope="session")
def record():
    """record(line): a measured value worth seeing in the log even when the test passes
    (each line once)."""
    def add(line):
        if line not in _measured:
            _measured.append(line)
    return add


def pytest_terminal_summary(terminalreporter):
    if _measured:
        terminalreporter.section("measured")
        for line in _measured:
            terminalreporter.write_line(line)
