#!/usr/bin/env bash
# Behaviour unchanged (issue 12): runs every case in cases/ and `deformesh
# curve` on the test meshes in tests/data/, takes the figures from each
# report.json and compares them with the values recorded in
# tests/data/behaviour/<run>.json.
#
#   scripts/behaviour.sh              compare every run; exit 1 naming each differing figure
#   scripts/behaviour.sh --record     run and (re)write the recorded values
#   scripts/behaviour.sh --quick      only the quick subset (the one scripts/test.sh runs)
#   scripts/behaviour.sh NAME...      only the named runs (e.g. case_quarter_disk curve_cylinder_p2)
#   scripts/behaviour.sh --list       print the run names
#
# Figures compared: every number, string and list in report.json except
# what depends on the machine or on an iterative solver's convergence:
# times (`time`, every `*_s`), peak memory (`peak_memory_mib`), iteration counts (`iterations_*`),
# multigrid rebuilds (`hierarchy_builds`), file names (`outputs`, `input`; `written`, the files' sizes and hashes) and the
# prose `definitions`. So: cells, nodes, unknowns, steps, halved steps,
# solves, the solver chosen, det J and scaled-Jacobian ranges, invalid
# cells, cell sizes, J/f min/max/L2/CoV, boundary distances, the
# repair's candidates (a list of records, each compared field by field),
# normalisation constant, high-order certification figures, and the
# command's exit status.
# Integers, strings, lists and booleans must be equal. Floats (report.json
# prints them with all 17 digits) must agree to a relative 1e-6, plus an
# absolute 1e-12 for figures at round-off level (boundary distances of
# 1e-16 on domains of size 1): |a - b| <= RTOL * max(|a|, |b|) + ATOL.
# Why not all 17 digits: runs are repeatable (every parallel sum is taken
# in fixed chunks; the last one that was not, the normalisation's, let
# water_wave_p3's settling flow differ by 1e-5 from run to run until
# stop 32), and the test build and the release build give the same 17
# digits today, but CG/AMG runs stop at a relative residual of 1e-7, so a
# mere change of summation order moves their figures by about that much. Set BEHAVIOUR_RTOL / BEHAVIOUR_ATOL to
# tighten or loosen. Each passing run prints its largest relative
# difference. Whole script: about 165 s on 2 busy cores; --quick about 20 s.
#
# The binary: $DEFORMESH if set, else target/release/deformesh (under
# $CARGO_TARGET_DIR if set), built with `cargo build --release` when missing
# or older than the sources.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
data="$root/tests/data/behaviour"

mode=compare
quick=0
only=()
for a in "$@"; do
    case "$a" in
        --record) mode=record ;;
        --quick) quick=1 ;;
        --list) mode=list ;;
        -h|--help) sed -n '2,/^set -euo/p' "$0" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
        -*) echo "behaviour.sh: unknown option $a" >&2; exit 2 ;;
        *) only+=("$a") ;;
    esac
done

