"""Triangle meshes made by Gmsh (MSH 4.1, linear), for the tests and the
benchmarks of triangle curving:

  layer  the square [-2, 2]^2 minus the circle r = 0.5, a triangle boundary
         layer on the circle (Gmsh's BoundaryLayer field: first height
         FIRST, ratio 1.3, thickness 0.06), size SIZE on the circle and
         FAR at the square's corners; groups wall, farfield, fluid
         (the issue's mesh: FIRST 1e-4, SIZE 0.05, FAR 0.3: 3,834 triangles
         with Gmsh 4.15.2)
  mixed  the layer mesh with the field's Quads = 1: quadrangles in the
         layer (19 of them across it), triangles outside; same groups
         (defaults, Gmsh 4.15.2: 1,216 quads + 1,402 triangles; the issue's
         1,007 + 1,467 is not reachable, the four arcs having as many edges
         each: SIZE 0.0625, FAR 0.25 gives the nearest, 988 + 1,428)
  disk   the disk r = 1 of triangles of size SIZE; groups wall, fluid

With --order P, also Gmsh's own curving of the same mesh on the same CAD
(--method setorder, fastcurving or elastic), judged as `deformesh curve`
judges its result: prints JSON {"method", "order", "elements", "invalid"
(minDetJac <= 0), "min_sj", "boundary_sample_distance" (the largest
distance of 17 points per wall edge to the circle), "seconds",
"elements_by_type", "invalid_by_type"}, over all the 2D elements (both
kinds of the mixed mesh). With --counts, first prints the linear mesh's
2D elements per type as JSON, e.g. {"Quadrilateral 4": 1216,
"Triangle 3": 1402}. With --curved FILE (and --order), also writes Gmsh's
curved mesh to FILE (MSH 4.1, ASCII).

Usage: python triangle_meshes.py KIND OUT.msh [--first H] [--size S] [--far F]
       [--order P] [--method M] [--counts] [--curved FILE]"""
import argparse, math
import gmsh

ap = argparse.ArgumentParser()
ap.add_argument("kind", choices=["layer", "mixed", "disk"])
ap.add_argument("out")
ap.add_argument("--first", type=float, default=1e-4)
ap.add_argument("--size", type=float, default=0.05)
ap.add_argument("--far", type=float, default=0.3)
ap.add_argument("--order", type=int)
ap.add_argument("--method", choices=["setorder", "fastcurving", "elastic"], default="setorder")
ap.add_argument("--counts", action="store_true")
ap.add_argument("--curved")
a = ap.parse_args()
gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
g = gmsh.model.geo
c0 = g.addPoint(0, 0, 0)
r = 1.0 if a.kind == "disk" else 0.5
ci = [g.addPoint(r * math.cos(k * math.pi / 2), r * math.sin(k * math.pi / 2), 0, a.size) for k in range(4)]
arcs = [g.addCircleArc(ci[k], c0, ci[(k + 1) % 4]) for k in range(4)]
if a.kind != "disk":
    L = 2.0
    sq = [g.addPoint(x, y, 0, a.far) for x, y in [(-L, -L), (L, -L), (L, L), (-L, L)]]
    sides = [g.addLine(sq[k], sq[(k + 1) % 4]) for k in range(4)]
    s = g.addPlaneSurface([g.addCurveLoop(sides), g.addCurveLoop(arcs)])
    g.synchronize()
    f = gmsh.model.mesh.field
    bl = f.add("BoundaryLayer")
    f.setNumbers(bl, "CurvesList", arcs)
    f.setNumber(bl, "Size", a.first)
    f.setNumber(bl, "Ratio", 1.3)
    f.setNumber(bl, "Thickness", 0.06)
    if a.kind == "mixed":
        f.setNumber(bl, "Quads", 1)
    f.setAsBoundaryLayer(bl)
    gmsh.model.addPhysicalGroup(1, arcs, name="wall")
    gmsh.model.addPhysicalGroup(1, sides, name="farfield")
else:
    s = g.addPlaneSurface([g.addCurveLoop(arcs)])
    g.synchronize()
    gmsh.model.addPhysicalGroup(1, arcs, name="wall")
gmsh.model.addPhysicalGroup(2, [s], name="fluid")
gmsh.model.mesh.generate(2)
gmsh.write(a.out)
if a.counts:
    import json

    by_type = {gmsh.model.mesh.getElementProperties(t)[0]: len(gmsh.model.mesh.getElementsByType(t)[0]) for t in gmsh.model.mesh.getElementTypes(2)}
    print(json.dumps(dict(sorted(by_type.items()))))
if a.order:
    import numpy as np
    from gmsh_curving import curve_and_judge_simplices

    curve_and_judge_simplices(a.order, a.method, 2, arcs, lambda pts: np.abs(np.hypot(pts[..., 0], pts[..., 1]) - r))
    if a.curved:
        gmsh.write(a.curved)
gmsh.finalize()
