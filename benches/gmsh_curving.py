#!/usr/bin/env python3
"""Benchmark Gmsh's own high-order curving on the two reference test meshes.

Usage:
    python benches/gmsh_curving.py [--order 3] [--repeat 3] [--timeout 120]

Needs the `gmsh` Python module (tested with gmsh 4.15).  For each geometry it
rebuilds the CAD in Gmsh (OpenCASCADE), generates the linear mesh, and then
times:

  * setOrder            gmsh.model.mesh.setOrder(p)          best of --repeat
  * HighOrderElastic    setOrder(p) (untimed), then gmsh.model.mesh.optimize("HighOrderElastic")
  * HighOrderFastCurving  same with optimize("HighOrderFastCurving")
  * HighOrder           same with optimize("HighOrder")       (timed once each)

Every method runs in its own subprocess so that a Gmsh abort / crash is caught
and reported, and optimisers taking longer than --timeout seconds are killed
and reported as skipped.

Reported per (geometry, method): number of elements of the top dimension,
time in seconds, number of elements Gmsh judges invalid
(getElementQualities(tags, "minDetJac") <= 0), and the minimum of "minSJ".

Geometries (rebuilt to match the test meshes in /work/shared/data):

  cylinder_bl_coarse: [-2,2]^2 minus the disk r=0.5; boundary layer on the
      circle (first layer 1e-3, ratio 1.3, thickness 0.1 -> 13 layers), quads
      via recombination; 12 wall edges, 14 edges per square side, 368 quads
      (identical entity-wise counts and layer radii to the file).
  ball_octant_hex: unit sphere intersected with the box [0,2]^3 (the octant),
      tets subdivided into hexes (Mesh.SubdivisionAlgorithm = 2); 2680 hexes,
      486 quads on the sphere, 222 on each plane (same counts as the file).
"""

import argparse
import json
import math
import os
import subprocess
import sys
import time

GEOMETRIES = {
    "cylinder_bl_coarse": {"target_elements": 368, "dim": 2},
    "ball_octant_hex": {"target_elements": 2680, "dim": 3},
}
METHODS = ["setOrder", "HighOrderElastic", "HighOrderFastCurving", "HighOrder"]

# Mesh-size parameters calibrated against the reference files.
CYL_LC = 0.3  # -> 12 edges on the circle, 14 per square side, 368 quads
CYL_BL_SIZE = 1e-3
CYL_BL_RATIO = 1.3
CYL_BL_THICKNESS = 0.1  # -> 13 layers, outermost at r ~ 0.601 (as in the file)
BALL_LC = 0.18  # -> 670 tets -> 2680 hexes (plateau 0.175..0.2 gives 2680)


# --------------------------------------------------------------------------
# Geometry + linear mesh
# --------------------------------------------------------------------------
def build_cylinder(gmsh):
    gmsh.model.add("cylinder_bl_coarse")
    occ = gmsh.model.occ
    rect = occ.addRectangle(-2, -2, 0, 4, 4)
    disk = occ.addDisk(0, 0, 0, 0.5, 0.5)
    out, _ = occ.cut([(2, rect)], [(2, disk)])
    occ.synchronize()
    surf = [t for d, t in out if d == 2]
    curves = [t for _, t in gmsh.model.getBoundary(out, combined=False, oriented=False)]
    wall = [c for c in curves if abs(occ.getMass(1, c) - math.pi * 1.0) < 1e-6]
    farfield = [c for c in curves if c not in wall]

    f = gmsh.model.mesh.field.add("BoundaryLayer")
    gmsh.model.mesh.field.setNumbers(f, "CurvesList", wall)
    gmsh.model.mesh.field.setNumber(f, "Size", CYL_BL_SIZE)
    gmsh.model.mesh.field.setNumber(f, "Ratio", CYL_BL_RATIO)
    gmsh.model.mesh.field.setNumber(f, "Thickness", CYL_BL_THICKNESS)
    gmsh.model.mesh.field.setNumber(f, "Quads", 1)
    gmsh.model.mesh.field.setAsBoundaryLayer(f)

    gmsh.option.setNumber("Mesh.MeshSizeMin", CYL_LC)
    gmsh.option.setNumber("Mesh.MeshSizeMax", CYL_LC)
    gmsh.option.setNumber("Mesh.Algorithm", 6)  # Frontal-Delaunay (+ Blossom recombination)
    gmsh.option.setNumber("Mesh.RecombinationAlgorithm", 1)  # Blossom
    gmsh.option.setNumber("Mesh.RecombineAll", 1)

    gmsh.model.addPhysicalGroup(1, wall, 1, "wall")
    gmsh.model.addPhysicalGroup(1, farfield, 2, "farfield")
    gmsh.model.addPhysicalGroup(2, surf, 3, "fluid")
    gmsh.model.mesh.generate(2)


