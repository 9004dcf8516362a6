#!/usr/bin/env python3
"""Models for the repair in patches (issue 42), made as a user makes them:
built with Gmsh's OpenCASCADE kernel (booleans, fillets), written as
STEP, opened again in a fresh model and meshed with tetrahedra there.

  torus    the torus R = 1, r = 0.3 about the z axis
  ballbox  the box [-1.5, 1.5]^3 minus the ball r = 0.5 (a boolean cut)
  sphere   the ball r = 1
  bracket  an L bracket (2 x 1 x 0.25 plate and 0.25 x 1 x 1.5 upright,
           fused), its inner edge filleted (r = 0.2), two holes (r = 0.2)
           cut through it

Sizes: Mesh.MeshSizeMax SIZE, MeshSizeMin SIZE / 3, 12 elements per 2 pi
of curvature. Writes DIR/KIND.step and DIR/KIND.msh (MSH 4.1, linear, no
physical groups: every entity's elements saved).

Kinds with sizes of their own (the three meshes issue 42 names):

  airfoil3   2D: a three-element high-lift section, slat, main element and
             flap, each one closed (periodic) B-spline through 2 x 80
             points of a NACA 4-digit-like section with a round trailing
             edge (main: chord 1, 2 % camber at 40 %, 12 % thick; slat:
             chord 0.16, 4 % camber, 10 % thick, 25 degrees nose down;
             flap: chord 0.3, 4 % camber, 12 % thick, 25 degrees down;
             gaps 2.5 % chord), in the far-field circle r = 10 about
             (0.5, 0). Quad boundary layer on the three elements (Gmsh's
             BoundaryLayer field, first 1e-4, ratio 1.2, 0.01 thick,
             Quads), triangles elsewhere (Mesh.Algorithm 6): SIZE at the
             walls, growing to 1.0 (Threshold on the distance, 0.01 to
             5.2), and 20 elements per 2 pi of curvature (the noses);
             SIZE 0.0066: the issue's size (8,738 triangles + 8,176 quads;
             the issue: 8,800 + 8,200)
  thinlayer  3D hexes: the square [-2, 2]^2 minus the disk r = 0.5,
             extruded over 0 <= z <= 1 in four layers (1 : 2 : 4 : 8), the
             face meshed with a quad boundary layer on the circle (first
             1e-5, ratio 1.2, 0.08 thick) as
             ../shared/data/make_extruded_bl.py does (size 0.3 at the
             square's corners, SIZE on the circle). Gmsh cannot mesh an
             extruded layer in a model read from STEP (the extrusion is
             not in the file), so it is meshed in the session that built
             the model, as the Gmsh tutorials do, and its entities are
             then given the tags of the STEP read again (each matched by
             type and bounding box): the mesh binds to DIR/KIND.step as
             the others do. SIZE 0.0098: 60,580 hexahedra (the issue:
             about 60,000; 0.3: 2,768)
  tetball    tetrahedra of the box [-1.5, 1.5]^3 minus the ball r = 0.5
             (the same boolean cut as ballbox), size SIZE at the sphere
             growing to 0.49 (Threshold on the distance, 0 to 1.5; as
             tests/python/tet_meshes.py ballbox, whose 0.6 now gives 4,757
             tetrahedra); SIZE 0.12: 6,317 tetrahedra (the issue: 0.12 at
             the ball, about 6,400; ballbox at SIZE 0.12 is 72,909)

--peers P: Gmsh's own curving of that mesh on that STEP, each method from
the file (setOrder P, HighOrderFastCurving, HighOrderElastic per
--methods), judged by check_cad.judge(); prints JSON {method: {"invalid",
"min_sj", "min_det_jac", "seconds"}}.

Usage: repair_models.py KIND DIR SIZE [--peers P] [--methods setorder,fastcurving]"""
import argparse
import json
import math
import os
import sys
import time

import gmsh

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import check_cad  # noqa: E402

ap = argparse.ArgumentParser()
ap.add_argument("kind", choices=["torus", "ballbox", "sphere", "bracket", "airfoil3", "thinlayer", "tetball"])
ap.add_argument("dir")
ap.add_argument("size", type=float)
ap.add_argument("--peers", type=int)
ap.add_argument("--methods", default="setorder,fastcurving")
a = ap.parse_args()
step = os.path.join(a.dir, a.kind + ".step")
msh = os.path.join(a.dir, a.kind + ".msh")


# airfoil3: the far-field circle's radius; each element: (chord, camber,
# its place, thickness, rotation in degrees about its reference point,
# the reference point: "le" or "te", where that point goes)
FAR_R = 10.0
ELEMENTS = [
    (0.16, 0.04, 0.4, 0.10, 25.0, "te", (0.005, 0.052)),
    (1.00, 0.02, 0.4, 0.12, 0.0, "le", (0.0, 0.0)),
    (0.30, 0.04, 0.4, 0.12, -25.0, "le", (0.935, -0.045)),
]


