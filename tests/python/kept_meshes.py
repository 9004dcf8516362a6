"""Meshes whose groups, entities and periodicity a curved output must keep,
made by Gmsh as a user would (MSH 4.1), with physical tags that are not
1, 2, 3 (a writer that renumbers them is caught).

  channel OUT.msh   2D: the channel [-2,2] x [-1,1] minus the circle r = 0.5,
                    all quads; groups wall 2 (the circle), inlet 3,
                    outlet 4 (periodic: outlet = inlet + (4, 0)), sides 5,
                    fluid 6 (surface), corner 7 (a point group)
  box OUT.msh       3D: the same channel extruded over [0, 1] into hexes;
                    periodic in z (top = bottom + (0, 0, 1)) and in x;
                    groups wall 2, inlet 3, outlet 4, sides 5, top 8,
                    bottom 9, fluid 6, a curve group rim 10 (the circle at
                    z = 0) and a point group corner 7

Usage: python kept_meshes.py channel|box OUT.msh
"""
import math
import sys

import gmsh

kind, out = sys.argv[1], sys.argv[2]
gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
occ = gmsh.model.occ
L, H, r = 2.0, 1.0, 0.5
rect = occ.addRectangle(-L, -H, 0, 2 * L, 2 * H)
disk = occ.addDisk(0, 0, 0, r, r)
(surf,), _ = occ.cut([(2, rect)], [(2, disk)])
occ.synchronize()
s = surf[1]


def curves_at(pred):
    out = []
    for d, t in gmsh.model.getBoundary([(2, s)], oriented=False):
        x0, y0, _, x1, y1, _ = gmsh.model.getBoundingBox(d, t)
        if pred(x0, y0, x1, y1):
            out.append(t)
    return out


inlet = curves_at(lambda x0, y0, x1, y1: abs(x0 + L) < 1e-6 and abs(x1 + L) < 1e-6)
outlet = curves_at(lambda x0, y0, x1, y1: abs(x0 - L) < 1e-6 and abs(x1 - L) < 1e-6)
sides = curves_at(lambda x0, y0, x1, y1: abs(y0 - y1) < 1e-6 and abs(abs(y0) - H) < 1e-6)
wall = curves_at(lambda x0, y0, x1, y1: max(abs(x0), abs(x1), abs(y0), abs(y1)) <= r + 1e-6)
corner = [t for _, t in gmsh.model.getBoundary([(1, c) for c in inlet], combined=False, oriented=False)
          if abs(gmsh.model.getValue(0, t, [])[1] + H) < 1e-6][0]
shift_x = [1, 0, 0, 2 * L, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]
gmsh.option.setNumber("Mesh.MeshSizeMax", 0.3)
gmsh.option.setNumber("Mesh.MeshSizeMin", 0.3)
gmsh.model.mesh.setSize([(0, t) for _, t in gmsh.model.getBoundary([(1, c) for c in wall], combined=False)], 0.15)
gmsh.option.setNumber("Mesh.Algorithm", 8)
gmsh.option.setNumber("Mesh.RecombinationAlgorithm", 2)
gmsh.option.setNumber("Mesh.RecombineAll", 1)
if kind == "channel":
    gmsh.model.mesh.setPeriodic(1, outlet, inlet, shift_x)
    gmsh.model.addPhysicalGroup(1, wall, 2, name="wall")
    gmsh.model.addPhysicalGroup(1, inlet, 3, name="inlet")
    gmsh.model.addPhysicalGroup(1, outlet, 4, name="outlet")
    gmsh.model.addPhysicalGroup(1, sides, 5, name="sides")
    gmsh.model.addPhysicalGroup(2, [s], 6, name="fluid")
    gmsh.model.addPhysicalGroup(0, [corner], 7, name="corner")
    gmsh.model.mesh.generate(2)
else:
    ex = occ.extrude([(2, s)], 0, 0, 1.0, numElements=[3], recombine=True)
    occ.synchronize()
    top = [t for d, t in ex if d == 2 and abs(gmsh.model.getBoundingBox(d, t)[2] - 1.0) < 1e-6
           and abs(gmsh.model.getBoundingBox(d, t)[5] - 1.0) < 1e-6][0]
    vol = [t for d, t in ex if d == 3][0]

    def faces_at(pred):
        return [t for d, t in gmsh.model.getBoundary([(3, vol)], oriented=False) if pred(*gmsh.model.getBoundingBox(d, t))]

    f_in = faces_at(lambda x0, y0, z0, x1, y1, z1: abs(x0 + L) < 1e-6 and abs(x1 + L) < 1e-6)
    f_out = faces_at(lambda x0, y0, z0, x1, y1, z1: abs(x0 - L) < 1e-6 and abs(x1 - L) < 1e-6)
    f_sides = faces_at(lambda x0, y0, z0, x1, y1, z1: abs(y0 - y1) < 1e-6 and abs(abs(y0) - H) < 1e-6)
    f_wall = faces_at(lambda x0, y0, z0, x1, y1, z1: max(abs(x0), abs(x1), abs(y0), abs(y1)) <= r + 1e-6)
    gmsh.model.mesh.setPeriodic(2, [top], [s], [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 1, 0, 0, 0, 1])
    gmsh.model.mesh.setPeriodic(2, f_out, f_in, shift_x)
    gmsh.model.addPhysicalGroup(2, f_wall, 2, name="wall")
    gmsh.model.addPhysicalGroup(2, f_in, 3, name="inlet")
    gmsh.model.addPhysicalGroup(2, f_out, 4, name="outlet")
    gmsh.model.addPhysicalGroup(2, f_sides, 5, name="sides")
    gmsh.model.addPhysicalGroup(2, [top], 8, name="top")
    gmsh.model.addPhysicalGroup(2, [s], 9, name="bottom")
    gmsh.model.addPhysicalGroup(3, [vol], 6, name="fluid")
    gmsh.model.addPhysicalGroup(1, wall, 10, name="rim")
    gmsh.model.addPhysicalGroup(0, [corner], 7, name="corner")
    gmsh.model.mesh.generate(3)
types = {t for dim in (2, 3) for t in gmsh.model.mesh.getElements(dim)[0]}
assert types <= {3, 5}, f"not all quads/hexes: element types {types}"
gmsh.write(out)
gmsh.finalize()
