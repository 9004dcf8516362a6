#!/usr/bin/env python3
"""Make the issue-10 curving benchmark meshes, and time Gmsh's peer methods on them.

Usage:
    python benches/curving_meshes.py OUTDIR [--only NAME]
        writes OUTDIR/NAME.msh (MSH 4.1 ASCII, named physical groups) for every
        mesh below, plus OUTDIR/ball.toml and OUTDIR/cylinder.toml (the geometry
        files of tests/curve_import.rs), and prints the element counts.

    python benches/curving_meshes.py --time NAME [--mesh FILE] [--order 3] [--repeat 3] [--timeout 600]
        rebuilds the CAD of mesh NAME in Gmsh and merges FILE (the written
        mesh) onto it -- or, without --mesh, remeshes it (the cylinder's quad
        recombination is not reproducible run to run: 8202..8230 quads) -- and times
          * setOrder          gmsh.model.mesh.setOrder(p)
          * HighOrderElastic  setOrder(p) (untimed), then optimize("HighOrderElastic")
        --repeat times each, every run in its own subprocess (a crash or a run
        longer than --timeout seconds or above --max-mem-gb is reported; after a failure the remaining
        repetitions of that method are skipped).  Prints one line
        "@@GMSH@@ {json}" per method with the median time, the invalid-element
        count (getElementQualities minDetJac <= 0) and the min minSJ.

Needs the `gmsh` Python module (tested with gmsh 4.15).

Meshes (CAD rebuilt as in benches/gmsh_curving.py, same physical group names
and tags as the reference files in tests/data):

  ball_octant_h012: unit sphere intersected with the box [0,2]^3, mesh size
      0.12, tets subdivided into hexes (Mesh.SubdivisionAlgorithm = 2):
      7544 hexes.  Groups sphere / plane_x0 / plane_z0 / plane_y0 / solid.
  ball_octant_h0208 (only with --only): mesh size 0.0208, about 1.07M hexes.
  ball_octant_h006: the same with mesh size 0.06: 49424 hexes (the ~50k-hex
      case; h = 0.12 only gives ~7.5k hexes).
  cylinder_bl_h005: [-2,2]^2 minus the disk r = 0.5, mesh size 0.05
      everywhere (64 wall edges), boundary layer on the circle (first layer
      1e-4, ratio 1.3, thickness 0.1), Frontal-Delaunay + Blossom
      recombination: ~8.2k quads (8202..8230, varies from run to run).  Groups wall / farfield / fluid.
"""

import argparse
import json
import math
import os
import resource
import statistics
import subprocess
import sys
import time

# geometry files: the constants CYLINDER and BALL of tests/curve_import.rs
CYLINDER_TOML = """\
[[group]]
name = "wall"
kind = "curve"
shape = { type = "circle", centre = [0.0, 0.0], radius = 0.5 }
"""

BALL_TOML = """\
[[group]]
name = "sphere"
kind = "curve"
shape = { type = "sphere", centre = [0.0, 0.0, 0.0], radius = 1.0 }
[[group]]
name = "plane_x0"
kind = "slip"
[[group]]
name = "plane_y0"
kind = "slip"
[[group]]
name = "plane_z0"
kind = "slip"
"""

CYL_BL_SIZE = 1e-4
CYL_BL_RATIO = 1.3
CYL_BL_THICKNESS = 0.1


