#!/usr/bin/env bash
# Level sets at the speed of the built-in shapes: `deformesh curve` of the
# same meshes with their walls bound by built-in shapes and by the same
# surfaces as level sets, in one run.
#
# Usage: benches/level_sets.sh [REPEAT] [ORDER]
#
#   REPEAT  runs per measurement (default 3); the median is reported
#   ORDER   element order (default 2)
#
# Environment:
#   DEFORMESH  binary (default target/release/deformesh; built with
#              `cargo build --release` if it is the default and missing)
#   PYTHON     Python with the gmsh module (default .venv/bin/python if
#              present, else python3)
#
# The meshes and geometry files (benches/level_sets_meshes.py) go to
# target/level-sets-bench/ if absent:
#   hollow_cylinder  0.5 <= r <= 1, 0 <= z <= 1, 1,152 hexes; inner and
#                    outer curved onto cylinder shapes or onto the level
#                    sets x^2 + y^2 - 0.25 and x^2 + y^2 - 1, top and
#                    bottom slip
#   torus            the solid torus R = 1, r = 0.5, 2,560 hexes, its
#                    surface the level set (sqrt(x^2 + y^2) - 1)^2 + z^2 - 0.25
#                    (no built-in torus shape: level set only)
# Times are wall-clock seconds of the whole command (reading, curving,
# certifying, writing the mesh, VTU, PNG and report), and the "algorithm 2"
# time the command prints.
set -euo pipefail
cd "$(dirname "$0")/.."

REPEAT=${1:-3}
ORDER=${2:-2}
case "$REPEAT$ORDER" in ''|*[!0-9]*) echo "usage: $0 [REPEAT] [ORDER]" >&2; exit 2 ;; esac
if [[ -z "${DEFORMESH:-}" ]]; then
    DEFORMESH=target/release/deformesh
    [[ -x $DEFORMESH ]] || cargo build --release
fi
if [[ -z "${PYTHON:-}" ]]; then
    if [[ -x .venv/bin/python ]]; then PYTHON=.venv/bin/python; else PYTHON=python3; fi
fi
DIR=target/level-sets-bench
OUT=$DIR/out
mkdir -p "$OUT"
need=0
for f in hollow_cylinder.msh torus.msh hollow_cylinder.shapes.toml hollow_cylinder.level_sets.toml torus.level_sets.toml; do
    [[ -f $DIR/$f ]] || need=1
done
if [[ $need == 1 ]]; then
    "$PYTHON" benches/level_sets_meshes.py "$DIR"
fi

median() { sort -g | awk '{a[NR] = $1} END {print a[int((NR + 1) / 2)]}'; }

# one measurement: prints "WALL ALG2" medians of REPEAT runs
measure() {
    local mesh=$1 geometry=$2 name=$3 walls=() algs=() t0 t1 log
    log=$OUT/$name.log
    for ((k = 0; k < REPEAT; k++)); do
        t0=$(date +%s.%N)
        "$DEFORMESH" curve "$DIR/$mesh" --geometry "$DIR/$geometry" --order "$ORDER" -o "$OUT/$name.msh" >"$log" 2>&1 || {
            echo "level_sets.sh: $name failed, see $log" >&2
            exit 1
        }
        t1=$(date +%s.%N)
        walls+=("$(echo "$t1 - $t0" | bc -l)")
        algs+=("$(sed -n 's/.*algorithm 2 \([0-9.]*\)s.*/\1/p' "$log" | tail -1)")
    done
    printf '%s %s\n' "$(printf '%s\n' "${walls[@]}" | median)" "$(printf '%s\n' "${algs[@]}" | median)"
}

echo "deformesh curve --order $ORDER, median of $REPEAT runs ($DEFORMESH)"
printf '%-16s %-12s %6s %10s %12s %9s\n' mesh binding hexes "wall (s)" "alg. 2 (s)" "vs shapes"
rows=(
    "hollow_cylinder|hollow_cylinder.msh|hollow_cylinder.shapes.toml|shapes|1152"
    "hollow_cylinder|hollow_cylinder.msh|hollow_cylinder.level_sets.toml|level_sets|1152"
    "torus|torus.msh|torus.level_sets.toml|level_sets|2560"
)
base=""
for row in "${rows[@]}"; do
    IFS='|' read -r mesh file geometry binding hexes <<<"$row"
    read -r wall alg < <(measure "$file" "$geometry" "${mesh}_$binding")
    ratio="-"
    if [[ $mesh == hollow_cylinder && $binding == shapes ]]; then
        base=$wall
        ratio="1.00"
    elif [[ $mesh == hollow_cylinder && -n $base ]]; then
        ratio=$(printf '%.2f' "$(echo "$wall / $base" | bc -l)")
    fi
    printf '%-16s %-12s %6s %10.2f %12.3f %9s\n' "$mesh" "$binding" "$hexes" "$wall" "$alg" "$ratio"
done
