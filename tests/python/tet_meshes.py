"""Tetrahedral meshes made by Gmsh (MSH 4.1, linear), for the tests and the
benchmarks of tetrahedron curving:

  ballbox  the box [-1.5, 1.5]^3 minus the ball r = 0.5, size SIZE on the
           sphere and FAR at the box's corners; groups sphere, box, fluid
           (the issue's mesh: SIZE 0.12, FAR 0.6: about 6,400 tetrahedra)
  ball     the ball r = 1 of size SIZE; groups sphere, fluid

With --order P, also Gmsh's own curving of the same mesh on the same CAD
(--method setorder, fastcurving or elastic), judged as `deformesh curve`
judges its result: prints JSON {"method", "order", "elements", "invalid"
(minDetJac <= 0), "min_sj", "boundary_sample_distance" (the largest
distance of the sphere's triangles, sampled on a lattice of 17 points per
edge, to the sphere), "seconds"}.

Usage: python tet_meshes.py KIND OUT.msh [--size S] [--far F] [--order P] [--method M]"""
import argparse
import gmsh

ap = argparse.ArgumentParser()
ap.add_argument("kind", choices=["ballbox", "ball"])
ap.add_argument("out")
ap.add_argument("--size", type=float, default=0.12)
ap.add_argument("--far", type=float, default=0.6)
ap.add_argument("--order", type=int)
ap.add_argument("--method", choices=["setorder", "fastcurving", "elastic"], default="setorder")
a = ap.parse_args()
gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
occ = gmsh.model.occ
r = 0.5 if a.kind == "ballbox" else 1.0
ball = occ.addSphere(0, 0, 0, r)
if a.kind == "ballbox":
    box = occ.addBox(-1.5, -1.5, -1.5, 3, 3, 3)
    vol = occ.cut([(3, box)], [(3, ball)])[0][0][1]
else:
    vol = ball
occ.synchronize()
faces = [t for d, t in gmsh.model.getBoundary([(3, vol)], oriented=False)]
sphere = [f for f in faces if gmsh.model.getType(2, f) == "Sphere"]
others = [f for f in faces if f not in sphere]
gmsh.model.addPhysicalGroup(2, sphere, name="sphere")
if others:
    gmsh.model.addPhysicalGroup(2, others, name="box")
gmsh.model.addPhysicalGroup(3, [vol], name="fluid")
gmsh.option.setNumber("Mesh.MeshSizeMax", a.far)
gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
f = gmsh.model.mesh.field
dist = f.add("Distance")
f.setNumbers(dist, "SurfacesList", sphere)
th = f.add("Threshold")
f.setNumber(th, "InField", dist)
f.setNumber(th, "SizeMin", a.size)
f.setNumber(th, "SizeMax", a.far)
f.setNumber(th, "DistMin", 0.0)
f.setNumber(th, "DistMax", 1.5)
f.setAsBackgroundMesh(th)
gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
gmsh.model.mesh.generate(3)
gmsh.write(a.out)
if a.order:
    import numpy as np
    from gmsh_curving import curve_and_judge_simplices

    curve_and_judge_simplices(a.order, a.method, 3, sphere, lambda pts: np.abs(np.linalg.norm(pts, axis=2) - r))
gmsh.finalize()
