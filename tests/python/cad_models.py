#!/usr/bin/env python3
"""CAD models made with Gmsh's OpenCASCADE kernel and written as STEP,
then meshed as a user would: the STEP opened again in a fresh model and
meshed there, so the mesh's entities carry the STEP's entity tags. For
the tests and the benchmark of `deformesh curve --cad`.

  naca2d      a NACA 0012 section (chord 1; upper and lower B-splines
              meeting at a sharp trailing edge and, tangentially, at the
              leading edge) in the box [-1.5, 3] x [-1.5, 1.5], with a quad
              boundary layer (Gmsh's BoundaryLayer field: first height
              FIRST, ratio 1.2, 0.02 thick, fan at the trailing edge), quads
              recombined outside (size SIZE at the airfoil, FAR at the box)
  fillet_box  the box [0, 1]^3 minus the cylinder r = 0.25 about the
              z axis through (0.5, 0.5), the edge x = y = 1 filleted
              (radius 0.25: the fillet meets its two planes tangentially
              along CAD curves); tetrahedra of size SIZE
  wing        the NACA 0012 section extruded over 0 <= z <= 1 inside a
              cylinder of radius 2 as an O-grid of four blocks, meshed
              with transfinite hexahedra (all-hex; graded towards the
              wing, first cell FIRST)

Writes DIR/KIND.step and DIR/KIND.msh (MSH 4.1, linear). The wing's
four blocks come out of the STEP as four solids with a face each where
two touch; the meshing session glues them (removeAllDuplicates, which
renumbers the entities), so it also writes the model it meshed as
DIR/wing.brep, as a user must, and the mesh binds to that file. Physical groups:
none for naca2d and fillet_box (every entity's elements are saved, as
Gmsh does by default), wing, farfield, ends and fluid for the wing.

--renumber: mesh in the session that built the model instead, as the
Gmsh tutorials do (its entity tags are not those of the STEP read again:
`--cad` binds it by geometry); Gmsh's own curving (--peers) then runs on
the model built again in its session.
--merge MESH: with --peers, Gmsh's curving of MESH (a mesh this script
made before, so that both sides curve the very same file: Gmsh's boundary
layer meshing is not repeatable to the element), nothing meshed or written.
--peers P: Gmsh's own curving of the same mesh on the same CAD (setOrder
P, and with --methods also HighOrderFastCurving / HighOrderElastic),
each from the linear mesh, judged as check_cad.py judges ours; prints
JSON {method: {"invalid", "min_sj", "min_det_jac",
"boundary_sample_distance", "seconds", "elements"}}.

Usage: cad_models.py KIND DIR [--size S] [--far F] [--first H] [--renumber]
                     [--peers P] [--methods setorder,fastcurving,elastic]
                     [--merge MESH]"""
import argparse
import json
import math
import os
import sys
import time

import gmsh

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import check_cad  # noqa: E402

DEFAULTS = {"naca2d": (0.02, 0.25, 1e-3), "fillet_box": (0.1, 0.1, 0.0), "wing": (0.06, 0.4, 0.01)}

ap = argparse.ArgumentParser()
ap.add_argument("kind", choices=sorted(DEFAULTS))
ap.add_argument("dir")
ap.add_argument("--size", type=float)
ap.add_argument("--far", type=float)
ap.add_argument("--first", type=float)
ap.add_argument("--renumber", action="store_true")
ap.add_argument("--peers", type=int)
ap.add_argument("--methods", default="setorder")
ap.add_argument("--merge")
a = ap.parse_args()
size, far, first = (v if v is not None else d for v, d in zip((a.size, a.far, a.first), DEFAULTS[a.kind]))
step = os.path.join(a.dir, a.kind + ".step")
msh = os.path.join(a.dir, a.kind + ".msh")
# the model the mesh is bound to
model = os.path.join(a.dir, a.kind + (".brep" if a.kind == "wing" else ".step"))


