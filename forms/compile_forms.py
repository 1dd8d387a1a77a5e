#!/usr/bin/python3
"""Compile the material laws with FFCx: one C file per variant, plus the C++ registry.

    compile_forms.py --out DIR [--material FILE ...] [--law NAME ...] [--fibres]
                     [--registry] [--cmake FILE] [--extra-variant K:CELL:DEGREE:QDEG[:VQDEG]]
                     [--elements all|hex1,hex2,tet1,tet2] [--variants REGEX]

A law is one file (forms/materials/*.py and the files of --material; see
muscleforms/law.py; --material adds users' files).  Each law's kernel sets (the law, and its passive counterpart
unless it names another law's) are compiled on hexahedra and tetrahedra of degree 1
and 2 at the default quadrature degree, as the F-bar Q1 hexahedron, as the
anti-locking Q1 if the law gives volumetric_stiff_part, and as one material-point
variant.  CMake runs one --law call per law file, so a new or edited law compiles
only its own kernels; --registry writes the C++ tables of laws and kernels
(form_registry.cpp); --cmake writes the generated-file list of each law for CMake.
Without --law, --fibres, --registry or --cmake: everything.  --elements compiles only
these elements' kernels (laws, loads, fibres; --extra-variant always), --variants only
the FE variants whose name (e.g. combi_hex1_q2_fbar) the regular expression matches: a
build for one job compiles what the job uses, and the registry names the rest as not
compiled.

Every call checks the law files first (muscleforms/law.py: declarations, roles, omega
kernels against cpp/material/activation_kernels.cpp; here: the energies traced with UFL,
so that a parameter used but not declared is found): a mistake is one line
"error: FILE:LINE: what is wrong" and exit status 1, before FFCx runs.
"""

import argparse
import math
import pathlib
import re
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))

from muscleforms import law as laws_module  # noqa: E402  (no UFL: the declarations)

try:
    from muscleforms import fbar, loads, taylor_hood, variants  # noqa: E402
except ImportError as e:  # the one failure that is the machine's, not a law file's
    raise SystemExit(f"error: cannot import UFL/FFCx/Basix ({e}): is python3-ffcx installed?")


ALL_ELEMENTS = [(c, d) for c in variants.CELLS for d in (1, 2)]
ELEMENTS = list(ALL_ELEMENTS)  # set by --elements
VARIANTS = [""]  # --variants: a regular expression (search) on the variant names


def parse_elements(text):
    if text == "all":
        return list(ALL_ELEMENTS)
    names = {f"{c}{d}": (c, d) for c, d in ALL_ELEMENTS}
    wanted = [e for e in text.replace(";", ",").split(",") if e]
    bad = [e for e in wanted if e not in names]
    if bad or not wanted:
        raise SystemExit(f"error: --elements {text!r}: expected all or a list of "
                         f"{', '.join(names)}")
    return [names[e] for e in names if e in wanted]


def kernel_variants(kernels, law, extra=()):
    """(kernels, cell, degree, qdeg, vqdeg, kind) of one kernel set; kind "", "fbar" or
    "th" (variants.variant_name)."""
    out = []
    for cell, degree in ELEMENTS:
        qdeg = variants.DEFAULT_QUADRATURE[(cell, degree)]
        out.append((kernels, cell, degree, qdeg, qdeg, ""))
        vqdeg = variants.REDUCED_VOLUMETRIC.get((cell, degree))
        if vqdeg is not None and law.volumetric_stiff_part is not None:
            out.append((kernels, cell, degree, qdeg, vqdeg, ""))
        if (cell, degree) in fbar.FBAR_ELEMENTS:
            out.append((kernels, cell, degree, qdeg, qdeg, "fbar"))
        if (cell, degree) in taylor_hood.TAYLOR_HOOD_ELEMENTS:
            out.append((kernels, cell, degree, qdeg, qdeg, "th"))
    out = [v for v in out if re.search(VARIANTS[0], variants.variant_name(*v))]
    out += [v for v in extra if v[0] == kernels and v not in out]
    return out


