#!/usr/bin/env bash
# Issue 24 benchmark: deformesh `curve` against Gmsh's setOrder,
# FastCurving and Elastic on the prism meshes of the issue and the
# hex-dominant mesh with pyramids (tests/python/prism_meshes.py at its
# default sizes), in one run.
#
# Usage: benches/prisms.sh [REPEAT]     (default 3; medians of times)
#
# Environment: DEFORMESH (default target/release/deformesh), PYTHON
# (default .venv/bin/python), CASES (default "extruded:1e-4 extruded:1e-5
# ballprism:1e-3 hexpyr:-": kind and first layer, - for none), ORDERS (default "2 3"), METHODS
# (Gmsh's, default "setorder fastcurving elastic"), GMSH_TIMEOUT (seconds
# per Gmsh run, default 300: Elastic takes 100–150 s on the extruded
# layers).
# Per row: elements, invalid elements (ours: certified; Gmsh at p = 2: its
# minDetJac <= 0; at p = 3, where Gmsh 4.15 evaluates no prism, VTK's own
# Lagrange cells sampled by tests/python/check_vtk_cells.py on Gmsh's
# curved mesh), least scaled Jacobian (ours sampled; Gmsh's minSJ bound;
# "-" where Gmsh cannot), boundary error (largest distance of the curved
# wall sampled on 17 points an edge), seconds (ours: the whole run with
# files written; Gmsh: the curving call alone), peak memory (ours, MiB).
set -euo pipefail
cd "$(dirname "$0")/.."
REPEAT=${1:-3}
DEFORMESH=${DEFORMESH:-target/release/deformesh}
PYTHON=${PYTHON:-.venv/bin/python}
CASES=${CASES:-"extruded:1e-4 extruded:1e-5 ballprism:1e-3 hexpyr:-"}
ORDERS=${ORDERS:-"2 3"}
METHODS=${METHODS:-"setorder fastcurving elastic"}
GMSH_TIMEOUT=${GMSH_TIMEOUT:-300}
DIR=target/prism-bench
mkdir -p "$DIR"
[[ -x $DEFORMESH ]] || cargo build --release
median() { sort -g | awk '{ a[NR] = $1 } END { print (NR % 2) ? a[(NR + 1) / 2] : (a[NR / 2] + a[NR / 2 + 1]) / 2 }'; }
SPHERE='[[group]]
name = "sphere"
kind = "curve"
shape = { type = "sphere", centre = [0.0, 0.0, 0.0], radius = 0.5 }'
printf '%s\n' "$SPHERE" > "$DIR/sphere.toml"
printf '%s\n' "${SPHERE/\[0.0, 0.0, 0.0\], radius = 0.5/[1.5, 0.5, 0.5], radius = 0.25}" > "$DIR/hexpyr.toml"
printf '| mesh | p | method | elements | invalid | min scaled J | boundary error | seconds (median of %s) | peak MiB |\n|---|---|---|---|---|---|---|---|---|\n' "$REPEAT"
for c in $CASES; do
    kind=${c%%:*}; first=${c##*:}; msh=$DIR/${kind}_${first}.msh
    geometry=tests/data/extruded_cylinder.geometry.toml; group=wall
    [[ $kind == ballprism ]] && { geometry=$DIR/sphere.toml; group=sphere; }
    [[ $kind == hexpyr ]] && { geometry=$DIR/hexpyr.toml; group=sphere; }
    layer=(--first "$first"); [[ $first == - ]] && layer=()
    "$PYTHON" tests/python/prism_meshes.py "$kind" "$msh" "${layer[@]}" 2> /dev/null
    for p in $ORDERS; do
        for method in $METHODS; do
            times=(); g=""
            for _ in $(seq "$REPEAT"); do
                g=$(timeout "$GMSH_TIMEOUT" "$PYTHON" tests/python/prism_meshes.py "$kind" "$DIR/g.msh" "${layer[@]}" --order "$p" --method "$method" --vtu "$DIR/g.vtu" 2> /dev/null) || true
                [[ -z $g ]] && break
                times+=("$(echo "$g" | "$PYTHON" -c 'import json,sys; print(json.load(sys.stdin)["seconds"])')")
            done
            if [[ -z $g ]]; then
                echo "| $kind $first | $p | Gmsh $method | | (no answer in ${GMSH_TIMEOUT} s) | | | | |"
                continue
            fi
            vtk=$("$PYTHON" tests/python/check_vtk_cells.py "$DIR/g.vtu" 2> /dev/null || true)
            "$PYTHON" - "$g" "$vtk" "$(printf '%s\n' "${times[@]}" | median)" "$kind $first" "$method" <<'EOF'
import json, sys
g = json.loads(sys.argv[1]); t = float(sys.argv[3])
if g.get("error") and (g.get("boundary_sample_distance") is None or (g.get("invalid") is None and "FaceClosureFull" not in g["error"])):
    print(f"| {sys.argv[4]} | {g['order']} | Gmsh {sys.argv[5]} | {g['elements']} | fails: {g['error'][:60]} | | | | |")
    sys.exit()
invalid = g["invalid"]
if invalid is None and sys.argv[2]:
    invalid = f"{json.loads(sys.argv[2])['overall']['invalid']} (VTK)"
sj = "-" if g["min_sj"] is None else f"{g['min_sj']:.3f}"
print(f"| {sys.argv[4]} | {g['order']} | Gmsh {sys.argv[5]} | {g['elements']} | {invalid} | {sj} | {g['boundary_sample_distance']:.2e} | {t:.3f} | |")
EOF
        done
        times=()
        for _ in $(seq "$REPEAT"); do
            "$DEFORMESH" curve "$msh" --geometry "$geometry" --order "$p" -o "$DIR/out.msh" > "$DIR/log" 2>&1 || { cat "$DIR/log"; exit 1; }
            times+=("$("$PYTHON" -c 'import json,sys; print(json.load(open(sys.argv[1]))["total_s"])' "$DIR/out.report.json")")
        done
        "$PYTHON" - "$DIR/out.report.json" "$(printf '%s\n' "${times[@]}" | median)" "$kind $first" "$group" <<'EOF'
import json, sys
r = json.load(open(sys.argv[1])); q = r["quality"]
print(f"| {sys.argv[3]} | {q['order']} | **deformesh** | {q['elements']} | {len(q['invalid_elements'])} | {q['scaled_jacobian']['min']:.3f} | {q['boundary_error'][sys.argv[4]]['samples']:.2e} | {float(sys.argv[2]):.2f} | {r['peak_memory_mib']:.0f} |")
EOF
    done
done
