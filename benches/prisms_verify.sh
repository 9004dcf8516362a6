#!/usr/bin/env bash
# Issue 24's checks at the full sizes, on the meshes benches/prisms.sh made
# (target/prism-bench): `curve` each at p = 2 and 3, then the real Gmsh
# reads our p = 2 files (every element's minDetJac > 0) and VTK's own
# Lagrange cells judge our p = 3 VTUs (tests/python/check_vtk_cells.py);
# prints per run the cells, invalid elements, least scaled Jacobian, the
# curved group's node distance and first-layer change, and the peers'
# verdicts. Usage: benches/prisms.sh first, then benches/prisms_verify.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
DEFORMESH=${DEFORMESH:-target/release/deformesh}
PYTHON=${PYTHON:-.venv/bin/python}
B=target/prism-bench
OUT=$B/verify
mkdir -p "$OUT"
run() { # mesh geometry p
    local out=$OUT/$(basename "$1" .msh)_p$3.msh
    "$DEFORMESH" curve "$1" --geometry "$2" --order "$3" -o "$out" > "$OUT/log" 2>&1 || { echo "FAILED: $1 at p = $3"; tail -3 "$OUT/log"; return; }
    "$PYTHON" - "${out%.msh}.report.json" "$1" "$3" <<'PY'
import json, sys
r = json.load(open(sys.argv[1])); q = r["quality"]
print(f"{sys.argv[2]} p = {sys.argv[3]}: {q['elements']} elements, {len(q['invalid_elements'])} invalid, min SJ {q['scaled_jacobian']['min']:.3f}, "
      f"curved nodes {q['boundary_node_distance']:.2e} off, first layer {json.dumps(q['first_layer_change'])}, {r['total_s']:.2f} s")
PY
    if [[ $3 == 2 ]]; then
        "$PYTHON" tests/python/check_msh.py "$out" | "$PYTHON" -c "
import json, sys
g = json.load(sys.stdin); m = g['elements_3d']['minDetJac']
print(f'  Gmsh: {len(m)} elements read, {sum(1 for x in m if x <= 0)} with minDetJac <= 0 (least {min(m):.2e}); types', {k: v['count'] for k, v in g['element_types'].items()})"
    else
        "$PYTHON" tests/python/check_vtk_cells.py "${out%.msh}.vtu" | "$PYTHON" -c "
import json, sys
g = json.load(sys.stdin)
print('  VTK:', {v['name']: (v['cells'], v['invalid'], f\"{v['min_det']:.2e}\") for v in g['types'].values()})"
    fi
}
for p in 2 3; do
    run "$B/extruded_1e-4.msh" tests/data/extruded_cylinder.geometry.toml "$p"
    run "$B/extruded_1e-5.msh" tests/data/extruded_cylinder.geometry.toml "$p"
    run "$B/ballprism_1e-3.msh" "$B/sphere.toml" "$p"
done
run "$B/hexpyr_-.msh" "$B/hexpyr.toml" 2