def section(chord, m, p, t, n=80):
    """The closed outline of a NACA 4-digit-like section (chord 1, max
    camber m at p, thickness t; the thickness law's trailing edge closed
    and rounded by 0.03 sqrt(x (1 - x)), so the outline is smooth all
    round), scaled to chord: 2n points from the trailing edge over the
    upper side to the leading edge and back under it, x = (1 - cos phi) / 2."""
    pts = []
    for k in range(2 * n):
        phi = math.pi * k / n
        x = 0.5 * (1 + math.cos(phi))
        side = 1 if k <= n else -1
        yt = 5 * t * (0.2969 * math.sqrt(x) - 0.1260 * x - 0.3516 * x**2 + 0.2843 * x**3 - 0.1036 * x**4)
        yt += 0.03 * math.sqrt(max(x * (1 - x), 0))
        if x < p:
            yc, dyc = m / p**2 * (2 * p * x - x**2), 2 * m / p**2 * (p - x)
        else:
            yc, dyc = m / (1 - p) ** 2 * (1 - 2 * p + 2 * p * x - x**2), 2 * m / (1 - p) ** 2 * (p - x)
        th = math.atan(dyc)
        pts.append((chord * (x - side * yt * math.sin(th)), chord * (yc + side * yt * math.cos(th))))
    return pts


def placed(element):
    """The outline of one of ELEMENTS where the configuration puts it."""
    chord, m, p, t, deg, ref, at = element
    pts = section(chord, m, p, t)
    x0, y0 = (0.0, 0.0) if ref == "le" else pts[0]
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return [(at[0] + c * (x - x0) - s * (y - y0), at[1] + s * (x - x0) + c * (y - y0)) for x, y in pts]


def three_elements(occ):
    """The slat's, the main element's and the flap's closed B-splines."""
    curves = []
    for e in ELEMENTS:
        tags = [occ.addPoint(x, y, 0) for x, y in placed(e)]
        curves.append(occ.addSpline(tags + [tags[0]]))
        # the points the splines pass through are not the model's
        occ.remove([(0, t) for t in tags[1:]])
    return curves


def build(occ):
    if a.kind == "torus":
        occ.addTorus(0, 0, 0, 1, 0.3)
    elif a.kind == "sphere":
        occ.addSphere(0, 0, 0, 1)
    elif a.kind in ("ballbox", "tetball"):
        box = occ.addBox(-1.5, -1.5, -1.5, 3, 3, 3)
        occ.cut([(3, box)], [(3, occ.addSphere(0, 0, 0, 0.5))])
    elif a.kind == "airfoil3":
        far = occ.addDisk(0.5, 0, 0, FAR_R, FAR_R)
        occ.cut([(2, far)], [(2, occ.addPlaneSurface([occ.addCurveLoop([c])])) for c in three_elements(occ)])
    elif a.kind == "thinlayer":
        square = occ.addRectangle(-2, -2, 0, 4, 4)
        face = occ.cut([(2, square)], [(2, occ.addDisk(0, 0, 0, 0.5, 0.5))])[0][0][1]
        h = [1, 2, 4, 8]
        cum = [sum(h[:k + 1]) / sum(h) for k in range(4)]
        occ.extrude([(2, face)], 0, 0, 1, numElements=[1, 1, 1, 1], heights=cum, recombine=True)
    else:
        plate, upright = occ.addBox(0, 0, 0, 2, 1, 0.25), occ.addBox(0, 0, 0, 0.25, 1, 1.5)
        fused, _ = occ.fuse([(3, plate)], [(3, upright)])
        occ.synchronize()

        def inner(e):
            x0, y0, z0, x1, y1, z1 = gmsh.model.getBoundingBox(1, e)
            return all(abs(v - 0.25) < 1e-6 for v in (x0, x1, z0, z1))

        edges = [e for _, e in gmsh.model.getEntities(1) if inner(e)]
        filleted = occ.fillet([fused[0][1]], edges, [0.2])
        holes = [(3, occ.addCylinder(1.3, 0.5, -0.1, 0, 0, 0.5, 0.2)), (3, occ.addCylinder(-0.1, 0.5, 0.9, 0.5, 0, 0, 0.2))]
        occ.cut(filleted, holes)
    occ.synchronize()


def signature():
    """Each entity of the current model by its dimension, type and
    bounding box (rounded): {(dim, type, box): tag}."""
    out = {}
    for d, t in gmsh.model.getEntities():
        key = (d, gmsh.model.getType(d, t), tuple(round(v, 6) + 0.0 for v in gmsh.model.getBoundingBox(d, t)))
        assert key not in out, f"two entities alike: {key}"
        out[key] = t
    return out


