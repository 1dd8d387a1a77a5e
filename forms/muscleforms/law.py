"""What a material-law file declares, and how the build finds the law files.

A law is one Python file (forms/materials/<name>.py, or any file named in
MUSCLE_MATERIALS) whose name is the law's name.  It declares:

  PARAMETERS   list of Parameter: name, preset, unit, admissible range, meaning
  ACTIVATION   what drives the activation (PASSIVE_LAW, TANH_LEVEL, omega_kernel(...))
  energy(kin, p, drive)
               the strain-energy density: kin the kinematics (kinematics.py), p the
               parameters as UFL constants by name, drive.level / drive.omega the
               activation (None in the passive counterpart: build no active term)
optional:
  PASSIVE      the law whose kernels stand for the passive state (default: this
               file with drive = None, compiled as "<name>_passive")
  volumetric_stiff_part(kin, p)
               the near-incompressibility part with zero stress at J = 1; given, the
               law also gets the anti-locking Q1 (that part on one point per cell)
  FIT_PARAMETERS  parameters the fit frees by default (default: all but kappa and
               the time function's)
  DEFAULT_FOR  the roles (ROLES) in which the programs take this law when none is
               named, e.g. ("muscle",): a scene part without a material

The docstring's first line is the law's one-line description.  Everything the C++
knows of a law -- the list of laws, parameter specs, presets, ranges, activation,
passive kernels, defaults -- is generated from these declarations (compile_forms.py).

load_laws checks every file before anything is compiled (compile_forms.py --cmake, at
CMake's configure step): a mistake is one LawError "FILE:LINE: what is wrong".
"""

import ast
import importlib.util
import math
import pathlib
import re
import traceback
from dataclasses import dataclass, field

ROOT = pathlib.Path(__file__).resolve().parents[2]

INF = math.inf


@dataclass(frozen=True)
class Parameter:
    name: str
    preset: float
    unit: str          # mm, s, kPa (= mN/mm^2), mN; "-" if dimensionless
    meaning: str
    lower: float = 0.0
    upper: float = INF
    lower_open: bool = True
    upper_open: bool = True


def positive(name, preset, unit, meaning):
    return Parameter(name, preset, unit, meaning)


def nonnegative(name, preset, unit, meaning):
    return Parameter(name, preset, unit, meaning, lower_open=False)


def interval(name, preset, lower, upper, unit, meaning, lower_open=False, upper_open=False):
    return Parameter(name, preset, unit, meaning, lower, upper, lower_open, upper_open)


def real(name, preset, unit, meaning):
    return Parameter(name, preset, unit, meaning, -INF, INF)


# Parameters of the time functions (C++ only: cpp/material/time_functions.cpp).
TANH_PARAMETERS = [positive("c", 34.4017, "1/s", "frequency of the tanh activation"),
                   real("t0", 0.0, "s", "activation start time")]


def _twitch_parameters():
    out = [nonnegative("N_a", 0.4619, "1/mm^2", "activated motor units per reference area")]
    for k, (F, T, rho) in enumerate(zip((2.5, 4.4, 76.8), (0.02, 0.011, 0.011),
                                        (0.05, 0.29, 0.66)), start=1):
        out += [nonnegative(f"F_{k}", F, "mN", f"twitch force of type {k}"),
                positive(f"T_{k}", T, "s", "twitch contraction time"),
                positive(f"I_{k}", 0.004, "s", "interstimulus interval"),
                interval(f"rho_{k}", rho, 0, 1, "-", f"fraction of motor-unit type {k}")]
    return out


TWITCH_PARAMETERS = _twitch_parameters()


@dataclass(frozen=True)
class Activation:
    """drive: "none" (passive law), "level" (time factor x element scale, as UFL
    coefficients) or "omega_kernel" (omega_a from a C++ quadrature-point kernel,
    cpp/material/activation_kernels.cpp, fed to the forms as a Taylor polynomial).
    time_function: "none", "tanh" or "twitch_train" (its parameters are appended to
    the law's).  stress_holds_omega: the stress treats omega_a as fixed (WKM)."""
    drive: str = "none"
    time_function: str = "none"
    kernel: str = ""
    taylor_order: int = 0
    stress_holds_omega: bool = False

    @property
    def parameters(self):
        return {"none": [], "tanh": TANH_PARAMETERS,
                "twitch_train": TANH_PARAMETERS + TWITCH_PARAMETERS}[self.time_function]


