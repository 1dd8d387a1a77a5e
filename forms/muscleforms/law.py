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

The docstring's first line is the law's one-line description.  Everything the C++
knows of a law -- the list of laws, parameter specs, presets, ranges, activation,
passive kernels -- is generated from these declarations (compile_forms.py).
"""

import importlib.util
import math
import pathlib
from dataclasses import dataclass, field

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
OMEGA_KERNELS = ("wkm", "giant")  # what activation_kernels.cpp implements


def omega_kernel(kernel, taylor_order, time_function="twitch_train", stress_holds_omega=False):
    if kernel not in OMEGA_KERNELS:
        raise ValueError(f"omega kernel {kernel!r}: the C++ kernels are {OMEGA_KERNELS}")
    if taylor_order not in (1, 2):
        raise ValueError("taylor_order: 1 (stress holds omega_a) or 2")
    return Activation("omega_kernel", time_function, kernel, taylor_order, stress_holds_omega)


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

    @property
    def active(self):
        return self.activation.drive != "none"

    def parameter_names(self):
        return [p.name for p in self.parameters]


class LawError(Exception):
    pass


def _load_module(path):
    spec = importlib.util.spec_from_file_location(f"muscle_law_{path.stem}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def load_law(path):
    path = pathlib.Path(path).resolve()
    name = path.stem
    if not name.isidentifier() or name != name.lower():
        raise LawError(f"{path}: a law's file name is its name: lower case, letters, digits, _")
    module = _load_module(path)
    for required in ("PARAMETERS", "ACTIVATION", "energy"):
        if not hasattr(module, required):
            raise LawError(f"{path}: a law file declares PARAMETERS, ACTIVATION and energy(); "
                           f"{required} is missing")
    activation = module.ACTIVATION
    parameters = list(module.PARAMETERS) + activation.parameters
    names = [p.name for p in parameters]
    duplicates = sorted({n for n in names if names.count(n) > 1})
    if duplicates:
        raise LawError(f"{path}: parameters declared twice: {', '.join(duplicates)}")
    for p in parameters:
        if not p.lower <= p.preset <= p.upper:
            raise LawError(f"{path}: parameter {p.name}: preset {p.preset} outside "
                           f"[{p.lower}, {p.upper}]")
    if activation.drive == "omega_kernel":
        missing = [n for n in ("alpha", "beta", "gamma", "omega_0", "lambda_min", "lambda_opt",
                               "P_opt") if n not in names]
        if missing:
            raise LawError(f"{path}: the {activation.kernel} omega kernel reads "
                           f"{', '.join(missing)}, which the law does not declare")
    passive = getattr(module, "PASSIVE", None)
    compiled_passive = activation.drive != "none" and passive is None
    if activation.drive == "none":
        passive = name
    elif passive is None:
        passive = f"{name}_passive"
    own = {p.name for p in module.PARAMETERS}
    default_fit = [n for n in names if n in own and n != "kappa"]
    doc = (module.__doc__ or name).strip().splitlines()[0]
    return Law(name, str(path), doc, parameters, activation, module.energy, passive,
               getattr(module, "volumetric_stiff_part", None),
               list(getattr(module, "FIT_PARAMETERS", default_fit)), compiled_passive)


def law_files(extra=()):
    """forms/materials/*.py, then the users' files (MUSCLE_MATERIALS)."""
    here = pathlib.Path(__file__).resolve().parent.parent / "materials"
    return sorted(here.glob("*.py")) + [pathlib.Path(e).resolve() for e in extra if e]


def load_laws(extra=()):
    """{name: Law} of every law file; LawError on a clash or a missing passive law."""
    laws = {}
    for path in law_files(extra):
        law = load_law(path)
        if law.name in laws:
            raise LawError(f"{path}: a law named {law.name} exists already ({laws[law.name].source})")
        laws[law.name] = law
    kernels = set(laws) | {f"{n}_passive" for n, l in laws.items() if l.compiled_passive}
    for law in laws.values():
        if law.passive not in kernels:
            raise LawError(f"{law.source}: PASSIVE = {law.passive!r} is not a law "
                           f"(laws: {', '.join(sorted(laws))})")
        if law.active and law.passive in laws and laws[law.passive].active:
            raise LawError(f"{law.source}: PASSIVE = {law.passive!r} is an active law")
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