def naca(x):
    """NACA 0012 half thickness, closed trailing edge."""
    return 0.6 * (0.2969 * math.sqrt(x) - 0.1260 * x - 0.3516 * x**2 + 0.2843 * x**3 - 0.1036 * x**4)


def airfoil(occ, n=60, split=None):
    """The section's curves: upper (trailing to leading edge) and lower
    (leading to trailing edge) B-splines through n cosine-spaced points
    each, vertical at the leading edge; with `split` (a chord fraction)
    each also cut there. Returns the curve tags in order around it."""
    xs = [0.5 * (1 - math.cos(math.pi * i / n)) for i in range(n + 1)]
    te, le = occ.addPoint(1, 0, 0), occ.addPoint(0, 0, 0)
    up = [te] + [occ.addPoint(x, naca(x), 0) for x in reversed(xs[1:-1])] + [le]
    lo = [le] + [occ.addPoint(x, -naca(x), 0) for x in xs[1:-1]] + [te]
    # with the law's own unit direction (dx, dy) at every point, from
    # the leading edge (vertical there) to the trailing edge: no wiggle
    def direction(x):
        if x == 0:
            return (0.0, 1.0)
        dy = 0.6 * (0.2969 * 0.5 / math.sqrt(x) - 0.1260 - 2 * 0.3516 * x + 3 * 0.2843 * x**2 - 4 * 0.1036 * x**3)
        return (1 / math.hypot(1, dy), dy / math.hypot(1, dy))
    dirs = [direction(x) for x in xs]
    up_t = [c for k in reversed(range(n + 1)) for c in (-dirs[k][0], -dirs[k][1], 0)]
    lo_t = [c for k in range(n + 1) for c in (dirs[k][0], -dirs[k][1], 0)]
    curves = [occ.addSpline(up, tangents=up_t), occ.addSpline(lo, tangents=lo_t)]
    # the points the splines pass through are not the model's
    occ.remove([(0, t) for t in up[1:-1] + lo[1:-1]])
    if split is None:
        return curves
    cuts = [occ.addPoint(split, naca(split), 0), occ.addPoint(split, -naca(split), 0)]
    out = occ.fragment([(1, c) for c in curves], [(0, p) for p in cuts])[0]
    return [t for d, t in out if d == 1]


def build():
    """The model of `kind`, synchronised."""
    occ = gmsh.model.occ
    if a.kind == "naca2d":
        foil = occ.addPlaneSurface([occ.addCurveLoop(airfoil(occ))])
        box = occ.addRectangle(-1.5, -1.5, 0, 4.5, 3)
        occ.cut([(2, box)], [(2, foil)])
    elif a.kind == "fillet_box":
        box = occ.addBox(0, 0, 0, 1, 1, 1)
        occ.synchronize()
        edge = [t for _, t in gmsh.model.getEntities(1) if _on_line(t, (1, 1))]
        box = occ.fillet([box], edge, [0.25])[0][1]
        hole = occ.addCylinder(0.5, 0.5, -0.1, 0, 0, 1.2, 0.25)
        occ.cut([(3, box)], [(3, hole)])
    else:
        ogrid(occ)
    occ.synchronize()


def _on_line(curve, xy):
    """Whether curve lies on the vertical line through xy."""
    b = gmsh.model.getBoundingBox(1, curve)
    return all(abs(b[i] - xy[i % 3]) < 1e-6 for i in (0, 1, 3, 4))


