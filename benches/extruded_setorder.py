"""(benches/snap_first.sh) ../shared/data/make_extruded_bl.py with Gmsh's setOrder(ORDER) timed on the
same model after writing the linear mesh; prints a last line `@@ {"setorder_s", "invalid", "min_minSJ"}`.
Usage: python extruded_setorder.py FIRST WALL_SIZE OUT.msh ORDER   (1e-5 0.04: 15,924 hexes; 1e-3 0.04: 7,952)

A small hex boundary-layer mesh that shows the 3D thin-layer problem: a quad annulus in the square [-2,2]^2
with a boundary layer on the circle r = 0.5 (first cell FIRST, growth 1.2, thickness 0.08), extruded along z
over [0, 1] in 4 layers. Groups: wall, farfield, bottom, top, fluid.
Usage: python make_extruded_bl.py FIRST WALL_SIZE OUT.msh   (e.g. 1e-5 0.3 small.msh: about 3.6k hexes)"""
import math, sys, gmsh

first, wall_size, out = float(sys.argv[1]), float(sys.argv[2]), sys.argv[3]
gmsh.initialize(); gmsh.option.setNumber("General.Terminal", 0)
gmsh.option.setNumber("Mesh.SaveAll", 0); gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
g = gmsh.model.geo
L, r = 2.0, 0.5
c0 = g.addPoint(0, 0, 0)
sq = [g.addPoint(x, y, 0, 0.3) for x, y in [(-L, -L), (L, -L), (L, L), (-L, L)]]
ci = [g.addPoint(r * math.cos(k * math.pi / 2), r * math.sin(k * math.pi / 2), 0, wall_size) for k in range(4)]
sl = [g.addLine(sq[k], sq[(k + 1) % 4]) for k in range(4)]
arcs = [g.addCircleArc(ci[k], c0, ci[(k + 1) % 4]) for k in range(4)]
s = g.addPlaneSurface([g.addCurveLoop(sl), g.addCurveLoop(arcs)])
g.synchronize()
f = gmsh.model.mesh.field
bl = f.add("BoundaryLayer")
f.setNumbers(bl, "CurvesList", arcs); f.setNumber(bl, "Size", first); f.setNumber(bl, "Ratio", 1.2)
f.setNumber(bl, "Thickness", 0.08); f.setNumber(bl, "Quads", 1); f.setAsBoundaryLayer(bl)
g.mesh.setRecombine(2, s)
h = [1, 2, 4, 8]; cum = [sum(h[:k + 1]) / sum(h) for k in range(4)]
ex = g.extrude([(2, s)], 0, 0, 1.0, numElements=[1, 1, 1, 1], heights=cum, recombine=True)
g.synchronize()
top, vol, lat = ex[0][1], ex[1][1], [t for d, t in ex[2:]]
gmsh.model.addPhysicalGroup(2, lat[4:8], name="wall")
gmsh.model.addPhysicalGroup(2, lat[0:4], name="farfield")
gmsh.model.addPhysicalGroup(2, [s], name="bottom")
gmsh.model.addPhysicalGroup(2, [top], name="top")
gmsh.model.addPhysicalGroup(3, [vol], name="fluid")
gmsh.option.setNumber("Mesh.Algorithm", 6); gmsh.option.setNumber("Mesh.RecombinationAlgorithm", 1)
gmsh.option.setNumber("Mesh.RecombineAll", 1)
gmsh.model.mesh.generate(3)
print({int(t): len(gmsh.model.mesh.getElementsByType(t)[0]) for t in gmsh.model.mesh.getElementTypes(3)})
gmsh.write(out)
from ogrid import setorder_judged
setorder_judged(gmsh, int(sys.argv[4]))
gmsh.finalize()
