"""(benches/snap_first.sh) An O-grid hex mesh of the cylinder r = 0.5, 0 <= z <= 1, made by Gmsh, with
Gmsh's setOrder(ORDER) timed on the same model after writing the linear mesh; prints a last line
`@@ {"setorder_s", "invalid", "min_minSJ"}` as extruded_setorder.py does.

The disk: a centre square of N x N quads (half-side 0.25) and four blocks of N x M quads out to the
circle; extruded along z in LAYERS layers. N = 8, M = 2, LAYERS = 16: 2,048 hexes (the thin-layer
issue's O-grid cylinder). Groups: wall (the cylinder), bottom, top, fluid.
Usage: python ogrid_setorder.py N M LAYERS OUT.msh ORDER"""
import sys
import gmsh
from ogrid import ogrid_disk, setorder_judged

n, m, layers, out, order = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3]), sys.argv[4], int(sys.argv[5])
gmsh.initialize(); gmsh.option.setNumber("General.Terminal", 0)
gmsh.option.setNumber("Mesh.SaveAll", 0); gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
g = gmsh.model.geo
c0 = g.addPoint(0, 0, 0)
surfaces, _ = ogrid_disk(g, lambda u, v: (u, v, 0), c0, 0.25, 0.5, n, m)
ex = g.extrude([(2, s) for s in surfaces], 0, 0, 1.0, numElements=[layers], recombine=True)
g.synchronize()
# extrude returns, per surface: its top, its volume, then its four sides in the order of its loop
per = [ex[i:i + 6] for i in range(0, len(ex), 6)]
top = [blk[0][1] for blk in per]
vols = [blk[1][1] for blk in per]
walls = [per[k + 1][3][1] for k in range(4)]  # the outer blocks' arc sides (loop position 1)
gmsh.model.addPhysicalGroup(2, walls, name="wall")
gmsh.model.addPhysicalGroup(2, surfaces, name="bottom")
gmsh.model.addPhysicalGroup(2, top, name="top")
gmsh.model.addPhysicalGroup(3, vols, name="fluid")
gmsh.model.mesh.generate(3)
print({int(t): len(gmsh.model.mesh.getElementsByType(t)[0]) for t in gmsh.model.mesh.getElementTypes(3)})
gmsh.write(out)
setorder_judged(gmsh, order)
gmsh.finalize()