def parse_variant(text, sets):
    parts = text.split(":")
    if len(parts) not in (4, 5):
        raise SystemExit(f"--extra-variant {text!r}: expected KERNELS:CELL:DEGREE:QDEG[:VQDEG]")
    kernels, cell, degree, qdeg = parts[0], parts[1], int(parts[2]), int(parts[3])
    if kernels not in sets or cell not in variants.CELLS or degree not in (1, 2):
        raise SystemExit(f"--extra-variant {text!r}: kernels in {sorted(sets)}, cell in "
                         f"{tuple(variants.CELLS)}, degree 1 or 2")
    vqdeg = int(parts[4]) if len(parts) == 5 else qdeg
    if not 0 <= vqdeg <= qdeg:
        raise SystemExit(f"--extra-variant {text!r}: VQDEG {vqdeg} must be between 0 and QDEG {qdeg}")
    if vqdeg != qdeg and sets[kernels][0].volumetric_stiff_part is None:
        raise SystemExit(f"--extra-variant {text!r}: law {sets[kernels][0].name} gives no "
                         f"volumetric_stiff_part")
    return kernels, cell, degree, qdeg, vqdeg, ""


def write_if_changed(path, text):
    path = pathlib.Path(path)
    if path.exists() and path.read_text() == text:
        return
    path.write_text(text)


def compile_objects(names, prefix, outdir, parameters):
    from ffcx import compiler, formatting
    code_h, code_c = compiler.compile_ufl_objects(names.objects, names.object_names,
                                                  prefix=prefix, parameters=parameters)
    tmp = outdir / "tmp" / prefix  # one folder per prefix: laws compile in parallel
    tmp.mkdir(parents=True, exist_ok=True)
    formatting.write_code(code_h, code_c, prefix, str(tmp))
    for ext in ("h", "c"):
        write_if_changed(outdir / f"{prefix}.{ext}", (tmp / f"{prefix}.{ext}").read_text())


def load_prefixes():
    return [f"loads_{c}{d}" for c, d in ELEMENTS]


def fibre_cells():
    return [c for c in variants.CELLS if any(c == cell for cell, _ in ELEMENTS)]


def law_prefixes(law, sets, extra):
    out = []
    for kernels, (owner, _) in sets.items():
        if owner is law:
            out += [variants.variant_name(*v) for v in kernel_variants(kernels, law, extra)]
            out.append(f"mp_{kernels}")
    return out


def compile_law(law, sets, extra, outdir, parameters):
    for kernels, (owner, active) in sets.items():
        if owner is not law:
            continue
        for v in kernel_variants(kernels, law, extra):
            names = (fbar.build_fbar_variant(law, active, *v[1:4]) if v[5] == "fbar"
                     else taylor_hood.build_taylor_hood_variant(law, active, *v[1:4])
                     if v[5] == "th" else variants.build_fe_variant(law, active, *v[1:5]))
            compile_objects(names, variants.variant_name(*v), outdir, parameters)
        compile_objects(variants.build_material_point_variant(law, active), f"mp_{kernels}",
                        outdir, parameters)


def check_energy(law, sets):
    """Build the material-point UFL of the law's kernel sets (no FFCx: a fraction of a
    second) and its volumetric_stiff_part: LawError "FILE:LINE: ..." on an undeclared
    parameter or any other error in the energy."""
    for kernels, (owner, active) in sets.items():
        if owner is not law:
            continue
        try:
            variants.build_material_point_variant(law, active)
            if law.volumetric_stiff_part is not None:
                variants.check_volumetric_part(law)
        except Exception as e:  # noqa: BLE001 -- any error of the user's energy is reported
            raise laws_module.LawError(laws_module.located(law.source, e, law.lines.get("energy")))


def cpp_string(text):
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def cpp_number(x):
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return repr(float(x))


def law_source(law):
    a = law.activation
    params = ",\n        ".join(
        f"{{{cpp_string(p.name)}, {cpp_number(p.preset)}, {cpp_number(p.lower)}, "
        f"{cpp_number(p.upper)}, {str(p.lower_open).lower()}, {str(p.upper_open).lower()}, "
        f"{cpp_string(p.unit)}, {cpp_string(p.meaning)}}}" for p in law.parameters)
    fit = ", ".join(cpp_string(n) for n in law.fit_parameters)
    roles = ", ".join(cpp_string(r) for r in law.default_for)
    return (f"      {{{cpp_string(law.name)}, {cpp_string(law.description)}, "
            f"{cpp_string(law.source)},\n       {{{params}}},\n       "
            f"{cpp_string(a.drive)}, {cpp_string(a.time_function)}, {cpp_string(a.kernel)}, "
            f"{a.taylor_order}, {str(a.stress_holds_omega).lower()}, {cpp_string(law.passive)}, "
            f"{str(law.volumetric_stiff_part is not None).lower()}, {{{fit}}}, {{{roles}}}}},")


