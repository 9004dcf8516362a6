"""A quad boundary-layer mesh around the circle r = 0.5 in [-2, 2]^2 (first
cell FIRST, growth 1.2, thickness 0.08), made by Gmsh, written to OUT (MSH
4.1). Groups wall, farfield, fluid; with --extrude, extruded along z over
[0, 1] in two layers (0.4, 0.6) into hexes, groups wall, farfield, bottom,
top, fluid.

With --order P (2D only), also Gmsh's own setOrder(P) of the same mesh on
the same CAD, judged like `deformesh curve` judges its result: prints JSON
{"elements", "invalid" (minDetJac <= 0), "boundary_sample_distance" (the
largest distance |r - 0.5| of 17 points a wall edge, as `samples = 16`)}.

Usage: python cylinder_bl.py FIRST WALL_SIZE OUT.msh [--far SIZE] [--extrude] [--order P]"""
import argparse, json, math
import gmsh

ap = argparse.ArgumentParser()
ap.add_argument("first", type=float)
ap.add_argument("wall_size", type=float)
ap.add_argument("out")
ap.add_argument("--far", type=float, default=0.3, help="mesh size at the square's corners")
ap.add_argument("--extrude", action="store_true")
ap.add_argument("--order", type=int)
ap.add_argument("--method", choices=["setorder", "fastcurving", "elastic"], default="setorder")
a = ap.parse_args()
gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
gmsh.option.setNumber("Mesh.SaveAll", 0)
gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
g = gmsh.model.geo
L, r = 2.0, 0.5
c0 = g.addPoint(0, 0, 0)
sq = [g.addPoint(x, y, 0, a.far) for x, y in [(-L, -L), (L, -L), (L, L), (-L, L)]]
ci = [g.addPoint(r * math.cos(k * math.pi / 2), r * math.sin(k * math.pi / 2), 0, a.wall_size) for k in range(4)]
sides = [g.addLine(sq[k], sq[(k + 1) % 4]) for k in range(4)]
arcs = [g.addCircleArc(ci[k], c0, ci[(k + 1) % 4]) for k in range(4)]
s = g.addPlaneSurface([g.addCurveLoop(sides), g.addCurveLoop(arcs)])
g.synchronize()
f = gmsh.model.mesh.field
bl = f.add("BoundaryLayer")
f.setNumbers(bl, "CurvesList", arcs)
f.setNumber(bl, "Size", a.first)
f.setNumber(bl, "Ratio", 1.2)
f.setNumber(bl, "Thickness", 0.08)
f.setNumber(bl, "Quads", 1)
f.setAsBoundaryLayer(bl)
if a.extrude:
    g.mesh.setRecombine(2, s)
    ex = g.extrude([(2, s)], 0, 0, 1.0, numElements=[1, 1], heights=[0.4, 1.0], recombine=True)
    g.synchronize()
    top, vol, lat = ex[0][1], ex[1][1], [t for d, t in ex[2:]]
    gmsh.model.addPhysicalGroup(2, lat[4:8], name="wall")
    gmsh.model.addPhysicalGroup(2, lat[0:4], name="farfield")
    gmsh.model.addPhysicalGroup(2, [s], name="bottom")
    gmsh.model.addPhysicalGroup(2, [top], name="top")
    gmsh.model.addPhysicalGroup(3, [vol], name="fluid")
else:
    gmsh.model.addPhysicalGroup(1, arcs, name="wall")
    gmsh.model.addPhysicalGroup(1, sides, name="farfield")
    gmsh.model.addPhysicalGroup(2, [s], name="fluid")
gmsh.option.setNumber("Mesh.Algorithm", 6)
gmsh.option.setNumber("Mesh.RecombinationAlgorithm", 1)
gmsh.option.setNumber("Mesh.RecombineAll", 1)
gmsh.model.mesh.generate(3 if a.extrude else 2)
gmsh.write(a.out)
if a.order and a.extrude:
    from gmsh_curving import curve_and_judge

    curve_and_judge(a.order, a.method, lat[4:8], lambda pts: abs((pts[..., 0] ** 2 + pts[..., 1] ** 2) ** 0.5 - r))
if a.order and not a.extrude:
    p = a.order
    gmsh.model.mesh.setOrder(p)
    _, tags, _ = gmsh.model.mesh.getElements(2)
    tags = [t for ts in tags for t in ts]
    dj = gmsh.model.mesh.getElementQualities(tags, "minDetJac")
    ref = [-1 + 2 * k / p for k in range(p + 1)]
    perm = [0] + list(range(2, p + 1)) + [1]  # Gmsh's line: ends, then interior
    worst = 0.0
    for arc in arcs:
        _, _, nodes = gmsh.model.mesh.getElements(1, arc)
        nodes = list(nodes[0])
        for e in range(len(nodes) // (p + 1)):
            row = nodes[e * (p + 1):(e + 1) * (p + 1)]
            xs = [gmsh.model.mesh.getNode(int(row[i]))[0][:2] for i in perm]
            for k in range(17):
                u = -1 + 2 * k / 16
                w = [math.prod((u - ref[j]) / (ref[i] - ref[j]) for j in range(p + 1) if j != i) for i in range(p + 1)]
                x = [sum(w[i] * xs[i][d] for i in range(p + 1)) for d in range(2)]
                worst = max(worst, abs(math.hypot(*x) - r))
    print(json.dumps({"elements": len(tags), "invalid": sum(1 for v in dj if v <= 0), "boundary_sample_distance": worst}))
gmsh.finalize()
