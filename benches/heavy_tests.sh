#!/usr/bin/env bash
# The integration tests too heavy for the suite's 20 minutes (each 23-80 s
# on 2 cores, measured by cargo nextest): `#[ignore = "heavy ..."]` in
# tests/it. They are real tests (the real Gmsh agrees, exact shapes); run
# them before a release and after changing what they cover:
#   cad: the extruded NACA wing of hexahedra, the full wing at p = 3;
#   band: the snap kept on the ball octant (and Algorithm 2 beside it),
#   multigrid iterations on thin layers, the band solve against the whole
#   mesh's; simplices: the tetrahedral ball in a box at p = 2, 3, 4;
#   curve_import: extruded thin layers with slip end planes, the hex layer
#   around a sphere; prisms: the extruded prism layer at p = 2 and 3.
# Uses the venv scripts/test.sh makes (run that first on a fresh clone).
set -euo pipefail
cd "$(dirname "$0")/.."
exec cargo test --test it "$@" -- --ignored