def registry_source(laws, sets, extra):
    """C++ tables: the laws, and (kernels, cell, degree, quadrature) -> generated code."""
    fe = [v for k, (law, _) in sets.items() for v in kernel_variants(k, law, extra)]
    lines = ["// Generated by forms/compile_forms.py from the law files -- do not edit.",
             '#include "form_registry.h"', "#include <limits>"]
    lines += [f'#include "{variants.variant_name(*v)}.h"' for v in fe]
    lines += [f'#include "mp_{k}.h"' for k in sets]
    lines += [f'#include "fibre_{c}.h"' for c in fibre_cells()]
    lines += [f'#include "{n}.h"' for n in load_prefixes()]
    lines += ["", "namespace", "{", "constexpr double inf = std::numeric_limits<double>::infinity();"]
    for v in fe:
        n = variants.variant_name(*v)
        if v[5] == "fbar":
            kernels = ", ".join(f"form_{n}_fbar_{k}" for k in
                                ("residual", "jacobian", "r0", "centre", "gradient", "hessian"))
            lines.append(f"const muscle::forms::FbarForms fbar_{n} = {{{kernels}, "
                         f"expression_{n}_fbar_centre_dilatation}};")
        elif v[5] == "th":
            kernels = ", ".join(f"form_{n}_th_{k}" for k in
                                ("residual", "jacobian_uq", "jacobian_qu", "jacobian_qq"))
            lines.append(f"const muscle::forms::TaylorHoodForms th_{n} = {{{kernels}}};")
    compiled = ",".join(f"{c}{d}" for c, d in ELEMENTS)
    lines += ["} // namespace", "", "namespace muscle::forms", "{", "",
              f'const char* compiled_elements() {{ return "{compiled}"; }}',
              f"const char* compiled_variants() {{ return {cpp_string(VARIANTS[0])}; }}", "",
              "const std::vector<LawInfo>& laws()", "{",
              "  static const std::vector<LawInfo> table = {"]
    lines += [law_source(law) for law in laws.values()]
    kernels = ", ".join(cpp_string(k) for k in laws_module.omega_kernels())
    lines += ["  };", "  return table;", "}", "",
              "const std::vector<const char*>& registered_omega_kernels()", "{",
              f"  static const std::vector<const char*> names = {{{kernels}}};",
              "  return names;", "}", "",
              "const std::vector<FeVariant>& fe_variants()", "{",
              "  static const std::vector<FeVariant> table = {"]
    for (kernels, cell, degree, qdeg, vqdeg, kind) in fe:
        law, active = sets[kernels]
        n = variants.variant_name(kernels, cell, degree, qdeg, vqdeg, kind)
        stretch = (f"expression_{n}_fibre_stretch"
                   if active and law.activation.drive == "omega_kernel" else "nullptr")
        split = (f"form_{n}_residual_volumetric, form_{n}_jacobian_volumetric" if vqdeg != qdeg
                 else "nullptr, nullptr")
        lines.append(f'      {{"{kernels}", "{variants.CELLS[cell]}", {degree}, {qdeg}, {vqdeg}, '
                     f'form_{n}_residual, form_{n}_jacobian, {split}, form_{n}_volume, form_{n}_energy, '
                     f'functionspace_form_{n}_residual, {stretch}, expression_{n}_post, '
                     f'{"&fbar_" + n if kind == "fbar" else "nullptr"}, '
                     f'{"&th_" + n if kind == "th" else "nullptr"}}},')
    lines += ["  };", "  return table;", "}", "",
              "const std::vector<MaterialPointVariant>& material_point_variants()", "{",
              "  static const std::vector<MaterialPointVariant> table = {"]
    for k in sets:
        lines.append(f'      {{"{k}", expression_mp_{k}_energy, expression_mp_{k}_stress, '
                     f'expression_mp_{k}_tangent, expression_mp_{k}_fibre_stretch}},')
    lines += ["  };", "  return table;", "}", "",
              "const std::vector<FibreVariant>& fibre_variants()", "{",
              "  static const std::vector<FibreVariant> table = {"]
    for c in fibre_cells():
        name = variants.CELLS[c]
        lines.append(f'      {{"{name}", form_fibre_{c}_laplace, form_fibre_{c}_rhs, '
                     f'functionspace_form_fibre_{c}_laplace, expression_fibre_{c}_gradient}},')
    lines += ["  };", "  return table;", "}", "",
              "const std::vector<LoadVariant>& load_variants()", "{",
              "  static const std::vector<LoadVariant> table = {"]
    for (c, degree), n in zip(ELEMENTS, load_prefixes()):
        forms = ", ".join(f"form_{n}_{k}" for k in ("pressure_residual", "pressure_jacobian",
                                                    "traction_residual", "gravity_residual", "area",
                                                    "mass"))
        lines.append(f'      {{"{variants.CELLS[c]}", {degree}, {forms}, '
                     f'functionspace_form_{n}_pressure_residual}},')
    lines += ["  };", "  return table;", "}", "", "} // namespace muscle::forms", ""]
    return "\n".join(lines)


