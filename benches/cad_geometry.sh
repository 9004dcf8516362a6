#!/usr/bin/env bash
# Issue 44 benchmark: meshes made as the Gmsh tutorials make them (the
# model built with OpenCASCADE booleans, extrusion and fillets, its STEP
# written, the mesh made in that same session: tests/python/cad_models.py
# --renumber), curved by `deformesh curve --cad model.step` in a separate
# process (bound by geometry: the STEP's tags are not the session's), and
# by Gmsh's setOrder, HighOrderFastCurving and HighOrderElastic in the
# meshing session (the model built again, the same linear mesh merged).
#
# Measures, the same on both sides' files: invalid elements and min SJ /
# min det J are Gmsh's (minDetJac <= 0 is invalid); "boundary" is the
# largest distance of the boundary elements, sampled at 17 points per
# edge, from the model entity nearest to them (check_cad.py
# --by-geometry). Time: ours the whole process (read, bind, curve,
# certify, write MSH, VTU, PNG, report), Gmsh's the curving call alone;
# medians of REPEAT.
#
# Usage: benches/cad_geometry.sh [REPEAT]     (REPEAT default 3)
#   CASES    subset of the case names below (default: the first three)
#   ORDERS   default "2 3"
#   METHODS  Gmsh's, default "setorder fastcurving elastic"
#   LIMIT    seconds one Gmsh method may take (default 300)
#   DEFORMESH, PYTHON as in benches/cad.sh
set -euo pipefail
cd "$(dirname "$0")/.."
REPEAT=${1:-3}
ORDERS=${ORDERS:-"2 3"}
METHODS=${METHODS:-"setorder fastcurving elastic"}
LIMIT=${LIMIT:-300}
CASES=${CASES:-"naca2d fillet_box wing"}
DEFORMESH=${DEFORMESH:-target/release/deformesh}
PYTHON=${PYTHON:-.venv/bin/python}
DEFORMESH_GMSH_LIB=${DEFORMESH_GMSH_LIB:-$("$PYTHON" -c 'import gmsh; print(gmsh.libpath)')}
export DEFORMESH_GMSH_LIB
OUT=target/cad-geometry-bench
mkdir -p "$OUT"
[[ -x $DEFORMESH ]] || cargo build --release

# name kind [cad_models.py options]; *_full are the issue's sizes
declare -A OPTS=(
    [naca2d]="naca2d"
    [fillet_box]="fillet_box"
    [wing]="wing"
    [naca2d_full]="naca2d --size 0.004 --far 0.1 --first 1e-4"
    [wing_full]="wing --size 0.05"
)
rows="$OUT/rows.jsonl"
: >"$rows"
for name in $CASES; do
    read -r kind extra <<<"${OPTS[$name]}"
    for p in $ORDERS; do
        dir="$OUT/$name-$p"
        mkdir -p "$dir"
        # shellcheck disable=SC2086
        "$PYTHON" tests/python/cad_models.py "$kind" "$dir" --renumber $extra >/dev/null
        for r in $(seq "$REPEAT"); do
            s=$(date +%s.%N)
            rc=0
            "$DEFORMESH" curve "$dir/$kind.msh" --cad "$dir/$kind.step" --order "$p" -o "$dir/ours.msh" --force >"$dir/ours.log" 2>&1 || rc=$?
            e=$(date +%s.%N)
            ours=$("$PYTHON" tests/python/check_cad.py --by-geometry "$dir/$kind.step" "$dir/ours.msh" 2>/dev/null || echo null)
            echo "{\"case\":\"$name\",\"p\":$p,\"tool\":\"deformesh\",\"rc\":$rc,\"seconds\":$(echo "$e - $s" | bc | awk '{printf "%.4f", $1}'),\"judged\":$ours}" >>"$rows"
            for m in $METHODS; do
                peer="$dir/peer-$m"
                mkdir -p "$peer"
                # the very file ours curved (Gmsh's boundary layers are not
                # repeatable to the element), in a session that built the
                # model as the meshing session did
                # shellcheck disable=SC2086
                j=$(timeout "$LIMIT" "$PYTHON" tests/python/cad_models.py "$kind" "$peer" --renumber $extra --peers "$p" --methods "$m" --merge "$dir/$kind.msh" 2>/dev/null || echo null)
                echo "{\"case\":\"$name\",\"p\":$p,\"tool\":\"$m\",\"peer\":$j}" >>"$rows"
            done
        done
    done
done
"$PYTHON" - "$rows" <<'EOF'
import json, statistics, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
label = {"deformesh": "**deformesh** (whole process)", "setorder": "Gmsh setOrder (call)",
         "fastcurving": "Gmsh FastCurving (call)", "elastic": "Gmsh Elastic (call)"}
print("| model | p | tool | elements | invalid | min SJ | min det J | boundary | time (s) |")
print("|---|---|---|---|---|---|---|---|---|")
keys = []
for r in rows:
    k = (r["case"], r["p"], r["tool"])
    if k not in keys:
        keys.append(k)
for k in keys:
    runs = [r for r in rows if (r["case"], r["p"], r["tool"]) == k]
    if k[2] == "deformesh":
        ok = [r for r in runs if r["rc"] == 0 and r["judged"]]
        if not ok:
            print(f"| {k[0]} | {k[1]} | {label[k[2]]} | | exit {runs[0]['rc']} | | | | |")
            continue
        j = ok[-1]["judged"]
        figs = (j["elements"], j["invalid"], j["min_sj"], j["min_det_jac"], j["sample_distance"][str(j["dim"] - 1)])
        secs = statistics.median(r["seconds"] for r in ok)
    else:
        ok = [r["peer"][k[2]] for r in runs if r["peer"]]
        if not ok:
            print(f"| {k[0]} | {k[1]} | {label[k[2]]} | | not done in the limit | | | | |")
            continue
        j = ok[-1]
        figs = (j["elements"], j["invalid"], j["min_sj"], j["min_det_jac"], j["boundary_sample_distance"])
        secs = statistics.median(r["seconds"] for r in ok)
    print(f"| {k[0]} | {k[1]} | {label[k[2]]} | {figs[0]} | {figs[1]} | {figs[2]:.3f} | {figs[3]:.2e} | {figs[4]:.1e} | {secs:.2f} |")
EOF