def build_ball(gmsh):
    # one construction of the octant for both benchmark scripts
    from curving_meshes import build_ball as build_octant

    build_octant(gmsh, "ball_octant_hex", BALL_LC)


BUILDERS = {"cylinder_bl_coarse": build_cylinder, "ball_octant_hex": build_ball}


# --------------------------------------------------------------------------
# Worker (runs in a subprocess): one geometry, one method
# --------------------------------------------------------------------------
def top_elements(gmsh, dim):
    types, tags, _ = gmsh.model.mesh.getElements(dim)
    names, all_tags = [], []
    for t, tg in zip(types, tags):
        names.append(gmsh.model.mesh.getElementProperties(t)[0])
        all_tags.extend(int(x) for x in tg)
    return names, all_tags


def quality(gmsh, dim):
    names, tags = top_elements(gmsh, dim)
    detj = gmsh.model.mesh.getElementQualities(tags, "minDetJac")
    sj = gmsh.model.mesh.getElementQualities(tags, "minSJ")
    return {
        "elements": len(tags),
        "element_types": names,
        "invalid_minDetJac_le_0": int(sum(1 for v in detj if v <= 0)),
        "min_minSJ": float(min(sj)) if len(sj) else None,
    }


def fresh_linear_mesh(gmsh, geom):
    gmsh.clear()
    gmsh.option.setNumber("General.Terminal", 0)
    BUILDERS[geom](gmsh)


