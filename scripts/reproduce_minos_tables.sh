#!/usr/bin/env bash
# The MINOS paper's tables (docs/RESULTS.md) from an empty folder, one resumable cell at a time.
#   scripts/reproduce_minos_tables.sh ROOT              every cell not done yet, in order
#   scripts/reproduce_minos_tables.sh ROOT --list       the cells and whether they are done
#   scripts/reproduce_minos_tables.sh ROOT --cell NAME  one cell (repeatable)
#   scripts/reproduce_minos_tables.sh ROOT --report     ROOT/tables.md from the finished cells
#   scripts/reproduce_minos_tables.sh ROOT --random-only  every cell up to its random row (minutes)
#   scripts/reproduce_minos_tables.sh ROOT --draws 3    each row trained with training seeds 0, 1, 2 (mean ± sd)
#   scripts/reproduce_minos_tables.sh ROOT --dagger N   the rows with an image with N DAgger rounds (other rows)
# Needs: the `minos` binary on PATH and the minos wheel with torch, lerobot and gymnasium in
# the Python environment ($PYTHON, default python3). Uses CUDA when torch sees a GPU.
set -euo pipefail
root=${1:?usage: $0 ROOT [--list | --report | --cell NAME ...]}
shift
command -v minos >/dev/null || { echo "minos (the binary) is not on PATH" >&2; exit 1; }
exec "${PYTHON:-python3}" -m minos.learn -q tables --root "$root" "$@"