def ogrid(occ):
    """The wing's four blocks: between the section (cut at 40 % chord)
    and the circle r = 2 about (0.5, 0), split by radial lines at the
    trailing edge, the cuts and the leading edge; extruded to z = 1."""
    foil = airfoil(occ, split=0.4)
    occ.synchronize()
    # the four points around the section, in order: TE, upper cut, LE, lower cut
    inner = [(1, 0), (0.4, naca(0.4)), (0, 0), (0.4, -naca(0.4))]
    h = 2 * math.sin(math.acos(-0.05))
    outer = [(2.5, 0), (0.4, h), (-1.5, 0), (0.4, -h)]
    ip = [next(t for _, t in gmsh.model.getEntities(0) if _at(t, (x, y, 0))) for x, y in inner]
    centre = occ.addPoint(0.5, 0, 0)
    op = [occ.addPoint(x, y, 0) for x, y in outer]
    radial = [occ.addLine(ip[k], op[k]) for k in range(4)]
    arcs = [occ.addCircleArc(op[k], centre, op[(k + 1) % 4]) for k in range(4)]
    # the section's piece from inner point k to k + 1
    piece = [next(c for c in foil if set(_ends(c)) == {ip[k], ip[(k + 1) % 4]}) for k in range(4)]
    faces = [occ.addPlaneSurface([occ.addCurveLoop([piece[k], radial[(k + 1) % 4], arcs[k], radial[k]])]) for k in range(4)]
    occ.remove([(0, centre)])
    blocks = [dt for dt in occ.extrude([(2, f) for f in faces], 0, 0, 1) if dt[0] == 3]
    # one face between two blocks, not two
    occ.fragment(blocks, [])


def _ends(curve):
    """The point tags at the ends of `curve`."""
    return [t for _, t in gmsh.model.getBoundary([(1, curve)], oriented=False)]


def mesh():
    """The linear mesh of the current model, as `kind` asks."""
    opt = gmsh.option.setNumber
    opt("Mesh.MeshSizeFromCurvature", 0)
    if a.kind == "naca2d":
        wall = [t for _, t in gmsh.model.getEntities(1) if gmsh.model.getType(1, t) == "BSpline"]
        te = [t for _, t in gmsh.model.getEntities(0) if _at(t, (1, 0, 0))]
        f = gmsh.model.mesh.field
        bl = f.add("BoundaryLayer")
        f.setNumbers(bl, "CurvesList", wall)
        f.setNumber(bl, "Size", first)
        f.setNumber(bl, "Ratio", 1.2)
        f.setNumber(bl, "Thickness", 0.02)
        f.setNumber(bl, "Quads", 1)
        f.setNumbers(bl, "FanPointsList", te)
        f.setAsBoundaryLayer(bl)
        dist = f.add("Distance")
        f.setNumbers(dist, "CurvesList", wall)
        f.setNumber(dist, "Sampling", 200)
        th = f.add("Threshold")
        f.setNumber(th, "InField", dist)
        f.setNumber(th, "SizeMin", size)
        f.setNumber(th, "SizeMax", far)
        f.setNumber(th, "DistMin", 0.02)
        f.setNumber(th, "DistMax", 1.5)
        f.setAsBackgroundMesh(th)
        opt("Mesh.MeshSizeExtendFromBoundary", 0)
        opt("Mesh.Algorithm", 8)
        opt("Mesh.RecombineAll", 1)
        gmsh.model.mesh.generate(2)
    elif a.kind == "fillet_box":
        opt("Mesh.MeshSizeMax", size)
        gmsh.model.mesh.generate(3)
    else:
        gmsh.model.occ.removeAllDuplicates()
        gmsh.model.occ.synchronize()
        gmsh.write(model)
        transfinite_wing()
        gmsh.model.mesh.generate(3)
        groups_wing()


def _at(point, x):
    return math.dist(gmsh.model.getValue(0, point, []), x) < 1e-9


