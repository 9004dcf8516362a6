#!/usr/bin/env bash
# Issue 10 curving benchmark: deformesh vs Gmsh's setOrder / HighOrderElastic.
#
# Usage: benches/curving.sh [REPEAT] [--gmsh-only] [--deformesh-only]
#
#   REPEAT      runs per measurement (default 3); medians are reported
#   --gmsh-only skip the deformesh runs (also skipped if $DEFORMESH is absent)
#   --deformesh-only  skip the Gmsh timings
#
# Environment:
#   DEFORMESH   binary (default target/release/deformesh)
#   PYTHON      Python with the gmsh module (default .venv/bin/python if present, else python3)
#   GMSH_TIMEOUT  per-run limit of a Gmsh run in seconds (default 600)
#   GMSH_MAX_MEM_GB  per-run address-space cap of a Gmsh run (default 16; 0 = none)
#   CASES       space-separated subset of the case names below
#
# The meshes (benches/curving_meshes.py) go to target/curving-bench/ if absent;
# deformesh outputs to target/curving-bench/out/.  For each Gmsh-built mesh,
# Gmsh rebuilds its CAD, merges the same .msh file onto it (so that setOrder
# snaps new nodes to the CAD) and times setOrder(3), and
# optimize("HighOrderElastic") after an untimed setOrder(3), each run in a
# fresh process; invalid = getElementQualities minDetJac <= 0.
set -euo pipefail
cd "$(dirname "$0")/.."

REPEAT=3
GMSH=1
DEFO=1
for a in "$@"; do
    case "$a" in
        --gmsh-only) DEFO=0 ;;
        --deformesh-only) GMSH=0 ;;
        ''|*[!0-9]*) echo "usage: $0 [REPEAT] [--gmsh-only] [--deformesh-only]" >&2; exit 2 ;;
        *) REPEAT=$a ;;
    esac
done
DEFORMESH=${DEFORMESH:-target/release/deformesh}
if [[ -z "${PYTHON:-}" ]]; then
    if [[ -x .venv/bin/python ]]; then PYTHON=.venv/bin/python; else PYTHON=python3; fi
fi
GMSH_TIMEOUT=${GMSH_TIMEOUT:-600}
GMSH_MAX_MEM_GB=${GMSH_MAX_MEM_GB:-16}
ORDER=3
DIR=target/curving-bench
OUT=$DIR/out
mkdir -p "$OUT"

# name | input mesh | geometry | built by Gmsh (1) or a fixed test file (0)
ALL_CASES=(
    "ball_octant_h012|$DIR/ball_octant_h012.msh|$DIR/ball.toml|1"
    "ball_octant_hex|tests/data/ball_octant_hex.msh|$DIR/ball.toml|0"
    "cylinder_bl_h005|$DIR/cylinder_bl_h005.msh|$DIR/cylinder.toml|1"
    "ball_octant_h006|$DIR/ball_octant_h006.msh|$DIR/ball.toml|1"
    "ball_octant_h008|$DIR/ball_octant_h008.msh|$DIR/ball.toml|1"
)
CASES=${CASES:-"ball_octant_h012 ball_octant_hex cylinder_bl_h005 ball_octant_h006"}

need=0
for f in ball_octant_h012.msh ball_octant_h006.msh cylinder_bl_h005.msh ball.toml cylinder.toml; do
    [[ -f $DIR/$f ]] || need=1
done
if (( need )); then
    echo "# making meshes in $DIR" >&2
    "$PYTHON" benches/curving_meshes.py "$DIR" >&2
fi

if (( DEFO )) && [[ ! -x $DEFORMESH ]]; then
    echo "# $DEFORMESH not found: deformesh runs skipped" >&2
    DEFO=0
fi

median() { sort -g | awk '{a[NR]=$1} END {if (NR == 0) print "-"; else if (NR % 2) print a[(NR+1)/2]; else print (a[NR/2]+a[NR/2+1])/2}'; }
elements() { # top-dimension element count of an MSH 4.1 ASCII file (quads type 3, hexes type 5)
    awk '/^\$Elements/ {getline; e=1; left=0; next}
         e && /^\$EndElements/ {e=0}
         e && left == 0 {n[$3] += $4; left = $4; next}
         e {left--}
         END {print (n[5] ? n[5] : n[3] + 0)}' "$1"
}

ROWS=()
for c in "${ALL_CASES[@]}"; do
    IFS='|' read -r name mesh geo built <<<"$c"
    [[ " $CASES " == *" $name "* ]] || continue
    nel=$(elements "$mesh")
    if (( DEFO )); then
        walls=() ; rss=0 ; status=ok
        for ((i = 1; i <= REPEAT; i++)); do
            rc=0
            /usr/bin/time -f "%e %M" -o "$OUT/$name.time" \
                "$DEFORMESH" curve "$mesh" --geometry "$geo" --order $ORDER -o "$OUT/$name.p$ORDER.msh" \
                >"$OUT/$name.log" 2>&1 || rc=$?
            (( rc == 0 )) || status="exit $rc (see $OUT/$name.log)"
            read -r w m < <(tail -n 1 "$OUT/$name.time")
            walls+=("$w"); if (( m > rss )); then rss=$m; fi
            echo "#   $name deformesh run $i: ${w} s, ${m} KB" >&2
        done
        med=$(printf '%s\n' "${walls[@]}" | median)
        ROWS+=("$(printf '%-18s %-18s %7s %10s %8s %8s %10s  %s' "$name" deformesh "$nel" "$med" \
            "$(awk -v k="$rss" 'BEGIN{printf "%.0f", k/1024}')" - - "$status")")
    fi
    if (( GMSH )) && (( built )); then
        while IFS= read -r line; do
            ROWS+=("$("$PYTHON" - "$line" "$nel" <<'EOF'
import json, sys
r = json.loads(sys.argv[1].split(" ", 1)[1])
if r.get("elements") is not None and r["elements"] != int(sys.argv[2]):
    r["status"] += f" MISMATCH: rebuilt mesh has {r['elements']}, file {sys.argv[2]}"
f = lambda v, s: "-" if v is None else format(v, s)
note = r.get("note")
print(f"{r['mesh']:<18} {'gmsh ' + r['method']:<18} {f(r.get('elements'), 'd'):>7} "
      f"{f(r.get('median_s'), '.3f'):>10} {f(r.get('max_rss_mb'), '.0f'):>8} "
      f"{f(r.get('invalid_minDetJac_le_0'), 'd'):>8} {f(r.get('min_minSJ'), '.4g'):>10}  "
      f"{r['status']}" + (f" ({note})" if note else ""))
EOF
)")
        done < <("$PYTHON" benches/curving_meshes.py --time "$name" --mesh "$mesh" --order $ORDER \
                    --repeat "$REPEAT" --timeout "$GMSH_TIMEOUT" --max-mem-gb "$GMSH_MAX_MEM_GB" | grep '^@@GMSH@@')
    fi
done

echo
echo "Curving benchmark, order $ORDER, median of $REPEAT (Gmsh HighOrderElastic: optimize only, after setOrder)"
hdr=$(printf '%-18s %-18s %7s %10s %8s %8s %10s  %s' case method elems "wall[s]" "RSS[MB]" invalid "min minSJ" status)
echo "$hdr"
printf '%*s\n' ${#hdr} '' | tr ' ' -
printf '%s\n' "${ROWS[@]}"
