#!/usr/bin/env bash
# Issue 21 benchmark: deformesh against Gmsh's setOrder, HighOrderFastCurving
# and HighOrderElastic on the triangle and tetrahedral meshes of the issue,
# at p = 2 and 3, in one run: invalid elements, min scaled Jacobian (ours:
# the certificate's Gmsh minSIGE; Gmsh's: its minSJ), boundary error
# (largest distance of the sampled wall to its shape), time (median of
# REPEAT runs, each Gmsh run in a fresh process on the same CAD).
#
# Usage: benches/simplices.sh [REPEAT]          (default 3)
#   DEFORMESH  binary (default target/release/deformesh)
#   PYTHON     Python with gmsh (default .venv/bin/python)
set -euo pipefail
cd "$(dirname "$0")/.."
REPEAT=${1:-3}
DEFORMESH=${DEFORMESH:-target/release/deformesh}
PYTHON=${PYTHON:-.venv/bin/python}
OUT=target/simplices-bench
mkdir -p "$OUT"
cat > "$OUT/circle.toml" <<'EOF'
[[group]]
name = "wall"
kind = "curve"
shape = { type = "circle", centre = [0.0, 0.0], radius = 0.5 }
EOF
cat > "$OUT/sphere.toml" <<'EOF'
[[group]]
name = "sphere"
kind = "curve"
shape = { type = "sphere", centre = [0.0, 0.0, 0.0], radius = 0.5 }
EOF
median() { sort -g | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}'; }
field() { "$PYTHON" -c "import json,sys; print(json.load(sys.stdin)$1)"; }

# name script kind geometry wall-group args
CASES=(
  "triangle_layer tests/python/triangle_meshes.py layer circle wall"
  "tet_ball_box tests/python/tet_meshes.py ballbox sphere sphere"
)
printf '| mesh | p | tool | elements | invalid | min SJ | boundary error | time (s) |\n|---|---|---|---|---|---|---|---|\n'
for c in "${CASES[@]}"; do
    read -r name script kind geom group <<<"$c"
    mesh="$OUT/$name.msh"
    "$PYTHON" "$script" "$kind" "$mesh" >/dev/null
    for p in 2 3; do
        times=()
        for _ in $(seq "$REPEAT"); do
            start=$(date +%s.%N)
            "$DEFORMESH" curve "$mesh" --geometry "$OUT/$geom.toml" --order "$p" -o "$OUT/out/${name}_p$p.msh" >/dev/null 2>&1
            times+=("$(echo "$(date +%s.%N) - $start" | bc)")
        done
        r="$OUT/out/${name}_p$p.report.json"
        q=$(cat "$r")
        printf '| %s | %s | deformesh | %s | %s | %.3f | %.2e | %.3f |\n' "$name" "$p" \
            "$(field "['quality']['elements']" <<<"$q")" "$(field "['quality']['invalid_elements'].__len__()" <<<"$q")" \
            "$(field "['quality']['scaled_jacobian']['min']" <<<"$q")" "$(field "['quality']['boundary_error']['$group']['samples']" <<<"$q")" \
            "$(printf '%s\n' "${times[@]}" | median)"
        for method in setorder fastcurving elastic; do
            secs=()
            for _ in $(seq "$REPEAT"); do
                j=$("$PYTHON" "$script" "$kind" "$OUT/gmsh_$name.msh" --order "$p" --method "$method" || echo '{"error": "failed"}')
                secs+=("$(field "['seconds']" <<<"$j" 2>/dev/null || echo nan)")
            done
            printf '| %s | %s | Gmsh %s | %s | %s | %.3f | %.2e | %.3f |\n' "$name" "$p" "$method" \
                "$(field "['elements']" <<<"$j")" "$(field "['invalid']" <<<"$j")" "$(field "['min_sj']" <<<"$j")" \
                "$(field "['boundary_sample_distance']" <<<"$j")" "$(printf '%s\n' "${secs[@]}" | median)"
        done
    done
done
