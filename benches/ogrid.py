"""Shared by the bench scripts that build O-grid meshes or time Gmsh's setOrder
(benches/level_sets_meshes.py, ogrid_setorder.py, extruded_setorder.py)."""
import json
import math
import time


def ogrid_disk(g, point, centre_point, half, r, centre, ring):
    """An O-grid disk of radius r in Gmsh's built-in kernel `g`: a square of
    half-width `half` (centre x centre quads) and four blocks out to the circle
    (centre x ring quads), all transfinite and recombined. `point(u, v)` gives
    the 3D point of in-plane coordinates (u, v) about the centre
    `centre_point` (a point tag). Returns the faces (the square first) and the
    arcs; each block's curve loop has its arc at position 1."""
    corner = [math.pi / 4 + k * math.pi / 2 for k in range(4)]
    sq = [g.addPoint(*point(half * math.cos(t), half * math.sin(t))) for t in corner]
    ci = [g.addPoint(*point(r * math.cos(t), r * math.sin(t))) for t in corner]
    sides = [g.addLine(sq[k], sq[(k + 1) % 4]) for k in range(4)]
    arcs = [g.addCircleArc(ci[k], centre_point, ci[(k + 1) % 4]) for k in range(4)]
    spokes = [g.addLine(sq[k], ci[k]) for k in range(4)]
    faces = [g.addPlaneSurface([g.addCurveLoop(sides)])]
    for k in range(4):
        faces.append(g.addPlaneSurface([g.addCurveLoop([spokes[k], arcs[k], -spokes[(k + 1) % 4], -sides[k]])]))
    for l in sides + arcs:
        g.mesh.setTransfiniteCurve(l, centre + 1)
    for l in spokes:
        g.mesh.setTransfiniteCurve(l, ring + 1)
    for s in faces:
        g.mesh.setTransfiniteSurface(s)
        g.mesh.setRecombine(2, s)
    return faces, arcs


def setorder_judged(gmsh, order):
    """Times Gmsh's setOrder(order) on the current model and prints the last line
    `@@ {"setorder_s", "invalid" (minDetJac <= 0), "min_minSJ"}`."""
    import numpy as np

    t0 = time.perf_counter()
    gmsh.model.mesh.setOrder(order)
    t = time.perf_counter() - t0
    tags = []
    for ty in gmsh.model.mesh.getElementTypes(3):
        tags += list(gmsh.model.mesh.getElementsByType(ty)[0])
    dj = np.array(gmsh.model.mesh.getElementQualities(tags, "minDetJac"))
    sj = np.array(gmsh.model.mesh.getElementQualities(tags, "minSJ"))
    print("@@", json.dumps({"setorder_s": t, "invalid": int((dj <= 0).sum()), "min_minSJ": float(sj.min())}))
