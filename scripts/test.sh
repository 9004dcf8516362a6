#!/usr/bin/env bash
# Runs the whole test suite, including the checks against the real Gmsh and
# VTK (tests/real_programs.rs). Creates .venv with the Python packages they
# need on first use; set DEFORMESH_PYTHON to use another interpreter instead.
set -euo pipefail
cd "$(dirname "$0")/.."

if [[ -z "${DEFORMESH_PYTHON:-}" && ! -x .venv/bin/python ]]; then
    python3 -m venv .venv
    .venv/bin/pip install --quiet "gmsh==4.15.*" "vtk==9.7.*"
fi
cargo test "$@"