# --------------------------------------------------------------------------
# Geometry + linear mesh
# --------------------------------------------------------------------------
def build_cylinder(gmsh, name, lc, generate=True):
    gmsh.model.add(name)
    occ = gmsh.model.occ
    rect = occ.addRectangle(-2, -2, 0, 4, 4)
    disk = occ.addDisk(0, 0, 0, 0.5, 0.5)
    out, _ = occ.cut([(2, rect)], [(2, disk)])
    occ.synchronize()
    surf = [t for d, t in out if d == 2]
    curves = [t for _, t in gmsh.model.getBoundary(out, combined=False, oriented=False)]
    wall = [c for c in curves if abs(occ.getMass(1, c) - math.pi * 1.0) < 1e-6]
    farfield = [c for c in curves if c not in wall]

    field = gmsh.model.mesh.field
    f = field.add("BoundaryLayer")
    field.setNumbers(f, "CurvesList", wall)
    field.setNumber(f, "Size", CYL_BL_SIZE)
    field.setNumber(f, "Ratio", CYL_BL_RATIO)
    field.setNumber(f, "Thickness", CYL_BL_THICKNESS)
    field.setNumber(f, "Quads", 1)
    field.setAsBoundaryLayer(f)

    gmsh.option.setNumber("Mesh.MeshSizeMin", lc)
    gmsh.option.setNumber("Mesh.MeshSizeMax", lc)
    gmsh.option.setNumber("Mesh.Algorithm", 6)  # Frontal-Delaunay (+ Blossom recombination)
    gmsh.option.setNumber("Mesh.RecombinationAlgorithm", 1)  # Blossom
    gmsh.option.setNumber("Mesh.RecombineAll", 1)

    gmsh.model.addPhysicalGroup(1, wall, 1, "wall")
    gmsh.model.addPhysicalGroup(1, farfield, 2, "farfield")
    gmsh.model.addPhysicalGroup(2, surf, 3, "fluid")
    if generate:
        gmsh.model.mesh.generate(2)


def build_ball(gmsh, name, lc, generate=True):
    gmsh.model.add(name)
    occ = gmsh.model.occ
    sph = occ.addSphere(0, 0, 0, 1)
    box = occ.addBox(0, 0, 0, 2, 2, 2)
    out, _ = occ.intersect([(3, sph)], [(3, box)])
    occ.synchronize()
    vols = [t for d, t in out if d == 3]
    groups = {"sphere": [], "plane_x0": [], "plane_y0": [], "plane_z0": []}
    for _, s in gmsh.model.getEntities(2):
        c = occ.getCenterOfMass(2, s)
        if abs(c[0]) < 1e-6:
            groups["plane_x0"].append(s)
        elif abs(c[1]) < 1e-6:
            groups["plane_y0"].append(s)
        elif abs(c[2]) < 1e-6:
            groups["plane_z0"].append(s)
        else:
            groups["sphere"].append(s)

    gmsh.option.setNumber("Mesh.MeshSizeMax", lc)
    gmsh.option.setNumber("Mesh.SubdivisionAlgorithm", 2)  # tets -> hexes

    # same physical tags and names as tests/data/ball_octant_hex.msh
    gmsh.model.addPhysicalGroup(2, groups["sphere"], 1, "sphere")
    gmsh.model.addPhysicalGroup(2, groups["plane_x0"], 2, "plane_x0")
    gmsh.model.addPhysicalGroup(2, groups["plane_z0"], 3, "plane_z0")
    gmsh.model.addPhysicalGroup(2, groups["plane_y0"], 4, "plane_y0")
    gmsh.model.addPhysicalGroup(3, vols, 5, "solid")
    if generate:
        gmsh.model.mesh.generate(3)


# name -> (builder, mesh size, top dimension, geometry file)
MESHES = {
    "ball_octant_h012": (build_ball, 0.12, 3, "ball.toml"),
    "ball_octant_h006": (build_ball, 0.06, 3, "ball.toml"),
    # about the thin-layer issue's ball octant of 25,208 hexes
    "ball_octant_h008": (build_ball, 0.08, 3, "ball.toml"),
    "cylinder_bl_h005": (build_cylinder, 0.05, 2, "cylinder.toml"),
    # the thin-layer issue's mesh of 10^6 hexes (about 1.07M; made only
    # when asked for with --only: minutes and gigabytes)
    "ball_octant_h0208": (build_ball, 0.0208, 3, "ball.toml"),
}
BY_REQUEST = {"ball_octant_h0208"}