# name | quick (1 = in the quick subset) | arguments after `deformesh`
# ({out} is the run's output folder)
runs=()
for c in cases/*.toml; do
    n=$(basename "$c" .toml)
    q=0
    case "$n" in quarter_disk|quarter_disk_dirichlet|quarter_disk_p3|quarter_ball_p3) q=1 ;; esac
    runs+=("case_$n|$q|run $c -o {out}")
done
cyl="tests/data/cylinder_bl_coarse.msh --geometry tests/data/behaviour/cylinder.geometry.toml"
ball="tests/data/ball_octant_hex.msh --geometry tests/data/behaviour/ball_octant.geometry.toml"
runs+=("curve_cylinder_p2|1|curve $cyl --order 2 --steps 10 -o {out}/curved.msh")
runs+=("curve_cylinder_p3_gauss_lobatto|0|curve $cyl --order 3 --steps 10 --spacing gauss_lobatto -o {out}/curved.msh")
runs+=("curve_cylinder_p2_dirichlet|0|curve $cyl --order 2 --steps 10 --mode dirichlet -o {out}/curved.msh")
runs+=("curve_ball_octant_p2|1|curve $ball --order 2 --steps 3 --snap never -o {out}/curved.msh")
# the default `--snap auto` on cells where the snap is kept: Algorithm 2 not run
runs+=("curve_ball_octant_p3_snap|0|curve $ball --order 3 -o {out}/curved.msh")

selected=()
for r in "${runs[@]}"; do
    IFS='|' read -r n q args <<<"$r"
    if ((${#only[@]})); then
        for o in "${only[@]}"; do [[ "$o" == "$n" ]] && selected+=("$r"); done
    elif ((quick == 0 || q == 1)); then
        selected+=("$r")
    fi
done
if [[ $mode == list ]]; then
    for r in "${runs[@]}"; do IFS='|' read -r n q _ <<<"$r"; echo "$n$( ((q)) && echo ' (quick)')"; done
    exit 0
fi
if ((${#only[@]})) && ((${#selected[@]} != ${#only[@]})); then
    echo "behaviour.sh: unknown run name among: ${only[*]} (see --list)" >&2
    exit 2
fi

bin="${DEFORMESH:-}"
if [[ -z "$bin" ]]; then
    bin="${CARGO_TARGET_DIR:-$root/target}/release/deformesh"
    if [[ ! -x "$bin" ]] || [[ -n "$(find src Cargo.toml Cargo.lock -newer "$bin" -print -quit)" ]]; then
        echo "behaviour: cargo build --release" >&2
        cargo build --release --quiet
    fi
fi
[[ -x "$bin" ]] || { echo "behaviour.sh: no binary at $bin" >&2; exit 2; }

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$data"
start=$SECONDS
failed=0
for r in "${selected[@]}"; do
    IFS='|' read -r n q args <<<"$r"
    out="$work/$n"
    mkdir -p "$out"
    t0=$SECONDS
    status=0
    # shellcheck disable=SC2086 # the arguments are words
    "$bin" ${args//\{out\}/$out} >"$work/$n.log" 2>&1 || status=$?
    report=$(find "$out" -maxdepth 1 -name '*report.json' | head -1)
    if ! python3 - "$mode" "$n" "$status" "${report:-}" "$data/$n.json" "${args//\{out\}/OUT}" <<'PY'
import json, math, os, sys

mode, name, status, report, recorded, command = sys.argv[1:7]
RTOL = float(os.environ.get("BEHAVIOUR_RTOL", "1e-6"))
ATOL = float(os.environ.get("BEHAVIOUR_ATOL", "1e-12"))
SKIP = {"time", "outputs", "written", "definitions", "hierarchy_builds", "input", "peak_memory_mib"}

def skipped(key):
    return key in SKIP or key.endswith("_s") or key.startswith("iterations")

def flatten(v, prefix, out):
    if isinstance(v, dict):
        for k, x in v.items():
            if not skipped(k):
                flatten(x, f"{prefix}.{k}" if prefix else k, out)
    elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
        # a list of records (the repair's candidates): each by its index,
        # so their times are skipped and their floats compared to RTOL
        for i, x in enumerate(v):
            flatten(x, f"{prefix}[{i}]", out)
    else:
        out[prefix] = v
    return out

figures = {"exit_status": int(status)}
if report and os.path.exists(report):
    with open(report) as f:
        flatten(json.load(f), "", figures)

if mode == "record":
    with open(recorded, "w") as f:
        json.dump({"command": "deformesh " + command, "figures": figures}, f, indent=1, sort_keys=True)
        f.write("\n")
    print(f"recorded {name}: {len(figures)} figures")
    sys.exit(0)

if not os.path.exists(recorded):
    print(f"{name}: no recorded values ({recorded}); run with --record")
    sys.exit(1)
with open(recorded) as f:
    want = json.load(f)["figures"]

def same(a, b):
    if isinstance(a, bool) or isinstance(b, bool) or not isinstance(a, (int, float)) or not isinstance(b, (int, float)):
        return a == b
    if isinstance(a, int) and isinstance(b, int):
        return a == b
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    return abs(a - b) <= RTOL * max(abs(a), abs(b)) + ATOL

bad = []
for k, w in want.items():
    if k not in figures:
        bad.append(f"  {k}: recorded {w!r}, now missing")
    elif not same(figures[k], w):
        g = figures[k]
        rel = ""
        if isinstance(g, (int, float)) and isinstance(w, (int, float)) and not isinstance(g, bool) and max(abs(g), abs(w)) > 0:
            rel = f" (relative {abs(g - w) / max(abs(g), abs(w)):.1e})"
        bad.append(f"  {k}: recorded {w!r}, now {g!r}{rel}")
new = sorted(set(figures) - set(want))
worst = 0.0
for k, w in want.items():
    g = figures.get(k)
    if isinstance(g, float) and isinstance(w, (int, float)) and not isinstance(w, bool) and max(abs(g), abs(w)) > ATOL:
        worst = max(worst, abs(g - w) / max(abs(g), abs(w)))
if bad:
    print(f"{name}: {len(bad)} of {len(want)} figures differ")
    print("\n".join(bad))
    sys.exit(1)
print(f"{name}: {len(want)} figures agree (largest relative difference {worst:.1e})" + (f" (new, not compared: {', '.join(new)})" if new else ""))
PY
    then
        failed=$((failed + 1))
        if ((status != 0)); then sed 's/^/    | /' "$work/$n.log" | tail -5; fi
    fi
    echo "    ($((SECONDS - t0)) s)"
done
echo "behaviour: ${#selected[@]} runs, $failed differ, $((SECONDS - start)) s"
((failed == 0))