PASSIVE_LAW = Activation()
TANH_LEVEL = Activation("level", "tanh")
TIME_FUNCTIONS = ("none", "tanh", "twitch_train")

# The C++ quadrature-point kernels register themselves where they are defined,
# MUSCLE_OMEGA_KERNEL("name", function) in this file; the build reads their names here.
KERNEL_SOURCE = ROOT / "cpp" / "material" / "activation_kernels.cpp"
_KERNEL_REGISTRATION = re.compile(r'^[ \t]*MUSCLE_OMEGA_KERNEL\([ \t]*"([^"]*)"', re.M)


def omega_kernels(source=KERNEL_SOURCE):
    """{name: line} of the kernels registered in the C++ source; LawError on a
    name registered twice."""
    text = pathlib.Path(source).read_text()
    out = {}
    for match in _KERNEL_REGISTRATION.finditer(text):
        name, line = match.group(1), text.count("\n", 0, match.start()) + 1
        if name in out:
            raise LawError(f"{source}:{line}: omega kernel {name!r} is registered twice "
                           f"(first at line {out[name]})")
        out[name] = line
    return out


def omega_kernel(kernel, taylor_order, time_function="twitch_train", stress_holds_omega=False):
    """omega_a from the C++ kernel registered as `kernel` (load_law checks the name)."""
    return Activation("omega_kernel", time_function, kernel, taylor_order, stress_holds_omega)


# What a law can be the default for (DEFAULT_FOR): role -> (exactly one law, meaning).
# The C++ asks for a role's law by name (muscle::default_model, models_for).
ROLES = {
    "muscle": (True, "the law of a muscle when none is named: a scene part without a "
                     "material, fusiform --model"),
    "fit": (True, "the law a fit result holds before it is fitted"),
    "paper": (False, "one of the paper's models: loadcases --model all, bench-assembly's "
                     "--models, the tests of the paper's findings"),
}


@dataclass(frozen=True)
class Drive:
    """The activation as the energy sees it; both None in a passive kernel."""
    level: object = None
    omega: object = None


@dataclass
class Law:
    name: str
    source: str
    description: str
    parameters: list          # the law's own, then its time function's
    activation: Activation
    energy: object
    passive: str              # kernel set of the passive state
    volumetric_stiff_part: object = None
    fit_parameters: list = field(default_factory=list)
    compiled_passive: bool = False  # this law's own "<name>_passive" kernel set
    default_for: list = field(default_factory=list)  # DEFAULT_FOR: roles
    lines: dict = field(default_factory=dict)  # declaration -> its line in the file

    def where(self, declaration=None):
        """"FILE:LINE" of a declaration (FILE alone if it has no line)."""
        line = self.lines.get(declaration)
        return f"{self.source}:{line}" if line else self.source

    @property
    def active(self):
        return self.activation.drive != "none"

    def parameter_names(self):
        return [p.name for p in self.parameters]


class LawError(Exception):
    pass


class UndeclaredParameter(KeyError):
    """An energy read p[name] of a parameter its law does not declare."""

    def __init__(self, name, declared):
        super().__init__(name)
        self.name, self.declared = name, declared

    def __str__(self):
        return (f"parameter {self.name!r} is used but not declared; declared: "
                f"{', '.join(self.declared)}")


class Parameters(dict):
    """The parameters as the energy sees them (name -> UFL constant); reading an
    undeclared one raises UndeclaredParameter."""

    def __missing__(self, name):
        raise UndeclaredParameter(name, list(self))


def located(path, error, fallback=None):
    """"FILE:LINE: message" for an exception raised while running a law file's code:
    the line is the deepest one of that file in the traceback (else `fallback`), and a
    deeper frame elsewhere (a shared part) is named after the message."""
    path = str(path)
    # this module's own frames (Parameters.__missing__) say nothing of the law
    frames = [f for f in traceback.extract_tb(error.__traceback__) if f.filename != __file__]
    own = [f for f in frames if f.filename == path]
    line = own[-1].lineno if own else fallback
    message = (str(error) if isinstance(error, (LawError, UndeclaredParameter))
               else f"{type(error).__name__}: {error}")
    if frames and frames[-1].filename != path and own:
        message += f" (in {frames[-1].filename}:{frames[-1].lineno})"
    return f"{path}:{line}: {message}" if line else f"{path}: {message}"


