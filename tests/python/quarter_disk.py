"""A quad mesh of the quarter disk r <= 1, x, y >= 0, in three transfinite
blocks (the square [0, 0.5]^2 and two blocks from its sides to the arc), N
cells along every block edge, made by Gmsh, written to OUT (MSH 4.1). Unlike
Algorithm 1's image of the unit square, no cell has two sides on the arc.
Groups arc, axes, disk.

Usage: python quarter_disk.py N OUT.msh"""
import math, sys
import gmsh

n, out = int(sys.argv[1]), sys.argv[2]
gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
gmsh.option.setNumber("Mesh.SaveAll", 0)
gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
g = gmsh.model.geo
c = math.sqrt(0.5)
o, a, m, b = (g.addPoint(x, y, 0) for x, y in [(0, 0), (0.5, 0), (0.5, 0.5), (0, 0.5)])
p, q, r = (g.addPoint(x, y, 0) for x, y in [(1, 0), (c, c), (0, 1)])
oa, am, mb, bo = g.addLine(o, a), g.addLine(a, m), g.addLine(m, b), g.addLine(b, o)
ap, mq, br = g.addLine(a, p), g.addLine(m, q), g.addLine(b, r)
pq, qr = g.addCircleArc(p, o, q), g.addCircleArc(q, o, r)
faces = [
    g.addPlaneSurface([g.addCurveLoop([oa, am, mb, bo])]),
    g.addPlaneSurface([g.addCurveLoop([ap, pq, -mq, -am])]),
    g.addPlaneSurface([g.addCurveLoop([mq, qr, -br, -mb])]),
]
g.synchronize()
for curve in [oa, am, mb, bo, ap, mq, br, pq, qr]:
    gmsh.model.mesh.setTransfiniteCurve(curve, n + 1)
for s in faces:
    gmsh.model.mesh.setTransfiniteSurface(s)
    gmsh.model.mesh.setRecombine(2, s)
gmsh.model.addPhysicalGroup(1, [pq, qr], name="arc")
gmsh.model.addPhysicalGroup(1, [oa, ap, bo, br], name="axes")
gmsh.model.addPhysicalGroup(2, faces, name="disk")
gmsh.model.mesh.generate(2)
gmsh.write(out)
gmsh.finalize()