def fresh_mesh(gmsh, name, msh=None):
    """Build the CAD of NAME and mesh it, or, given MSH (a file written by
    make()), merge that mesh onto the CAD entities instead: the Blossom
    recombination of the cylinder is not reproducible from run to run
    (8202..8230 quads), so timings must load the very file deformesh reads.
    Merged nodes still snap to the CAD in setOrder (checked: high-order
    nodes on the circle and the sphere to 2e-16)."""
    gmsh.clear()
    gmsh.option.restoreDefaults()  # options are global: no leaks between meshes
    gmsh.option.setNumber("General.Terminal", 0)
    builder, lc, _, _ = MESHES[name]
    builder(gmsh, name, lc, generate=msh is None)
    if msh is not None:
        gmsh.merge(msh)


def top_element_tags(gmsh, dim):
    _, tags, _ = gmsh.model.mesh.getElements(dim)
    return [int(x) for tg in tags for x in tg]


def quality(gmsh, dim):
    tags = top_element_tags(gmsh, dim)
    detj = gmsh.model.mesh.getElementQualities(tags, "minDetJac")
    sj = gmsh.model.mesh.getElementQualities(tags, "minSJ")
    return {
        "elements": len(tags),
        "invalid_minDetJac_le_0": int(sum(1 for v in detj if v <= 0)),
        "min_minSJ": float(min(sj)) if len(sj) else None,
    }


# --------------------------------------------------------------------------
# Mesh writing
# --------------------------------------------------------------------------
def make(outdir, only):
    import gmsh

    os.makedirs(outdir, exist_ok=True)
    for name, (_, lc, dim, geo) in MESHES.items():
        if (only and name not in only) or (not only and name in BY_REQUEST):
            continue
        t0 = time.perf_counter()
        # a fresh Gmsh session per mesh (options and state survive gmsh.clear())
        gmsh.initialize(["curving_meshes"], readConfigFiles=False)
        gmsh.option.setNumber("General.Terminal", 0)
        fresh_mesh(gmsh, name)
        q = quality(gmsh, dim)
        gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
        gmsh.option.setNumber("Mesh.Binary", 0)
        path = os.path.join(outdir, name + ".msh")
        gmsh.write(path)
        kind = "hexes" if dim == 3 else "quads"
        print(f"{path}: {q['elements']} {kind} (h = {lc}), invalid {q['invalid_minDetJac_le_0']}, "
              f"min minSJ {q['min_minSJ']:.4f}, {time.perf_counter() - t0:.1f} s  [geometry {geo}]",
              flush=True)
        gmsh.finalize()
    for fname, text in (("ball.toml", BALL_TOML), ("cylinder.toml", CYLINDER_TOML)):
        with open(os.path.join(outdir, fname), "w") as f:
            f.write(text)