def _declaration_lines(tree):
    """{NAME: line} of the file's top-level assignments and functions."""
    lines = {}
    for node in tree.body:
        targets = []
        if isinstance(node, ast.Assign):
            targets = [t.id for t in node.targets if isinstance(t, ast.Name)]
        elif isinstance(node, (ast.AnnAssign, ast.AugAssign)) and isinstance(node.target, ast.Name):
            targets = [node.target.id]
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            targets = [node.name]
        for t in targets:
            lines.setdefault(t, node.lineno)
    return lines


def _load_module(path):
    """The law file run as a module; its declaration lines.  LawError "FILE:LINE: ..."
    on a syntax error or an exception while it runs."""
    text = path.read_text()
    try:
        tree = ast.parse(text, str(path))
    except SyntaxError as e:
        where = f"{path}:{e.lineno}" if e.lineno else str(path)
        raise LawError(f"{where}: syntax error: {e.msg}") from None
    spec = importlib.util.spec_from_file_location(f"muscle_law_{path.stem}", path)
    module = importlib.util.module_from_spec(spec)
    try:
        spec.loader.exec_module(module)
    except Exception as e:  # noqa: BLE001 -- any error of the user's file is reported
        raise LawError(located(path, e)) from None
    return module, _declaration_lines(tree)


def _names(values):
    return ", ".join(values) if values else "none"


def load_law(path, kernels=None):
    """The law of one file, checked; `kernels`: the registered omega kernels
    (default: those of KERNEL_SOURCE)."""
    path = pathlib.Path(path).resolve()
    name = path.stem
    if not name.isidentifier() or name != name.lower():
        raise LawError(f"{path}: a law's file name is its name: lower case, letters, digits, _")
    if not path.is_file():
        raise LawError(f"{path}: no such law file")
    module, lines = _load_module(path)

    def fail(declaration, message):
        line = lines.get(declaration)
        raise LawError(f"{path}:{line}: {message}" if line else f"{path}: {message}")

    for required in ("PARAMETERS", "ACTIVATION", "energy"):
        if not hasattr(module, required):
            fail(None, f"a law file declares PARAMETERS, ACTIVATION and energy(); "
                       f"{required} is missing")
    own_parameters = module.PARAMETERS
    if (not isinstance(own_parameters, (list, tuple))
            or not all(isinstance(p, Parameter) for p in own_parameters)):
        fail("PARAMETERS", "PARAMETERS is a list of parameters: positive(...), nonnegative(...), "
                           "interval(...), real(...)")
    activation = module.ACTIVATION
    if not isinstance(activation, Activation):
        fail("ACTIVATION", "ACTIVATION is PASSIVE_LAW, TANH_LEVEL or omega_kernel(...), "
                           f"not {activation!r}")
    if not callable(module.energy):
        fail("energy", "energy is a function energy(kin, p, drive)")
    parameters = list(own_parameters) + activation.parameters
    names = [p.name for p in parameters]
    duplicates = sorted({n for n in names if names.count(n) > 1})
    if duplicates:
        fail("PARAMETERS", f"parameters declared twice: {', '.join(duplicates)}")
    for p in parameters:
        if not p.lower <= p.preset <= p.upper:
            fail("PARAMETERS", f"parameter {p.name}: preset {p.preset} outside "
                               f"[{p.lower}, {p.upper}]")
    if activation.time_function not in TIME_FUNCTIONS:
        fail("ACTIVATION", f"time function {activation.time_function!r}: expected one of "
                           f"{', '.join(TIME_FUNCTIONS)}")
    if activation.drive == "omega_kernel":
        registered = omega_kernels() if kernels is None else kernels
        if activation.kernel not in registered:
            fail("ACTIVATION", f"omega kernel {activation.kernel!r} is not a C++ kernel; "
                               f"registered: {_names(sorted(registered))} "
                               f"(MUSCLE_OMEGA_KERNEL in {KERNEL_SOURCE.relative_to(ROOT)})")
        if activation.taylor_order not in (1, 2):
            fail("ACTIVATION", f"taylor_order {activation.taylor_order!r}: 1 (the stress holds "
                               "omega_a) or 2")
        missing = [n for n in ("alpha", "beta", "gamma", "omega_0", "lambda_min", "lambda_opt",
                               "P_opt") if n not in names]
        if missing:
            fail("ACTIVATION", f"the {activation.kernel} omega kernel reads "
                               f"{', '.join(missing)}, which the law does not declare")
    passive = getattr(module, "PASSIVE", None)
    if passive is not None and not (isinstance(passive, str) and passive):
        fail("PASSIVE", f"PASSIVE names a law, not {passive!r}")
    compiled_passive = activation.drive != "none" and passive is None
    if activation.drive == "none":
        passive = name
    elif passive is None:
        passive = f"{name}_passive"
    own = {p.name for p in own_parameters}
    default_fit = [n for n in names if n in own and n != "kappa"]
    fit = getattr(module, "FIT_PARAMETERS", default_fit)
    if not isinstance(fit, (list, tuple)) or not all(isinstance(n, str) for n in fit):
        fail("FIT_PARAMETERS", "FIT_PARAMETERS is a list of parameter names")
    unknown = [n for n in fit if n not in names]
    if unknown:
        fail("FIT_PARAMETERS", f"FIT_PARAMETERS: {', '.join(unknown)} not declared; "
                               f"declared: {', '.join(names)}")
    default_for = getattr(module, "DEFAULT_FOR", ())
    if isinstance(default_for, str) or not isinstance(default_for, (list, tuple)):
        fail("DEFAULT_FOR", f"DEFAULT_FOR is a tuple of roles, e.g. (\"muscle\",), not "
                            f"{default_for!r}")
    for role in default_for:
        if role not in ROLES:
            fail("DEFAULT_FOR", f"DEFAULT_FOR: unknown role {role!r}; roles: "
                                f"{', '.join(ROLES)} (ROLES in forms/muscleforms/law.py)")
    volumetric = getattr(module, "volumetric_stiff_part", None)
    if volumetric is not None and not callable(volumetric):
        fail("volumetric_stiff_part", "volumetric_stiff_part is a function (kin, p)")
    doc = (module.__doc__ or name).strip().splitlines()[0]
    return Law(name, str(path), doc, parameters, activation, module.energy, passive,
               volumetric, list(fit), compiled_passive, list(dict.fromkeys(default_for)),
               lines)


