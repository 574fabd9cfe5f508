#!/usr/bin/python3
"""Checks that every #include runs down the layers, never up or around.

The library's folders (include/gipdyn/<folder>, src/<folder>) and the
applications' (apps/<folder>, python/src) are ordered from the bottom up in
LAYERS; a file may include files of its own folder and of folders below it.
Headers directly in include/gipdyn belong to "common", except the umbrella
headers, which may include everything. Exits 1 and lists every include that
runs up (a folder including one above it), which is also what a circle
between folders needs.

Usage: scripts/check_layers.py [repository root]
"""
import os
import re
import sys

# Bottom first. A folder may include its own files and those of earlier folders.
LAYERS = [
    "detail",       # raw loops with no dependency (detail/factor_pair_product.hpp)
    "common",       # errors, joint types, features, metrics, progress, threads
    "optim",        # the optimiser
    "robot",        # rigid-body models, KDL, URDF
    "io",           # CSV, MAT, model containers
    "preprocess",   # filtering robot logs
    "sim",          # simulated motions
    "kernels",      # covariance functions and their gradients
    "gp",           # exact, sparse and weight-space GP likelihoods
    "distributed",  # the MPI + ScaLAPACK likelihood
    "model",        # per-joint GP training and the model
    "estimators",   # every estimator, the table, the teacher
    "sensing",      # what a model senses: contact detection
    "capi",         # the C API
    "reports",      # apps/reports: tables, plots
    "experiments",  # apps/experiments
    "cli",          # apps/cli
    "python",       # python/src
]
UMBRELLA = {"include/gipdyn/gipdyn.hpp", "include/gipdyn/gipdyn.h"}
INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)


def folder_of_file(path):
    parts = path.split("/")
    if parts[0] == "include":
        return parts[2] if len(parts) > 3 else "common"
    if parts[0] == "src":
        return parts[1]
    if parts[0] == "apps":
        return parts[1]
    if parts[:2] == ["python", "src"]:
        return "python"
    return None


def folder_of_include(target, including_folder):
    if target.startswith("gipdyn/"):
        parts = target.split("/")
        return parts[1] if len(parts) > 2 else "common"
    first = target.split("/")[0]
    if first in LAYERS and "/" in target:  # apps/: "reports/plots.hpp"
        return first
    return including_folder  # a file beside it


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    rank = {name: i for i, name in enumerate(LAYERS)}
    upward, unknown, files = [], set(), 0
    for top in ("include/gipdyn", "src", "apps", "python/src"):
        for directory, _, names in os.walk(os.path.join(root, top)):
            for name in sorted(names):
                if not name.endswith((".hpp", ".cpp", ".h", ".inc")):
                    continue
                path = os.path.relpath(os.path.join(directory, name), root)
                if path in UMBRELLA:
                    continue
                folder = folder_of_file(path)
                if folder not in rank:
                    unknown.add(folder)
                    continue
                files += 1
                with open(os.path.join(root, path), encoding="utf-8") as f:
                    text = f.read()
                for target in INCLUDE.findall(text):
                    to = folder_of_include(target, folder)
                    if to not in rank:
                        unknown.add(to)
                    elif rank[to] > rank[folder]:
                        upward.append(f"{path}: includes {target} ({folder} -> {to}, a layer above)")
    if unknown:
        print("check_layers: folders not in LAYERS: " + ", ".join(sorted(str(u) for u in unknown)) +
              "; add each where it belongs in scripts/check_layers.py")
        return 1
    if upward:
        print("\n".join(upward))
        print(f"check_layers: {len(upward)} include(s) run up the layers; move the code they need down, "
              "or the including code up")
        return 1
    print(f"check_layers: {files} files, every include runs down the layers {' < '.join(LAYERS)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