def cmake_source(laws, sets, extra):
    """set(MUSCLE_LAWS ...), and per law its file and generated C files."""
    lines = ["# Generated by forms/compile_forms.py --cmake -- do not edit.",
             f"set(MUSCLE_LAWS {' '.join(laws)})"]
    for law in laws.values():
        files = " ".join(f"{p}.c" for p in law_prefixes(law, sets, extra))
        lines.append(f'set(MUSCLE_LAW_{law.name}_SOURCE "{law.source}")')
        lines.append(f"set(MUSCLE_LAW_{law.name}_FILES {files})")
    lines.append(f"set(MUSCLE_FIBRE_FILES {' '.join(f'fibre_{c}.c' for c in fibre_cells())})")
    lines.append(f"set(MUSCLE_LOAD_FILES {' '.join(f'{n}.c' for n in load_prefixes())})")
    return "\n".join(lines) + "\n"


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", required=True, help="output directory for the generated code")
    parser.add_argument("--material", action="append", default=[],
                        help="a user's law file outside the tree (repeatable)")
    parser.add_argument("--law", action="append", default=[], help="compile this law's kernels")
    parser.add_argument("--fibres", action="store_true", help="compile the fibre Laplace problem")
    parser.add_argument("--loads", action="store_true", help="compile the external loads")
    parser.add_argument("--registry", action="store_true", help="write form_registry.cpp")
    parser.add_argument("--cmake", help="write the generated-file lists for CMake to this file")
    parser.add_argument("--extra-variant", action="append", default=[],
                        help="KERNELS:CELL:DEGREE:QDEG[:VQDEG] added to the standard set")
    parser.add_argument("--elements", default="all",
                        help="all, or the elements to compile: hex1,hex2,tet1,tet2")
    parser.add_argument("--variants", default="",
                        help="compile only the FE variants whose name matches (Python re.search)")
    args = parser.parse_args()
    ELEMENTS[:] = parse_elements(args.elements)
    try:
        re.compile(args.variants)
    except re.error as e:
        raise SystemExit(f"error: --variants {args.variants!r}: not a regular expression ({e})")
    VARIANTS[0] = args.variants

    everything = not (args.law or args.fibres or args.loads or args.registry or args.cmake)
    try:
        laws = laws_module.load_laws(args.material)
        sets = laws_module.kernel_sets(laws)
        unknown = [n for n in args.law if n not in laws]
        if unknown:
            raise SystemExit(f"error: --law {unknown[0]}: laws are {', '.join(laws)}")
        # the configure step (--cmake) checks every energy; FFCx's runs their own
        for name in (laws if args.cmake or everything else args.law):
            check_energy(laws[name], sets)
    except laws_module.LawError as e:
        raise SystemExit(f"error: {e}")
    extra = [parse_variant(v, sets) for v in args.extra_variant]
    outdir = pathlib.Path(args.out)
    outdir.mkdir(parents=True, exist_ok=True)

    if args.cmake:
        write_if_changed(args.cmake, cmake_source(laws, sets, extra))
    if args.law or args.fibres or args.loads or everything:
        from ffcx.parameters import get_parameters
        parameters = get_parameters({"verbosity": 40})
        for name in (laws if everything else args.law):
            compile_law(laws[name], sets, extra, outdir, parameters)
        if args.fibres or everything:
            for c in fibre_cells():
                compile_objects(variants.build_fibre_variant(c), f"fibre_{c}", outdir, parameters)
        if args.loads or everything:
            for (c, d), n in zip(ELEMENTS, load_prefixes()):
                compile_objects(loads.build_load_variant(c, d), n, outdir, parameters)
    if args.registry or everything:
        write_if_changed(outdir / "form_registry.cpp", registry_source(laws, sets, extra))


if __name__ == "__main__":
    main()
