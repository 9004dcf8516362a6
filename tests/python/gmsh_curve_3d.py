"""Gmsh's own curving of the extruded cylinder boundary-layer hex mesh: builds
exactly the mesh of `cylinder_bl.py FIRST WALL_SIZE OUT --far SIZE --extrude`
(same geometry code), writes it to OUT (MSH 4.1), then with --order P curves it
on the same CAD: setOrder(P), then for --method fastcurving / elastic the
optimiser HighOrderFastCurving / HighOrderElastic (Mesh.HighOrderOptimize 4 /
3), timed, and judged like `deformesh curve` judges its result: prints JSON
{"method", "order", "elements", "invalid" (minDetJac <= 0), "min_sj",
"boundary_sample_distance" (largest |hypot(x, y) - 0.5| of 17 x 17 points per
wall face), "seconds"}, or {"method", "error"} when Gmsh throws.

Usage: python gmsh_curve_3d.py FIRST WALL_SIZE OUT.msh [--far SIZE] [--order P --method {setorder,fastcurving,elastic}]"""
import argparse, json, math, time
import gmsh

ap = argparse.ArgumentParser()
ap.add_argument("first", type=float)
ap.add_argument("wall_size", type=float)
ap.add_argument("out")
ap.add_argument("--far", type=float, default=0.3, help="mesh size at the square's corners")
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
g.mesh.setRecombine(2, s)
ex = g.extrude([(2, s)], 0, 0, 1.0, numElements=[1, 1], heights=[0.4, 1.0], recombine=True)
g.synchronize()
top, vol, lat = ex[0][1], ex[1][1], [t for d, t in ex[2:]]
gmsh.model.addPhysicalGroup(2, lat[4:8], name="wall")
gmsh.model.addPhysicalGroup(2, lat[0:4], name="farfield")
gmsh.model.addPhysicalGroup(2, [s], name="bottom")
gmsh.model.addPhysicalGroup(2, [top], name="top")
gmsh.model.addPhysicalGroup(3, [vol], name="fluid")
gmsh.option.setNumber("Mesh.Algorithm", 6)
gmsh.option.setNumber("Mesh.RecombinationAlgorithm", 1)
gmsh.option.setNumber("Mesh.RecombineAll", 1)
gmsh.model.mesh.generate(3)
gmsh.write(a.out)
if a.order:
    import numpy as np  # only now: imported earlier, it changes Gmsh's mesh (pointer-ordered sets)
    p = a.order
    try:
        t0 = time.perf_counter()
        gmsh.model.mesh.setOrder(p)
        if a.method != "setorder":
            gmsh.option.setNumber("Mesh.HighOrderOptimize", 4 if a.method == "fastcurving" else 3)
            gmsh.model.mesh.optimize("HighOrderFastCurving" if a.method == "fastcurving" else "HighOrderElastic")
        secs = time.perf_counter() - t0
    except Exception as e:
        print(json.dumps({"method": a.method, "error": str(e)}))
        raise SystemExit(1)
    tags = np.concatenate(gmsh.model.mesh.getElements(3)[1])
    dj = np.array(gmsh.model.mesh.getElementQualities(tags, "minDetJac"))
    sj = np.array(gmsh.model.mesh.getElementQualities(tags, "minSJ"))
    qt = gmsh.model.mesh.getElementType("Quadrangle", p)
    uv = [c for i in range(17) for j in range(17) for c in (-1 + i / 8, -1 + j / 8, 0)]
    bf = np.reshape(gmsh.model.mesh.getBasisFunctions(qt, uv, "Lagrange")[1], (289, -1))
    nt, xyz, _ = gmsh.model.mesh.getNodes()
    x = np.zeros((int(nt.max()) + 1, 3))
    x[nt] = np.reshape(xyz, (-1, 3))
    worst = 0.0
    for w in lat[4:8]:
        nodes = np.reshape(gmsh.model.mesh.getElementsByType(qt, w)[1], (-1, bf.shape[1]))
        pts = np.einsum("qn,enc->eqc", bf, x[nodes])
        worst = max(worst, float(np.abs(np.hypot(pts[..., 0], pts[..., 1]) - r).max()))
    print(json.dumps({"method": a.method, "order": p, "elements": len(tags), "invalid": int((dj <= 0).sum()),
                      "min_sj": float(sj.min()), "boundary_sample_distance": worst, "seconds": secs}))
gmsh.finalize()