def transfinite_wing():
    """Transfinite curves, faces and blocks: section pieces and their
    arcs at spacing SIZE, FAR along z, the radial lines graded from the
    wing outwards (ratio 1.15, first cell about FIRST)."""
    n_radial = int(round(math.log(1 + 1.5 * 0.15 / first) / math.log(1.15))) + 1
    n_span = max(2, int(round(1 / far)) + 1)
    for _, c in gmsh.model.getEntities(1):
        p, q = _end_points(c)
        if abs(p[2] - q[2]) > 0.5:
            gmsh.model.mesh.setTransfiniteCurve(c, n_span)
        elif gmsh.model.getType(1, c) == "Line":
            # Progression grows from the curve's first point: flip it
            # where that point is the outer one
            outward = math.hypot(p[0] - 0.5, p[1]) < math.hypot(q[0] - 0.5, q[1])
            gmsh.model.mesh.setTransfiniteCurve(c, n_radial, "Progression", 1.15 if outward else -1.15)
        else:
            # a section piece or the arc facing it: the upper and lower
            # pieces (trailing edge to 40 %) are longer than the nose's
            back = min(p[0], q[0]) > 0.35
            gmsh.model.mesh.setTransfiniteCurve(c, int(round((0.6 if back else 0.5) / size)) + 1)
    for _, s in gmsh.model.getEntities(2):
        gmsh.model.mesh.setTransfiniteSurface(s)
        gmsh.model.mesh.setRecombine(2, s)
    for _, v in gmsh.model.getEntities(3):
        gmsh.model.mesh.setTransfiniteVolume(v)


def _end_points(c):
    """The coordinates of curve c's first and last points."""
    b = gmsh.model.getBoundary([(1, c)], oriented=True)
    return [gmsh.model.getValue(0, abs(t), []) for _, t in b][:2]


def groups_wing():
    surfaces = [t for _, t in gmsh.model.getEntities(2)]
    on = lambda s, k: gmsh.model.getType(2, s) == k
    z = lambda s: gmsh.model.getBoundingBox(2, s)
    # OpenCASCADE's extruded B-spline: Gmsh says "Unknown"
    wall = [s for s in surfaces if not on(s, "Plane") and not on(s, "Cylinder")]
    farfield = [s for s in surfaces if on(s, "Cylinder")]
    ends = [s for s in surfaces if abs(z(s)[5] - z(s)[2]) < 1e-6]
    gmsh.model.addPhysicalGroup(2, wall, name="wing")
    gmsh.model.addPhysicalGroup(2, farfield, name="farfield")
    gmsh.model.addPhysicalGroup(2, ends, name="ends")
    gmsh.model.addPhysicalGroup(3, [t for _, t in gmsh.model.getEntities(3)], name="fluid")


def peers(p):
    """Gmsh's curving of the linear mesh, each method from the file."""
    out = {}
    for method in a.methods.split(","):
        gmsh.clear()
        if a.renumber:
            # in the meshing session: the model built again, as it was meshed
            build()
            if a.kind == "wing":
                gmsh.model.occ.removeAllDuplicates()
                gmsh.model.occ.synchronize()
        else:
            gmsh.open(model)
        gmsh.merge(a.merge or msh)
        t0 = time.perf_counter()
        gmsh.model.mesh.setOrder(p)
        if method != "setorder":
            gmsh.option.setNumber("Mesh.HighOrderOptimize", 4 if method == "fastcurving" else 3)
            gmsh.model.mesh.optimize("HighOrderFastCurving" if method == "fastcurving" else "HighOrderElastic")
        secs = time.perf_counter() - t0
        j = check_cad.judge()
        dim = j["dim"]
        out[method] = {"elements": j["elements"], "invalid": j["invalid"], "min_sj": j["min_sj"], "min_det_jac": j["min_det_jac"],
                       "boundary_sample_distance": j["sample_distance"][str(dim - 1)], "seconds": secs}
    return out


gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
build()
check_cad.write_quietly(step)
if not a.renumber:
    # as a user would: the STEP opened and meshed in a model of its own
    gmsh.clear()
    gmsh.open(step)
if not a.merge:
    mesh()
    gmsh.write(msh)
if a.peers:
    print(json.dumps(peers(a.peers)))
gmsh.finalize()
