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

  --simplices       triangles (channel) or tetrahedra (box) instead: the
                    box is then not symmetric across its period in z

Usage: python kept_meshes.py channel|box OUT.msh [--simplices]
"""
import math
import sys

import gmsh

kind, out = sys.argv[1], sys.argv[2]
simplices = "--simplices" in sys.argv[3:]
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


def sides_of(dim_tag):
    """The boundary entities of `dim_tag` on each side of the channel,
    judged by their bounding boxes in x and y (the ends z = 0, 1 of the
    box are on none)."""
    near = lambda a, b: abs(a - b) < 1e-6  # OCC pads boxes by 1e-7
    out = {"inlet": [], "outlet": [], "sides": [], "wall": []}
    for d, t in gmsh.model.getBoundary([dim_tag], oriented=False):
        x0, y0, _, x1, y1, _ = gmsh.model.getBoundingBox(d, t)
        if near(x0, -L) and near(x1, -L):
            out["inlet"].append(t)
        elif near(x0, L) and near(x1, L):
            out["outlet"].append(t)
        elif near(y0, y1) and near(abs(y0), H):
            out["sides"].append(t)
        elif max(abs(x0), abs(x1), abs(y0), abs(y1)) <= r + 1e-6:
            out["wall"].append(t)
    return out


curves = sides_of((2, s))
inlet, outlet, sides, wall = curves["inlet"], curves["outlet"], curves["sides"], curves["wall"]
corner = [t for _, t in gmsh.model.getBoundary([(1, c) for c in inlet], combined=False, oriented=False)
          if abs(gmsh.model.getValue(0, t, [])[1] + H) < 1e-6][0]
shift_x = [1, 0, 0, 2 * L, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]
gmsh.option.setNumber("Mesh.MeshSizeMax", 0.3)
gmsh.option.setNumber("Mesh.MeshSizeMin", 0.3)
gmsh.model.mesh.setSize([(0, t) for _, t in gmsh.model.getBoundary([(1, c) for c in wall], combined=False)], 0.15)
gmsh.option.setNumber("Mesh.Algorithm", 8)
gmsh.option.setNumber("Mesh.RecombinationAlgorithm", 2)
gmsh.option.setNumber("Mesh.RecombineAll", 0 if simplices else 1)
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
    # tetrahedra: no layers, Gmsh meshes the volume freely
    ex = occ.extrude([(2, s)], 0, 0, 1.0) if simplices else occ.extrude([(2, s)], 0, 0, 1.0, numElements=[3], recombine=True)
    occ.synchronize()
    top = [t for d, t in ex if d == 2 and abs(gmsh.model.getBoundingBox(d, t)[2] - 1.0) < 1e-6
           and abs(gmsh.model.getBoundingBox(d, t)[5] - 1.0) < 1e-6][0]
    vol = [t for d, t in ex if d == 3][0]

    faces = sides_of((3, vol))
    f_in, f_out, f_sides, f_wall = faces["inlet"], faces["outlet"], faces["sides"], faces["wall"]
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
want = {2, 4} if simplices else {3, 5}
assert types <= want, f"not all of element types {want}: {types}"
gmsh.write(out)
gmsh.finalize()
