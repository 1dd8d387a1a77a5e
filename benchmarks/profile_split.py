#!/usr/bin/python3
"""Where one bench-assembly operation's instructions go: the callgrind dumps of
`valgrind --tool=callgrind --instr-atstart=no bench-assembly --repetitions 1`, split by
exclusive cost into FFCx kernels, PETSc insertion, the F-bar condensation in C++, libm
(pow/exp/log/cbrt), the activation kernels, and the rest (DOLFINx packing and loops).

    profile_split.py FOLDER [--markdown]

Prints one row per "MODEL:OPERATION" dump, in million instructions.
"""

import argparse
import glob
import os
import re
import subprocess

# first match wins; tested on the exclusive-cost function names of callgrind_annotate
CATEGORIES = [
    ("ffcx", re.compile(r"tabulate_tensor_integral")),
    ("fbar_cpp", re.compile(r"fbar_element|FbarElement|CellEvaluation|Gather::apply|fbar_unknowns")),
    ("libm", re.compile(r"(^|[^a-z])(pow|exp|log|cbrt|sqrt)[a-z0-9_]*$|__ieee754|__(pow|exp|log)"
                        r"|libm[.-]")),
    ("activation", re.compile(r"activation|omega|root_finding|lambert", re.I)),
    ("insertion", re.compile(r"^(Mat|PetscSort|PetscFind|ISLocalToGlobal|PetscMem|PetscArray)"
                             r"|libpetsc")),
]
ORDER = ["ffcx", "insertion", "fbar_cpp", "libm", "activation", "other"]


def split(path):
    out = subprocess.run(["callgrind_annotate", "--inclusive=no", "--threshold=100", path],
                         capture_output=True, text=True, check=True).stdout
    label, parts = None, {c: 0 for c in ORDER}
    total = 0
    for line in out.splitlines():
        m = re.match(r"\s*([\d,]+)\s+(?:\([\s\d.%]+\)\s+)?(\S.*)$", line)
        if line.startswith("Trigger:") or "Client Request:" in line:
            label = line.split(":")[-2].strip() + ":" + line.split(":")[-1].strip()
        if not m or "PROGRAM TOTALS" in line:
            if m and "PROGRAM TOTALS" in line:
                total = int(m.group(1).replace(",", ""))
            continue
        count, name = int(m.group(1).replace(",", "")), m.group(2)
        function = name.split(":", 1)[1] if ":" in name and not name.startswith("?") else name
        for cat, pattern in CATEGORIES:
            if pattern.search(function) or pattern.search(name):
                parts[cat] += count
                break
        else:
            parts["other"] += count
    return label, total, parts


def label_of(path):
    with open(path) as f:
        for line in f:
            if line.startswith("desc: Trigger: Client Request:"):
                return line.split(":", 3)[3].strip()
    return None


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("folder")
    parser.add_argument("--markdown", action="store_true")
    args = parser.parse_args()
    rows = []
    for path in glob.glob(os.path.join(args.folder, "callgrind.out*")):
        label = label_of(path)
        if label is None:
            continue
        _, total, parts = split(path)
        rows.append((label, total, parts))
    rows.sort()
    if args.markdown:
        print("| operation | total | " + " | ".join(ORDER) + " |")
        print("|---" * (len(ORDER) + 2) + "|")
    for label, total, parts in rows:
        cells = [f"{parts[c] / 1e6:.1f}" for c in ORDER]
        if args.markdown:
            print(f"| {label} | {total / 1e6:.1f} | " + " | ".join(cells) + " |")
        else:
            print(f"{label:20s} {total / 1e6:9.1f} " + " ".join(f"{c}={v}" for c, v in zip(ORDER, cells)))


if __name__ == "__main__":
    main()