def worker(geom, method, order, repeat):
    import gmsh

    gmsh.initialize(["gmsh_curving"], readConfigFiles=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.logger.start()
    dim = GEOMETRIES[geom]["dim"]
    res = {"geometry": geom, "method": method, "order": order}
    try:
        if method == "linear":
            fresh_linear_mesh(gmsh, geom)
            res["time_s"] = None
            res.update(quality(gmsh, dim))
        elif method == "setOrder":
            times = []
            for _ in range(max(1, repeat)):
                fresh_linear_mesh(gmsh, geom)
                t0 = time.perf_counter()
                gmsh.model.mesh.setOrder(order)
                times.append(time.perf_counter() - t0)
            res["time_s"] = min(times)
            res["times_s"] = times
            res.update(quality(gmsh, dim))
        else:
            fresh_linear_mesh(gmsh, geom)
            t0 = time.perf_counter()
            gmsh.model.mesh.setOrder(order)
            res["setOrder_time_s"] = time.perf_counter() - t0
            before = quality(gmsh, dim)
            res["invalid_before_opt"] = before["invalid_minDetJac_le_0"]
            t0 = time.perf_counter()
            try:
                gmsh.model.mesh.optimize(method)
                res["time_s"] = time.perf_counter() - t0
            except Exception as e:  # Gmsh reports errors as Python exceptions
                res["time_s"] = time.perf_counter() - t0
                res["status"] = "error"
                res["error"] = str(e)
            res.update(quality(gmsh, dim))
        res.setdefault("status", "ok")
    except Exception as e:
        res["status"] = "error"
        res["error"] = str(e)
    log = gmsh.logger.get()
    errs = [l for l in log if l.startswith("Error")]
    if errs:
        res["gmsh_errors"] = errs[-5:]
    gmsh.logger.stop()
    gmsh.finalize()
    print("@@RESULT@@" + json.dumps(res), flush=True)


# --------------------------------------------------------------------------
# Driver
# --------------------------------------------------------------------------
def run_one(geom, method, order, repeat, timeout):
    cmd = [sys.executable, os.path.abspath(__file__), "--worker", geom, method,
           "--order", str(order), "--repeat", str(repeat)]
    t0 = time.perf_counter()
    base = {"geometry": geom, "method": method, "order": order}
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        base.update(status="skipped_timeout", time_s=None, elements=None,
                    invalid_minDetJac_le_0=None, min_minSJ=None,
                    note=f"killed after {timeout:.0f} s (wall {time.perf_counter() - t0:.1f} s)")
        return base
    for line in p.stdout.splitlines():
        if line.startswith("@@RESULT@@"):
            return json.loads(line[len("@@RESULT@@"):])
    tail = (p.stderr or p.stdout or "").strip().splitlines()[-5:]
    base.update(status="aborted", returncode=p.returncode, time_s=None, elements=None,
                invalid_minDetJac_le_0=None, min_minSJ=None, stderr_tail=tail)
    return base


def fmt(v, spec):
    return "-" if v is None else format(v, spec)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--order", type=int, default=3)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--timeout", type=float, default=120.0,
                    help="per-optimiser wall-clock limit in seconds (default 120)")
    ap.add_argument("--geometry", choices=list(GEOMETRIES), action="append",
                    help="restrict to one geometry (may be repeated)")
    ap.add_argument("--worker", nargs=2, metavar=("GEOM", "METHOD"), help=argparse.SUPPRESS)
    args = ap.parse_args()

    if args.worker:
        worker(args.worker[0], args.worker[1], args.order, args.repeat)
        return

    geoms = args.geometry or list(GEOMETRIES)
    results = []
    for g in geoms:
        lin = run_one(g, "linear", 1, 1, 600)
        print(f"# {g}: linear mesh has {lin.get('elements')} elements "
              f"(target {GEOMETRIES[g]['target_elements']}), "
              f"invalid={lin.get('invalid_minDetJac_le_0')}", file=sys.stderr, flush=True)
        for m in METHODS:
            to = max(args.timeout, 600.0) if m == "setOrder" else args.timeout
            r = run_one(g, m, args.order, args.repeat, to)
            r["target_elements"] = GEOMETRIES[g]["target_elements"]
            results.append(r)
            print(f"#   {m}: {r.get('status')} time={fmt(r.get('time_s'), '.4f')}",
                  file=sys.stderr, flush=True)

    print(json.dumps(results, indent=2))

    hdr = f"{'geometry':<20} {'method':<22} {'elems':>6} {'time[s]':>9} {'invalid':>8} {'min minSJ':>10}  status"
    print()
    print(f"Gmsh {_gmsh_version()} high-order curving, order {args.order}, "
          f"setOrder best of {args.repeat}, optimisers once (after setOrder)")
    print(hdr)
    print("-" * len(hdr))
    for r in results:
        print(f"{r['geometry']:<20} {r['method']:<22} {fmt(r.get('elements'), 'd'):>6} "
              f"{fmt(r.get('time_s'), '.4f'):>9} {fmt(r.get('invalid_minDetJac_le_0'), 'd'):>8} "
              f"{fmt(r.get('min_minSJ'), '.4f'):>10}  {r.get('status')}"
              + (f" ({r['error']})" if r.get("error") else ""))


def _gmsh_version():
    try:
        import gmsh
        return gmsh.__version__
    except Exception:
        return "?"


if __name__ == "__main__":
    main()