def law_files(extra=()):
    """forms/materials/*.py, then the users' files (MUSCLE_MATERIALS)."""
    here = pathlib.Path(__file__).resolve().parent.parent / "materials"
    return sorted(here.glob("*.py")) + [pathlib.Path(e).resolve() for e in extra if e]


def load_laws(extra=()):
    """{name: Law} of every law file; LawError on a clash or a missing passive law."""
    laws = {}
    kernels = omega_kernels()
    for path in law_files(extra):
        law = load_law(path, kernels)
        if law.name in laws:
            raise LawError(f"{path}: a law named {law.name} exists already ({laws[law.name].source})")
        laws[law.name] = law
    sets = set(laws) | {f"{n}_passive" for n, l in laws.items() if l.compiled_passive}
    for law in laws.values():
        if law.passive not in sets:
            raise LawError(f"{law.where('PASSIVE')}: PASSIVE = {law.passive!r} is not a law "
                           f"(laws: {', '.join(sorted(laws))})")
        if law.active and law.passive in laws and laws[law.passive].active:
            raise LawError(f"{law.where('PASSIVE')}: PASSIVE = {law.passive!r} is an active law")
    for role, (one, meaning) in ROLES.items():
        holders = [law for law in laws.values() if role in law.default_for]
        if not holders:
            raise LawError(f"no law file declares DEFAULT_FOR = (\"{role}\",) ({meaning}); "
                           f"laws: {', '.join(laws)}")
        if one and len(holders) > 1:
            raise LawError(f"{holders[1].where('DEFAULT_FOR')}: DEFAULT_FOR \"{role}\" names "
                           f"one law ({meaning}); {holders[0].where('DEFAULT_FOR')} "
                           f"declares it already")
    return laws


def kernel_sets(laws):
    """{kernel set name: (law, active)}: each law's own kernels, and the passive
    counterparts compiled from an active law's file."""
    out = {}
    for law in laws.values():
        out[law.name] = (law, law.active)
        if law.compiled_passive:
            out[law.passive] = (law, False)
    return out
