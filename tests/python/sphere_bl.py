"""A hex boundary-layer O-grid around the sphere |x| = 0.5 inside the box
[-B, B]^3 (B = 1 unless --box B), made by Gmsh (geo kernel, all transfinite), written to OUT (MSH
4.1, linear hexes). The 8 points (0.5/sqrt 3)(+-1, +-1, +-1), joined by
great-circle arcs, give 6 spherical patches of N x N cells; 8 radial lines
join them to the box corners, graded geometrically (ratio about G) so that the
thinnest first cell at the sphere is FIRST. Groups sphere, box, fluid. Prints
JSON {"hexes", "first" (measured smallest node height above the sphere),
"first_line" (the first cell on the radial lines, where it is largest)}.

With --order P, also curves the same mesh on the same CAD with Gmsh: setOrder
(P), then for --method fastcurving / elastic the optimiser HighOrderFastCurving
/ HighOrderElastic (Mesh.HighOrderOptimize 4 / 3), timed; judged like
`deformesh curve` judges its result: prints JSON {"method", "order",
"elements", "invalid" (minDetJac <= 0), "min_sj", "boundary_sample_distance"
(largest ||x| - 0.5| of 17 x 17 points per sphere face), "seconds"}, or
{"method", "error"} when Gmsh throws.

Usage: python sphere_bl.py FIRST N OUT.msh [--growth G] [--box B] [--order P --method {setorder,fastcurving,elastic}]"""
import argparse, json, math
import numpy as np
import gmsh
from gmsh_curving import curve_and_judge

ap = argparse.ArgumentParser()
ap.add_argument("first", type=float)
ap.add_argument("n", type=int)
ap.add_argument("out")
ap.add_argument("--growth", type=float, default=1.3)
ap.add_argument("--box", type=float, default=1.0)
ap.add_argument("--order", type=int)
ap.add_argument("--method", choices=["setorder", "fastcurving", "elastic"], default="setorder")
a = ap.parse_args()
R, L = 0.5, a.box * math.sqrt(3) - 0.5  # sphere radius, radial line length


def build(h):
    """The O-grid whose radial lines start with a cell h; returns (sphere surfaces, fluid group)."""
    gmsh.model.add("sphere_bl")
    g = gmsh.model.geo
    o = g.addPoint(0, 0, 0)
    sg = [((k >> 2 & 1) * 2 - 1, (k >> 1 & 1) * 2 - 1, (k & 1) * 2 - 1) for k in range(8)]
    sp = [g.addPoint(*(R / math.sqrt(3) * c for c in s)) for s in sg]
    bp = [g.addPoint(*(a.box * c for c in s)) for s in sg]
    # radial cells n and ratio q with a first cell h: L (q - 1) / (q^n - 1) = h
    n = max(1, round(math.log(1 + L * (a.growth - 1) / h) / math.log(a.growth)))
    lo, hi = 1.0 + 1e-12, 10.0
    for _ in range(200):
        q = (lo + hi) / 2
        lo, hi = (q, hi) if L * (q - 1) / (q ** n - 1) > h else (lo, q)
    rad = [g.addLine(sp[k], bp[k]) for k in range(8)]  # sphere -> box: q > 0 puts the small cell at the sphere
    for c in rad:
        g.mesh.setTransfiniteCurve(c, n + 1, "Progression", q)
    arc, edge = {}, {}
    for i in range(8):
        for bit in (4, 2, 1):
            if not i & bit:
                arc[i, i | bit] = g.addCircleArc(sp[i], o, sp[i | bit])
                edge[i, i | bit] = g.addLine(bp[i], bp[i | bit])
    for c in list(arc.values()) + list(edge.values()):
        g.mesh.setTransfiniteCurve(c, a.n + 1)
    cur = lambda d, i, j: d[i, j] if i < j else -d[j, i]
    conn = {e: g.addSurfaceFilling([g.addCurveLoop([arc[e], rad[e[1]], -edge[e], -rad[e[0]]])]) for e in arc}
    sph, box, vols = [], [], []
    for f in (4, 2, 1):
        p, r = [b for b in (4, 2, 1) if b != f]
        for v in (0, f):
            cyc = [v, v | p, v | p | r, v | r]
            ring = list(zip(cyc, cyc[1:] + cyc[:1]))
            sph.append(g.addSurfaceFilling([g.addCurveLoop([cur(arc, i, j) for i, j in ring])], sphereCenterTag=o))
            box.append(g.addSurfaceFilling([g.addCurveLoop([cur(edge, i, j) for i, j in ring])]))
            side = [conn[min(i, j), max(i, j)] for i, j in ring]
            vols.append(g.addVolume([g.addSurfaceLoop([sph[-1], box[-1]] + side)]))
    for s in sph + box + list(conn.values()):
        g.mesh.setTransfiniteSurface(s)
        g.mesh.setRecombine(2, s)
    for v in vols:
        g.mesh.setTransfiniteVolume(v)
    g.synchronize()
    gmsh.model.addPhysicalGroup(2, sph, name="sphere")
    gmsh.model.addPhysicalGroup(2, box, name="box")
    fluid = gmsh.model.addPhysicalGroup(3, vols, name="fluid")
    gmsh.model.mesh.generate(3)
    return sph, fluid


def heights():
    """(max ||x| - R| over the sphere's nodes, smallest height |x| - R of the other nodes)."""
    on = {int(t) for s in sph for t in gmsh.model.mesh.getNodes(2, s, includeBoundary=True)[0]}
    tags, xyz = gmsh.model.mesh.getNodesForPhysicalGroup(3, fluid)
    d = np.linalg.norm(np.reshape(xyz, (-1, 3)), axis=1) - R
    m = np.isin(tags, list(on))
    return float(np.abs(d[m]).max()), float(d[~m].min())


gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
gmsh.option.setNumber("Mesh.SaveAll", 0)
gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
h = a.first
for _ in range(4):  # the transfinite volumes thin the first layer away from the radial lines
    sph, fluid = build(h)
    on_sphere, first = heights()
    if abs(first / a.first - 1) < 0.005:
        break
    h *= a.first / first
    gmsh.model.remove()
assert on_sphere < 1e-12 and abs(first / a.first - 1) < 0.02, (on_sphere, first)
gmsh.write(a.out)
hexes = sum(len(t) for t in gmsh.model.mesh.getElements(3)[1])
print(json.dumps({"hexes": hexes, "first": first, "first_line": h}))
if a.order:
    curve_and_judge(a.order, a.method, sph, lambda pts: np.abs(np.linalg.norm(pts, axis=2) - R))
gmsh.finalize()
