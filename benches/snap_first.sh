#!/usr/bin/env bash
# Issue 22 benchmark: deformesh `curve` (its default, the snap first) against
# Gmsh's setOrder on the extruded cylinder layers of the issue, in one run.
#
# Usage: benches/snap_first.sh [REPEAT]     (default 3; medians of times)
#
# Environment: DEFORMESH (default target/release/deformesh), PYTHON (default
# .venv/bin/python), MEMBERS (default "ogrid:8:2:16 1e-3:0.04 1e-5:0.04": first layer and
# wall size of benches/extruded_setorder.py; 7,952 and 15,924 hexes), ORDERS
# (default 3); a member `ogrid:N:M:LAYERS` is the O-grid cylinder of
# benches/ogrid_setorder.py instead (ogrid:8:2:16: 2,048 hexes, in the
# default). The ball octants are in benches/curving.sh.
# Per row: hexes, invalid elements (ours: certified; Gmsh: minDetJac <= 0),
# least scaled Jacobian (ours sampled; Gmsh its minSJ bound), whether the
# snap was kept, seconds (ours: the whole run with files written; Gmsh:
# setOrder alone), peak memory (ours, MiB).
set -euo pipefail
cd "$(dirname "$0")/.."
REPEAT=${1:-3}
DEFORMESH=${DEFORMESH:-target/release/deformesh}
PYTHON=${PYTHON:-.venv/bin/python}
MEMBERS=${MEMBERS:-"ogrid:8:2:16 1e-3:0.04 1e-5:0.04"}
ORDERS=${ORDERS:-3}
DIR=target/snap-first-bench
mkdir -p "$DIR"
[[ -x $DEFORMESH ]] || cargo build --release
median() { sort -g | awk '{ a[NR] = $1 } END { print (NR % 2) ? a[(NR + 1) / 2] : (a[NR / 2] + a[NR / 2 + 1]) / 2 }'; }
printf '| mesh | p | method | hexes | invalid | min scaled J | snap kept | seconds (median of %s) | peak MiB |\n|---|---|---|---|---|---|---|---|---|\n' "$REPEAT"
for m in $MEMBERS; do
    if [[ $m == ogrid:* ]]; then
        IFS=: read -r _ n rings layers <<< "$m"
        msh=$DIR/ogrid_${n}_${rings}_${layers}.msh; label="O-grid $n/$rings/$layers"
        make=(benches/ogrid_setorder.py "$n" "$rings" "$layers" "$msh")
    else
        first=${m%%:*}; wall=${m##*:}; msh=$DIR/ext_${first}_${wall}.msh; label="ext $first/$wall"
        make=(benches/extruded_setorder.py "$first" "$wall" "$msh")
    fi
    for p in $ORDERS; do
        gt=(); g=""
        for _ in $(seq "$REPEAT"); do
            g=$("$PYTHON" "${make[@]}" "$p" | grep '^@@' | cut -c 4-)
            gt+=("$(echo "$g" | "$PYTHON" -c 'import json,sys; print(json.load(sys.stdin)["setorder_s"])')")
        done
        ot=()
        for _ in $(seq "$REPEAT"); do
            "$DEFORMESH" curve "$msh" --geometry tests/data/extruded_cylinder.geometry.toml --order "$p" -o "$DIR/out.msh" > "$DIR/log" 2>&1
            ot+=("$("$PYTHON" -c 'import json,sys; print(json.load(open(sys.argv[1]))["total_s"])' "$DIR/out.report.json")")
        done
        "$PYTHON" - "$DIR/out.report.json" "$g" "$(printf '%s\n' "${ot[@]}" | median)" "$(printf '%s\n' "${gt[@]}" | median)" "$label" <<'EOF'
import json, sys
r = json.load(open(sys.argv[1])); q = r["quality"]; g = json.loads(sys.argv[2])
print(f"| {sys.argv[5]} | {q['order']} | deformesh | {q['elements']} | {len(q['invalid_elements'])} | {q['scaled_jacobian']['min']:.3f} | {q['snap_first']['kept']} | {float(sys.argv[3]):.2f} | {r['peak_memory_mib']:.0f} |")
print(f"| {sys.argv[5]} | {q['order']} | Gmsh setOrder | {q['elements']} | {g['invalid']} | {g['min_minSJ']:.3f} | | {float(sys.argv[4]):.3f} | |")
EOF
    done
done