# --------------------------------------------------------------------------
# Gmsh timings
# --------------------------------------------------------------------------
def worker(name, method, order, msh):
    import gmsh

    gmsh.initialize(["curving_meshes"], readConfigFiles=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.logger.start()
    dim = MESHES[name][2]
    res = {"mesh": name, "method": method, "order": order}
    try:
        fresh_mesh(gmsh, name, msh)
        t0 = time.perf_counter()
        gmsh.model.mesh.setOrder(order)
        t_order = time.perf_counter() - t0
        if method == "setOrder":
            res["time_s"] = t_order
        else:
            res["setOrder_s"] = t_order
            t0 = time.perf_counter()
            gmsh.model.mesh.optimize(method)
            res["time_s"] = time.perf_counter() - t0
        res.update(quality(gmsh, dim))
        res["status"] = "ok"
    except Exception as e:  # Gmsh reports errors as Python exceptions
        res["status"] = "error"
        res["error"] = str(e)
    errs = [l for l in gmsh.logger.get() if l.startswith("Error")]
    if errs:
        res["gmsh_errors"] = errs[-3:]
    gmsh.logger.stop()
    gmsh.finalize()
    res["max_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    print("@@RESULT@@" + json.dumps(res), flush=True)


def run_once(name, method, order, timeout, msh, max_mem_gb):
    cmd = [sys.executable, os.path.abspath(__file__), "--worker", name, method, "--order", str(order)]
    if msh:
        cmd += ["--mesh", os.path.abspath(msh)]

    def limit():  # address-space cap: fail this run, not the machine (OOM killer)
        if max_mem_gb > 0:
            b = int(max_mem_gb * 2**30)
            resource.setrlimit(resource.RLIMIT_AS, (b, b))

    t0 = time.perf_counter()
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, preexec_fn=limit)
    except subprocess.TimeoutExpired:
        return {"status": "timeout", "note": f"killed after {time.perf_counter() - t0:.0f} s"}
    for line in p.stdout.splitlines():
        if line.startswith("@@RESULT@@"):
            return json.loads(line[len("@@RESULT@@"):])
    tail = (p.stderr or p.stdout or "").strip().splitlines()[-2:]
    note = f"exit {p.returncode} after {time.perf_counter() - t0:.0f} s"
    if max_mem_gb > 0:
        note += f", address space capped at {max_mem_gb:g} GB"
    if tail:
        note += ": " + " | ".join(tail)
    return {"status": "aborted", "returncode": p.returncode, "note": note}


def time_gmsh(name, order, repeat, timeout, methods, msh, max_mem_gb):
    for method in methods:
        runs = []
        for i in range(max(1, repeat)):
            r = run_once(name, method, order, timeout, msh, max_mem_gb)
            runs.append(r)
            print(f"#   {name} {method} run {i + 1}: {r.get('status')} "
                  f"{r.get('time_s', float('nan')):.3f} s", file=sys.stderr, flush=True)
            if r.get("status") != "ok":
                break
        ok = [r for r in runs if r.get("status") == "ok"]
        out = {"mesh": name, "method": method, "order": order, "repeat": len(runs),
               "status": runs[-1].get("status") if not ok or len(ok) < len(runs) else "ok"}
        if ok:
            last = ok[-1]
            out["median_s"] = statistics.median(r["time_s"] for r in ok)
            out["times_s"] = [r["time_s"] for r in ok]
            for k in ("elements", "invalid_minDetJac_le_0", "min_minSJ"):
                out[k] = last.get(k)
            out["max_rss_mb"] = max(r.get("max_rss_mb", 0) for r in ok)
            if "setOrder_s" in last:
                out["setOrder_s"] = last["setOrder_s"]
        if runs[-1].get("status") != "ok":
            out["note"] = runs[-1].get("note") or runs[-1].get("error")
        print("@@GMSH@@ " + json.dumps(out), flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("outdir", nargs="?", help="write the meshes and geometry files here")
    ap.add_argument("--only", action="append", choices=list(MESHES), help="make only this mesh")
    ap.add_argument("--time", choices=list(MESHES), help="time Gmsh's methods on this mesh")
    ap.add_argument("--method", action="append", help="setOrder, HighOrderElastic (default both)")
    ap.add_argument("--mesh", help="with --time: load this file (written by OUTDIR mode) onto the "
                    "rebuilt CAD instead of remeshing")
    ap.add_argument("--order", type=int, default=3)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--timeout", type=float, default=600.0, help="per-run limit in seconds")
    ap.add_argument("--max-mem-gb", type=float, default=16.0,
                    help="per-run address-space cap in GB, 0 for none (default 16)")
    ap.add_argument("--worker", nargs=2, metavar=("NAME", "METHOD"), help=argparse.SUPPRESS)
    args = ap.parse_args()

    if args.worker:
        worker(args.worker[0], args.worker[1], args.order, args.mesh)
    elif args.time:
        time_gmsh(args.time, args.order, args.repeat, args.timeout,
                  args.method or ["setOrder", "HighOrderElastic"], args.mesh, args.max_mem_gb)
    elif args.outdir:
        make(args.outdir, args.only)
    else:
        ap.error("give OUTDIR or --time NAME")


if __name__ == "__main__":
    main()