def size_field(faces_or_curves, dim, size_min, size_max, dist_min, dist_max, curvature=0):
    """Threshold on the distance to the walls as the background mesh
    size, nothing taken from the boundary or the points; with curvature
    N, also N elements per 2 pi of a curve's curvature (the least wins)."""
    f = gmsh.model.mesh.field
    dist = f.add("Distance")
    f.setNumbers(dist, "SurfacesList" if dim == 2 else "CurvesList", faces_or_curves)
    if dim == 1:
        f.setNumber(dist, "Sampling", 200)
    th = f.add("Threshold")
    f.setNumber(th, "InField", dist)
    f.setNumber(th, "SizeMin", size_min)
    f.setNumber(th, "SizeMax", size_max)
    f.setNumber(th, "DistMin", dist_min)
    f.setNumber(th, "DistMax", dist_max)
    f.setAsBackgroundMesh(th)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", curvature)


def boundary_layer(curves, first, thickness):
    f = gmsh.model.mesh.field
    bl = f.add("BoundaryLayer")
    f.setNumbers(bl, "CurvesList", curves)
    f.setNumber(bl, "Size", first)
    f.setNumber(bl, "Ratio", 1.2)
    f.setNumber(bl, "Thickness", thickness)
    f.setNumber(bl, "Quads", 1)
    f.setAsBoundaryLayer(bl)


gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
build(gmsh.model.occ)
check_cad.write_quietly(step)
gmsh.clear()
gmsh.open(step)
if a.kind == "airfoil3":
    walls = [t for _, t in gmsh.model.getEntities(1) if gmsh.model.getType(1, t) == "BSpline"]
    assert len(walls) == 3, walls
    boundary_layer(walls, 1e-4, 0.01)
    size_field(walls, 1, a.size, 1.0, 0.01, 5.2, curvature=20)
    gmsh.option.setNumber("Mesh.Algorithm", 6)
    gmsh.model.mesh.generate(2)
elif a.kind == "tetball":
    sphere = [t for _, t in gmsh.model.getEntities(2) if gmsh.model.getType(2, t) == "Sphere"]
    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.49)
    size_field(sphere, 2, a.size, 0.49, 0.0, 1.5)
    gmsh.model.mesh.generate(3)
elif a.kind == "thinlayer":
    # the STEP's tags; then the model built again, meshed with its
    # extrusion, its entities given those tags
    tags = signature()
    gmsh.clear()
    build(gmsh.model.occ)
    mine = signature()
    assert set(mine) == set(tags), "the STEP read again is not the model built"
    for d, t in gmsh.model.getEntities(0):
        x, y, z = gmsh.model.getValue(0, t, [])
        if abs(z) < 1e-6:
            gmsh.model.mesh.setSize([(0, t)], a.size if math.hypot(x, y) < 1 else 0.3)
    circle = [t for _, t in gmsh.model.getEntities(1) if gmsh.model.getType(1, t) in ("Circle", "Ellipse") and abs(gmsh.model.getBoundingBox(1, t)[5]) < 1e-6]
    assert len(circle) == 1, circle
    boundary_layer(circle, 1e-5, 0.08)
    gmsh.option.setNumber("Mesh.Algorithm", 6)
    gmsh.option.setNumber("Mesh.RecombinationAlgorithm", 1)
    gmsh.option.setNumber("Mesh.RecombineAll", 1)
    gmsh.model.mesh.generate(3)
    # two steps, past every tag in use, so that no two meet on the way
    shift = 1 + max(t for _, t in gmsh.model.getEntities())
    for key, t in mine.items():
        gmsh.model.setTag(key[0], t, t + shift)
    for key, t in mine.items():
        gmsh.model.setTag(key[0], t + shift, tags[key])
else:
    gmsh.option.setNumber("Mesh.MeshSizeMax", a.size)
    gmsh.option.setNumber("Mesh.MeshSizeMin", a.size / 3)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 12)
    gmsh.model.mesh.generate(3)
gmsh.write(msh)
if a.peers:
    out = {}
    for method in a.methods.split(","):
        gmsh.clear()
        gmsh.open(step)
        gmsh.merge(msh)
        t0 = time.perf_counter()
        gmsh.model.mesh.setOrder(a.peers)
        if method != "setorder":
            gmsh.option.setNumber("Mesh.HighOrderOptimize", 4 if method == "fastcurving" else 3)
            gmsh.model.mesh.optimize("HighOrderFastCurving" if method == "fastcurving" else "HighOrderElastic")
        secs = time.perf_counter() - t0
        j = check_cad.judge()
        out[method] = {"invalid": j["invalid"], "min_sj": j["min_sj"], "min_det_jac": j["min_det_jac"], "seconds": secs}
    print(json.dumps(out))
gmsh.finalize()
