#!/usr/bin/env bash
# Runs the whole test suite, including the checks against the real Gmsh,
# VTK, MFEM and meshio (tests/it: real_programs*, kept, mfem, abaqus, msh22), then scripts/behaviour.sh: every case and
# four `curve` runs compared with the figures recorded before the redesign
# of issue 12 (2–3 minutes), with the binary `cargo test` has just built
# (optimised test profile: no second, release, build in CI).
# Then the Python package's tests (python/tests, pytest): the extension
# built with the same profile (its library shared with `cargo test`'s),
# staged with the package's Python files under target/python.
# BEHAVIOUR=quick runs its quick subset (about 20 s), BEHAVIOUR=0 skips it. Creates .venv with the Python packages they
# need on first use; set DEFORMESH_PYTHON to use another interpreter instead.
set -euo pipefail
cd "$(dirname "$0")/.."

if [[ -z "${DEFORMESH_PYTHON:-}" ]]; then
    [[ -x .venv/bin/python ]] || python3 -m venv .venv
    # an older .venv may lack the packages added since
    if ! .venv/bin/python -c "import gmsh, vtk, mfem.ser, meshio, pytest" 2>/dev/null; then
        .venv/bin/pip install --quiet "gmsh==4.15.*" "vtk==9.7.*" "mfem==4.10.*" "meshio==5.3.*" "pytest==8.*"
    fi
fi
python="${DEFORMESH_PYTHON:-.venv/bin/python}"
log=$(mktemp)
trap 'rm -f "$log"' EXIT
status=0
cargo test --workspace "$@" 2>&1 | tee "$log" || status=$?
# one summary line over all test binaries (unit, integration, doc tests)
awk '/^test result:/ { for (i = 1; i <= NF; i++) { if ($(i+1) ~ /^passed/) p += $i; if ($(i+1) ~ /^failed/) f += $i } }
     END { printf "tests: %d passed, %d failed\n", p, f }' "$log"
# the Python package (issue 46): the extension of the test profile, whose
# library `cargo test --workspace` has just built (the workspace resolved
# as one, so its dependencies' features are the extension's: measured on a
# fresh clone, this build compiled the library and its dependencies again,
# 6m55s, without it), staged as the package
py=0
PYO3_PYTHON="$python" PYO3_BUILD_EXTENSION_MODULE=1 cargo build --profile test -p deformesh-python || py=$?
if ((py == 0)); then
    stage="${CARGO_TARGET_DIR:-target}/python/deformesh"
    rm -rf "$stage" && mkdir -p "$stage"
    cp python/deformesh/*.py "$stage/"
    cp "${CARGO_TARGET_DIR:-target}/debug/lib_deformesh.so" "$stage/_deformesh.abi3.so"
    PYTHONPATH="$(dirname "$stage")" DEFORMESH="${CARGO_TARGET_DIR:-target}/debug/deformesh" "$python" -m pytest -q python/tests || py=$?
fi
if ((status == 0)); then status=$py; fi
# behaviour unchanged (issue 12); the first failure's status is kept
export DEFORMESH="${DEFORMESH:-${CARGO_TARGET_DIR:-target}/debug/deformesh}"
case "${BEHAVIOUR:-full}" in
    0 | no | off) b=0 ;;
    quick) b=0; scripts/behaviour.sh --quick || b=$? ;;
    *) b=0; scripts/behaviour.sh || b=$? ;;
esac
if ((status == 0)); then status=$b; fi
exit "$status"
