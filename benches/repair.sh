#!/usr/bin/env bash
# Issue 42 benchmark: `deformesh curve --cad` (the snap, its repair in
# patches, Algorithm 2 on the whole mesh only where no patch will do)
# against Gmsh's setOrder, HighOrderFastCurving and HighOrderElastic on
# the same linear meshes and the same CAD, each side a whole process that
# reads, curves and writes (ours also writes its VTU, PNG and report, as
# `curve` does by default), timed with /usr/bin/time in the same run;
# medians of REPEAT. Quality is Gmsh's own measure of every file
# (benches/gmsh_judge.py: invalid = minDetJac <= 0, minSJ).
#
# Usage: benches/repair.sh [REPEAT]          (REPEAT default 3)
#   CASES    subset of the case names below (default all)
#   ORDERS   default "2 3"
#   METHODS  Gmsh's, default "setorder fastcurving elastic"
#   LIMIT    seconds one run may take (default 300)
#   MEMORY   KB of address space one run may take (ulimit -v; default
#            none): a run over it fails, the machine is not exhausted
#   DEFORMESH, PYTHON as in benches/cad.sh
#
# Meshes (tests/python/repair_models.py: OCC, STEP written and opened
# again, tetrahedra): bracket (an L bracket, filleted, two holes),
# torus, torus_coarse (the one whose snap inverts a tetrahedron at p = 3),
# sphere, ballbox (a boolean cut); and the three the issue names:
# airfoil3 (2D: slat, main element and flap, closed B-splines, a 1e-4
# quad boundary layer, triangles elsewhere; 8,738 triangles + 8,176
# quads), tetball (the box minus the ball with size 0.12 at the ball,
# 6,317 tets) and thinlayer (the extruded cylinder layer, first cell
# 1e-5, 60,580 hexes; slow and large: give it MEMORY, e.g. 16000000, and
# LIMIT; Gmsh's Elastic asks PETSc for 21.5 GB at p = 3).
# A run that fails says why: "did not end in LIMIT s" (timeout), else its
# exit status and its log's first line naming an error, or its last line
# (the logs: DIR/ours_pP.log, DIR/g_METHOD_pP.log).
set -euo pipefail
cd "$(dirname "$0")/.."
REPEAT=${1:-3}
ORDERS=${ORDERS:-"2 3"}
METHODS=${METHODS:-"setorder fastcurving elastic"}
LIMIT=${LIMIT:-300}
DEFORMESH=${DEFORMESH:-target/release/deformesh}
PYTHON=${PYTHON:-.venv/bin/python}
DEFORMESH_GMSH_LIB=${DEFORMESH_GMSH_LIB:-$("$PYTHON" -c 'import gmsh; print(gmsh.libpath)')}
export DEFORMESH_GMSH_LIB
OUT=target/repair-bench
mkdir -p "$OUT"
[[ -x $DEFORMESH ]] || cargo build --release
median() { sort -g | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}'; }
# run TIMES CMD...: CMD timed into TIMES, stopped after LIMIT s, its
# address space capped at MEMORY KB if set; CMD's exit status
run() {
    local t=$1
    shift
    (
        [[ -z "${MEMORY:-}" ]] || ulimit -v "$MEMORY"
        exec /usr/bin/time -f "%e %M" -o "$t" timeout "$LIMIT" "$@"
    )
}
# why LOG's run with exit status RC failed
why() {
    if (($2 == 124)); then
        echo "did not end in ${LIMIT} s"
    else
        # the first line that says what went wrong, else the last
        local line
        line=$(grep -E 'Exception:|Error:|error:|ERROR:|panicked|memory allocation' "$1" | grep -v -- '-----' | head -1 || true)
        [[ -n "$line" ]] || line=$(grep -v '^[[:space:]]*$' "$1" | tail -1 || true)
        echo "failed (exit $2): $(tr '|' '/' <<<"$line" | cut -c1-160)"
    fi
}

