#!/usr/bin/env bash
# Runs the whole test suite, including the checks against the real Gmsh,
# VTK, MFEM and meshio (tests/it: real_programs*, kept, mfem, abaqus, msh22), then scripts/behaviour.sh: every case and
# four `curve` runs compared with the figures recorded before the redesign
# of issue 12 (2–3 minutes), with the binary `cargo test` has just built
# (optimised test profile: no second, release, build in CI).
# BEHAVIOUR=quick runs its quick subset (about 20 s), BEHAVIOUR=0 skips it. Creates .venv with the Python packages they
# need on first use; set DEFORMESH_PYTHON to use another interpreter instead.
set -euo pipefail
cd "$(dirname "$0")/.."

if [[ -z "${DEFORMESH_PYTHON:-}" ]]; then
    [[ -x .venv/bin/python ]] || python3 -m venv .venv
    # an older .venv may lack the packages added since
    if ! .venv/bin/python -c "import gmsh, vtk, mfem.ser, meshio" 2>/dev/null; then
        .venv/bin/pip install --quiet "gmsh==4.15.*" "vtk==9.7.*" "mfem==4.10.*" "meshio==5.3.*"
    fi
fi
log=$(mktemp)
trap 'rm -f "$log"' EXIT
status=0
cargo test "$@" 2>&1 | tee "$log" || status=$?
# one summary line over all test binaries (unit, integration, doc tests)
awk '/^test result:/ { for (i = 1; i <= NF; i++) { if ($(i+1) ~ /^passed/) p += $i; if ($(i+1) ~ /^failed/) f += $i } }
     END { printf "tests: %d passed, %d failed\n", p, f }' "$log"
# behaviour unchanged (issue 12); the first failure's status is kept
export DEFORMESH="${DEFORMESH:-${CARGO_TARGET_DIR:-target}/debug/deformesh}"
case "${BEHAVIOUR:-full}" in
    0 | no | off) b=0 ;;
    quick) b=0; scripts/behaviour.sh --quick || b=$? ;;
    *) b=0; scripts/behaviour.sh || b=$? ;;
esac
if ((status == 0)); then status=$b; fi
exit "$status"
