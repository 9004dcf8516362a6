"""A 2D quad boundary-layer mesh around the circle r = 0.5 in [-2, 2]^2 (first
cell FIRST, growth 1.2, thickness 0.08; groups wall, farfield, fluid), written
to OUT (MSH 4.1). With ORDER, also Gmsh's own setOrder(ORDER) of the same mesh
on the same CAD, judged like `deformesh curve` judges its result: prints JSON
{"elements", "invalid" (minDetJac <= 0), "boundary_sample_distance" (the
largest distance |r - 0.5| of 17 points a wall edge, as `samples = 16`)}.

Usage: python bl2d.py FIRST WALL_SIZE OUT.msh [ORDER]"""
import json, math, sys
import gmsh

first, wall_size, out = float(sys.argv[1]), float(sys.argv[2]), sys.argv[3]
order = int(sys.argv[4]) if len(sys.argv) > 4 else None
gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
gmsh.option.setNumber("Mesh.SaveAll", 0)
gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
g = gmsh.model.geo
L, r = 2.0, 0.5
c0 = g.addPoint(0, 0, 0)
sq = [g.addPoint(x, y, 0, 0.3) for x, y in [(-L, -L), (L, -L), (L, L), (-L, L)]]
ci = [g.addPoint(r * math.cos(k * math.pi / 2), r * math.sin(k * math.pi / 2), 0, wall_size) for k in range(4)]
sides = [g.addLine(sq[k], sq[(k + 1) % 4]) for k in range(4)]
arcs = [g.addCircleArc(ci[k], c0, ci[(k + 1) % 4]) for k in range(4)]
s = g.addPlaneSurface([g.addCurveLoop(sides), g.addCurveLoop(arcs)])
g.synchronize()
f = gmsh.model.mesh.field
bl = f.add("BoundaryLayer")
f.setNumbers(bl, "CurvesList", arcs)
f.setNumber(bl, "Size", first)
f.setNumber(bl, "Ratio", 1.2)
f.setNumber(bl, "Thickness", 0.08)
f.setNumber(bl, "Quads", 1)
f.setAsBoundaryLayer(bl)
gmsh.model.addPhysicalGroup(1, arcs, name="wall")
gmsh.model.addPhysicalGroup(1, sides, name="farfield")
gmsh.model.addPhysicalGroup(2, [s], name="fluid")
gmsh.option.setNumber("Mesh.Algorithm", 6)
gmsh.option.setNumber("Mesh.RecombinationAlgorithm", 1)
gmsh.option.setNumber("Mesh.RecombineAll", 1)
gmsh.model.mesh.generate(2)
gmsh.write(out)
if order:
    gmsh.model.mesh.setOrder(order)
    _, tags, _ = gmsh.model.mesh.getElements(2)
    tags = [t for ts in tags for t in ts]
    dj = gmsh.model.mesh.getElementQualities(tags, "minDetJac")
    ref = [-1 + 2 * k / order for k in range(order + 1)]
    perm = [0] + list(range(2, order + 1)) + [1]  # Gmsh's line: ends, then interior
    worst = 0.0
    for arc in arcs:
        _, _, nodes = gmsh.model.mesh.getElements(1, arc)
        nodes = list(nodes[0])
        for e in range(len(nodes) // (order + 1)):
            row = nodes[e * (order + 1):(e + 1) * (order + 1)]
            xs = [gmsh.model.mesh.getNode(int(row[i]))[0][:2] for i in perm]
            for k in range(17):
                u = -1 + 2 * k / 16
                w = [math.prod((u - ref[j]) / (ref[i] - ref[j]) for j in range(order + 1) if j != i) for i in range(order + 1)]
                x = [sum(w[i] * xs[i][d] for i in range(order + 1)) for d in range(2)]
                worst = max(worst, abs(math.hypot(*x) - r))
    print(json.dumps({"elements": len(tags), "invalid": sum(1 for v in dj if v <= 0), "boundary_sample_distance": worst}))
gmsh.finalize()