# name kind size
ALL=(
  "bracket bracket 0.08"
  "torus torus 0.12"
  "torus_coarse torus 0.2"
  "sphere sphere 0.2"
  "ballbox ballbox 0.3"
  "airfoil3 airfoil3 0.0066"
  "tetball tetball 0.12"
  "thinlayer thinlayer 0.0098"
)
printf '| mesh | p | tool | elements | invalid | min SJ (Gmsh) | time (s) | peak MB | written |\n|---|---|---|---|---|---|---|---|---|\n'
for c in "${ALL[@]}"; do
    read -r name kind size <<<"$c"
    [[ -z "${CASES:-}" || " $CASES " == *" $name "* ]] || continue
    dir="$OUT/$name"
    mkdir -p "$dir"
    "$PYTHON" tests/python/repair_models.py "$kind" "$dir" "$size" >/dev/null
    for p in $ORDERS; do
        # ours
        : >"$dir/ours_p$p.times"
        rc=0
        for r in $(seq "$REPEAT"); do
            if run "$dir/t" "$DEFORMESH" curve "$dir/$kind.msh" --cad "$dir/$kind.step" --order "$p" -o "$dir/ours_p$p.msh" >"$dir/ours_p$p.log" 2>&1; then
                cat "$dir/t" >>"$dir/ours_p$p.times"
            else
                rc=$?
                echo "fail $rc $(tail -1 "$dir/t")" >>"$dir/ours_p$p.times"
            fi
        done
        t=$(awk '$1 != "fail" {print $1}' "$dir/ours_p$p.times" | median)
        m=$(awk '$1 != "fail" {print $2}' "$dir/ours_p$p.times" | median)
        if [[ -n "$t" ]]; then
            j=$("$PYTHON" benches/gmsh_judge.py "$dir/ours_p$p.msh")
            won=$("$PYTHON" -c 'import json,sys; r=json.load(open(sys.argv[1])); print(r["quality"]["repair"]["won"])' "$dir/ours_p$p.report.json")
            "$PYTHON" - "$name" "$p" "deformesh" "$j" "$t" "$m" "$won" <<'PY'
import json, sys
name, p, tool, j, t, m, won = sys.argv[1:]
j = json.loads(j)
print(f"| {name} | {p} | **{tool}** | {j['elements']} | {j['invalid']} | {j['min_sj']:.4f} | {float(t):.2f} | {float(m) / 1024:.0f} | {won} |")
PY
        else
            echo "| $name | $p | **deformesh** | | $(why "$dir/ours_p$p.log" "$rc") | | | | |"
        fi
        for meth in $METHODS; do
            : >"$dir/g_${meth}_p$p.times"
            n=$REPEAT
            [[ $meth == elastic ]] && n=1
            ok=1
            for r in $(seq "$n"); do
                if run "$dir/t" "$PYTHON" benches/gmsh_peer.py "$dir/$kind.step" "$dir/$kind.msh" "$p" "$meth" "$dir/g_${meth}_p$p.msh" >"$dir/g_${meth}_p$p.log" 2>&1; then
                    cat "$dir/t" >>"$dir/g_${meth}_p$p.times"
                else
                    rc=$?
                    ok=0
                fi
            done
            if ((ok)); then
                t=$(awk '{print $1}' "$dir/g_${meth}_p$p.times" | median)
                m=$(awk '{print $2}' "$dir/g_${meth}_p$p.times" | median)
                j=$("$PYTHON" benches/gmsh_judge.py "$dir/g_${meth}_p$p.msh")
                "$PYTHON" - "$name" "$p" "Gmsh $meth" "$j" "$t" "$m" "" <<'PY'
import json, sys
name, p, tool, j, t, m, won = sys.argv[1:]
j = json.loads(j)
print(f"| {name} | {p} | {tool} | {j['elements']} | {j['invalid']} | {j['min_sj']:.4f} | {float(t):.2f} | {float(m) / 1024:.0f} | |")
PY
            else
                echo "| $name | $p | Gmsh $meth | | $(why "$dir/g_${meth}_p$p.log" "$rc") | | | | |"
            fi
        done
    done
done
