#!/usr/bin/env bash
# Issue 11 benchmark: 3D thin boundary layers, deformesh `curve` against
# Gmsh's own curving (setOrder, HighOrderFastCurving, HighOrderElastic) on
# the same linear meshes and the same CAD, in one run.
#
# Usage: benches/thin_layers.sh [REPEAT]     (default 3; medians of times)
#
# Environment:
#   DEFORMESH      binary (default target/release/deformesh)
#   PYTHON         Python with gmsh and numpy (default .venv/bin/python)
#   CASES          subset of: cyl1e-5 cyl1e-3 sphere1e-4 (default all)
#   ORDERS         default "2 3"
#   ELASTIC_TIMEOUT  seconds for one HighOrderElastic run (default 300; run once)
#
# Meshes: tests/python/cylinder_bl.py --extrude (the extruded cylinder,
# wall size 0.3, --far 0.8, 1,472 / 670 hexes)
# and tests/python/sphere_bl.py (O-grid, 3 x 3 cells a patch, 1,566 hexes,
# thinnest first cell 1e-4). Figures per row: invalid elements (ours:
# certified; Gmsh: minDetJac <= 0), least scaled Jacobian (ours: sampled on
# (3p+1)^3 points; Gmsh: its minSJ bound), sampled boundary error (17 x 17
# points a face), seconds (ours: the whole `curve` run with files written;
# Gmsh: setOrder + optimiser alone).
set -euo pipefail
cd "$(dirname "$0")/.."
REPEAT=${1:-3}
DEFORMESH=${DEFORMESH:-target/release/deformesh}
PYTHON=${PYTHON:-.venv/bin/python}
CASES=${CASES:-"cyl1e-5 cyl1e-3 sphere1e-4"}
ORDERS=${ORDERS:-"2 3"}
ELASTIC_TIMEOUT=${ELASTIC_TIMEOUT:-300}
DIR=target/thin-layers-bench
mkdir -p "$DIR/out"
[[ -x $DEFORMESH ]] || cargo build --release


# the mesh of a case, written to $DIR/<case>.msh; with extra arguments,
# Gmsh's curving of it (prints its JSON line last)
gmsh_case() {
    local case=$1; shift
    case $case in
        cyl1e-5) "$PYTHON" tests/python/cylinder_bl.py 1e-5 0.3 "$DIR/$case.msh" --far 0.8 --extrude "$@" ;;
        cyl1e-3) "$PYTHON" tests/python/cylinder_bl.py 1e-3 0.3 "$DIR/$case.msh" --far 0.8 --extrude "$@" ;;
        sphere1e-4) "$PYTHON" tests/python/sphere_bl.py 1e-4 3 "$DIR/$case.msh" "$@" ;;
    esac
}

export -f gmsh_case
export DIR PYTHON

median() { sort -g | awk '{ a[NR] = $1 } END { print (NR % 2) ? a[(NR + 1) / 2] : (a[NR / 2] + a[NR / 2 + 1]) / 2 }'; }

printf '| case | p | method | invalid | min scaled J | boundary error | seconds (median of %s) |\n|---|---|---|---|---|---|---|\n' "$REPEAT"
for case in $CASES; do
    gmsh_case "$case" > /dev/null
    geometry=tests/data/extruded_cylinder.geometry.toml; group=wall
    [[ $case == sphere* ]] && geometry=tests/data/sphere.geometry.toml && group=sphere
    for p in $ORDERS; do
        times=()
        for _ in $(seq "$REPEAT"); do
            out=$DIR/out/$case-p$p.msh
            if "$DEFORMESH" curve "$DIR/$case.msh" --geometry "$geometry" --order "$p" -o "$out" > "$DIR/out/log" 2>&1; then
                times+=("$("$PYTHON" -c "import json,sys; print(json.load(open(sys.argv[1]))['total_s'])" "${out%.msh}.report.json")")
            else
                times+=("failed")
            fi
        done
        if [[ " ${times[*]} " == *failed* ]]; then
            echo "| $case | $p | deformesh | failed: $(tail -1 "$DIR/out/log") | | | |"
        else
            "$PYTHON" - "${out%.msh}.report.json" "$group" "$(printf '%s\n' "${times[@]}" | median)" <<'EOF'
import json, sys
r = json.load(open(sys.argv[1])); q = r["quality"]; d = q["boundary_data"]
left = d["sliding_left"]
how = f"Dirichlet data after sliding stopped at t = {left['t']:.2f}" if left else ("Dirichlet" if d["dirichlet"] else "sliding")
print(f"| {r['input'].split('/')[-1][:-4]} | {q['order']} | deformesh ({how}, settled by {q['settling']['how']}) | {len(q['invalid_elements'])} | {q['scaled_jacobian']['min']:.3f} | {q['boundary_error'][sys.argv[2]]['samples']:.2e} | {float(sys.argv[3]):.2f} |")
EOF
        fi
        for method in setorder fastcurving elastic; do
            n=$REPEAT; limit=600
            [[ $method == elastic ]] && n=1 && limit=$ELASTIC_TIMEOUT
            lines=()
            for _ in $(seq "$n"); do
                lines+=("$(timeout "$limit" bash -c "gmsh_case $case --order $p --method $method" 2>&1 | tail -1 || true)")
            done
            printf '%s\n' "${lines[@]}" | "$PYTHON" -c '
import json, statistics, sys
case, p, method, limit = sys.argv[1:]
rows = []
for line in sys.stdin:
    try:
        row = json.loads(line)
    except ValueError:
        continue
    # a run stopped by the timeout leaves only the mesh line
    if "method" in row:
        rows.append(row)
if not rows:
    print(f"| {case} | {p} | Gmsh {method} | did not finish in {limit} s | | | |")
elif "error" in rows[0]:
    err = rows[0]["error"][:70]
    print(f"| {case} | {p} | Gmsh {method} | fails: {err} | | | |")
else:
    r = rows[0]
    t = statistics.median(x["seconds"] for x in rows)
    invalid, sj, dist = r["invalid"], r["min_sj"], r["boundary_sample_distance"]
    print(f"| {case} | {p} | Gmsh {method} | {invalid} | {sj:.3g} | {dist:.2e} | {t:.3f} |")
' "$case" "$p" "$method" "$limit"
        done
    done
done
