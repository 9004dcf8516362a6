"""Prism meshes made by Gmsh as a user would (MSH 4.1 ASCII, linear,
Mesh.SaveAll off, physical groups on every boundary face and on every 3D
element), for the tests and the benchmarks of prism curving:

  extruded   triangles with a boundary layer around the circle r = 0.5 in
             the square [-2, 2]^2 (Gmsh's BoundaryLayer field on the circle,
             Quads off: first cell FIRST (1e-4), ratio 1.3, thickness 0.06,
             i.e. 20 layers; size 0.085 on the circle, 0.3 at the square's
             corners), extruded along z over [0, 1] in LAYERS (4) recombined
             layers into prisms (geo kernel: the wall is the true cylinder);
             groups wall, farfield, bottom (z = 0), top (z = 1), fluid.
             Defaults: the issue's 10,152 prisms (40 segments on the
             circle); --size 4 --layers 2: 1,100 prisms (12 segments, 19
             layers). --first 1e-5: 12,960 prisms.
  ballprism  the box [-1.5, 1.5]^3 minus the ball r = 0.5: 6 layers of prisms
             grown on the sphere (OCC) by geo.extrudeBoundaryLayer (first
             FIRST (1e-3), ratio 1.3), tetrahedra outside sharing the
             layer's outer triangles; size 0.5 on the sphere (50 triangles),
             0.38 at the box; groups sphere, box, fluid (prisms and tets).
             Defaults: 300 prisms, 2,469 tets (the issue: 240 and 2,471,
             a sphere of 40 triangles, which no size here gives: 0.46 -> 48,
             0.5 -> 50, 0.55 -> 28); --size 1.6: 180 prisms, 782 tets.
  hexpyr     the box [0, 2] x [0, 1]^2 minus the ball r = 0.25 at
             (1.5, 0.5, 0.5) (OCC): [0, 1]^3 transfinite, recombined (6^3
             hexes), the rest tetrahedra (size 0.18), Gmsh putting pyramids on
             the hexes' quads at the interface; groups sphere, box, fluid.
             Defaults: 216 hexes, 36 pyramids, 1,215 tets; --size 1.5: 64,
             16, 665.

--size F multiplies every mesh size (hexpyr: 6 / F hexes an edge). The
written file is read back into a fresh model and checked with Gmsh: every
3D element's minDetJac > 0; every face of the 3D elements shared by two of
them or else the face of exactly one element of a boundary group (so the
prisms and the tets conform), and every boundary element a face of a 3D
element. Counts per element kind and per group, times and the checks go to
stderr; exit status 1 if a check fails.

With --order P, also Gmsh's own curving of the same mesh on the same CAD
(--method setorder, fastcurving or elastic: setOrder(P), then for the last
two HighOrderFastCurving / HighOrderElastic with Mesh.HighOrderOptimize 4 /
3), judged as tet_meshes.py judges it: prints one JSON line {"method",
"order", "elements", "invalid" (3D elements with minDetJac <= 0), "min_sj",
"boundary_sample_distance" (the largest distance to the curved wall of the
wall's faces sampled with Gmsh's Lagrange basis on 17 points an edge:
triangles on their lattice, quads on 17 x 17), "seconds",
"elements_by_type", "invalid_by_type"}. Gmsh 4.15 evaluates nothing on
prisms of order 3 ("FaceClosureFull not implemented for prisms of order
3"): then "invalid" and "min_sj" are null, "error" says why, and the
per-type figures hold the types Gmsh could judge. When the curving itself
throws (Elastic of order-3 prisms, and FastCurving where it curves them),
the same JSON with
null figures and "error", and exit status 1. With --vtu FILE the
curved 3D elements are also written as a VTU (VTK Lagrange cells, linear
cells at P = 1), their nodes put in VTK's order by gmsh_to_vtk (not for
Gmsh's pyramids of order > 1, whose collapsed coordinates it does not map).

Usage: python prism_meshes.py KIND OUT.msh [--size F] [--first H] [--layers N]
           [--order P] [--method setorder|fastcurving|elastic] [--vtu OUT.vtu]"""
import argparse, json, math, sys, time
import gmsh

# numpy is imported only after the mesh is generated: imported before, it
# changes Gmsh's element connectivity (pointer-ordered sets)

FAMILIES = {"Tetrahedron": 4, "Prism": 6, "Hexahedron": 8, "Pyramid": 5}
VTK_TYPES = {  # family: (linear VTK type, Lagrange VTK type)
    "Tetrahedron": (10, 71), "Prism": (13, 73), "Hexahedron": (12, 72), "Pyramid": (14, 74)}


def log(*parts):
    print(*parts, file=sys.stderr)


def family_order(t):
    """(family, order) of Gmsh's 3D element type t, without
    getElementProperties (which throws for prisms of order 3)."""
    for fam in FAMILIES:
        for p in range(1, 5):
            if gmsh.model.mesh.getElementType(fam, p) == t:
                return fam, p
    raise ValueError(f"element type {t} is not a 3D Lagrange type")


def type_name(t, nodes_per_element):
    """Gmsh's name of the type ("Prism 18"), built as Gmsh builds it."""
    return f"{family_order(t)[0]} {nodes_per_element}"


# ---------------------------------------------------------------- geometry

def extruded(a):
    g = gmsh.model.geo
    L, r = 2.0, 0.5
    first = a.first if a.first is not None else 1e-4
    c0 = g.addPoint(0, 0, 0)
    sq = [g.addPoint(x, y, 0, 0.3 * a.size) for x, y in [(-L, -L), (L, -L), (L, L), (-L, L)]]
    ci = [g.addPoint(r * math.cos(k * math.pi / 2), r * math.sin(k * math.pi / 2), 0, 0.085 * a.size) for k in range(4)]
    sides = [g.addLine(sq[k], sq[(k + 1) % 4]) for k in range(4)]
    arcs = [g.addCircleArc(ci[k], c0, ci[(k + 1) % 4]) for k in range(4)]
    s = g.addPlaneSurface([g.addCurveLoop(sides), g.addCurveLoop(arcs)])
    g.synchronize()
    f = gmsh.model.mesh.field
    bl = f.add("BoundaryLayer")
    f.setNumbers(bl, "CurvesList", arcs)
    f.setNumber(bl, "Size", first)
    f.setNumber(bl, "Ratio", 1.3)
    f.setNumber(bl, "Thickness", 0.06)
    f.setNumber(bl, "Quads", 0)
    f.setAsBoundaryLayer(bl)
    ex = g.extrude([(2, s)], 0, 0, 1.0, numElements=[a.layers], recombine=True)
    g.synchronize()
    top, vol = ex[0][1], ex[1][1]
    lateral = [t for d, t in ex[2:] if d == 2]
    wall = [t for t in lateral if max(map(abs, gmsh.model.getBoundingBox(2, t)[:2] + gmsh.model.getBoundingBox(2, t)[3:5])) < r + 1e-6]
    far = [t for t in lateral if t not in wall]
    assert len(wall) == 4 and len(far) == 4, (wall, far)
    gmsh.model.addPhysicalGroup(2, wall, name="wall")
    gmsh.model.addPhysicalGroup(2, far, name="farfield")
    gmsh.model.addPhysicalGroup(2, [s], name="bottom")
    gmsh.model.addPhysicalGroup(2, [top], name="top")
    gmsh.model.addPhysicalGroup(3, [vol], name="fluid")
    return wall, lambda pts: abs((pts[..., 0] ** 2 + pts[..., 1] ** 2) ** 0.5 - r)


def box_surfaces(g, x0, x1, h):
    """The six plane faces of the box [x0, x1] (geo kernel), size h at its corners."""
    p = [g.addPoint(x1[0] if k & 1 else x0[0], x1[1] if k & 2 else x0[1], x1[2] if k & 4 else x0[2], h) for k in range(8)]
    e = {(i, i | b): g.addLine(p[i], p[i | b]) for i in range(8) for b in (1, 2, 4) if not i & b}
    cur = lambda i, j: e[i, j] if i < j else -e[j, i]
    faces = []
    for f in (1, 2, 4):
        q, r = [b for b in (1, 2, 4) if b != f]
        for v in (0, f):
            cyc = [v, v | q, v | q | r, v | r]
            faces.append(g.addPlaneSurface([g.addCurveLoop([cur(i, j) for i, j in zip(cyc, cyc[1:] + cyc[:1])])]))
    return faces


def ballprism(a):
    R, first, ratio, n = 0.5, a.first if a.first is not None else 1e-3, 1.3, 6
    occ, g = gmsh.model.occ, gmsh.model.geo
    ball = occ.addSphere(0, 0, 0, R)
    occ.synchronize()
    sphere = [t for d, t in gmsh.model.getBoundary([(3, ball)])]
    occ.remove([(3, ball)])  # keeps the sphere surface
    occ.mesh.setSize(occ.getEntities(0), 0.5 * a.size)
    occ.synchronize()
    heights = [first * (ratio ** (k + 1) - 1) / (ratio - 1) for k in range(n)]  # cumulative
    gmsh.option.setNumber("Geometry.ExtrudeReturnLateralEntities", 0)
    ex = g.extrudeBoundaryLayer([(2, s) for s in sphere], [1] * n, heights, True)
    outer = [ex[i - 1][1] for i in range(1, len(ex)) if ex[i][0] == 3]
    layer = [t for d, t in ex if d == 3]
    box = box_surfaces(g, (-1.5,) * 3, (1.5,) * 3, 0.38 * a.size)
    tets = g.addVolume([g.addSurfaceLoop(box), g.addSurfaceLoop(outer)])
    g.synchronize()
    gmsh.model.addPhysicalGroup(2, sphere, name="sphere")
    gmsh.model.addPhysicalGroup(2, box, name="box")
    gmsh.model.addPhysicalGroup(3, layer + [tets], name="fluid")
    return sphere, lambda pts: abs(((pts ** 2).sum(axis=-1)) ** 0.5 - R)


def hexpyr(a):
    R, c = 0.25, (1.5, 0.5, 0.5)
    occ = gmsh.model.occ
    hexes = occ.addBox(0, 0, 0, 1, 1, 1)
    rest = occ.cut([(3, occ.addBox(1, 0, 0, 1, 1, 1))], [(3, occ.addSphere(*c, R))])[0]
    out, _ = occ.fragment([(3, hexes)], rest)
    occ.synchronize()
    vols = [t for d, t in out if d == 3]
    hexes = [t for t in vols if gmsh.model.getBoundingBox(3, t)[3] < 1 + 1e-6]
    assert len(hexes) == 1 and len(vols) == 2, out
    hexes = hexes[0]
    n = max(1, round(6 / a.size))
    hf = [t for d, t in gmsh.model.getBoundary([(3, hexes)], combined=False, oriented=False)]
    for _, cv in gmsh.model.getBoundary([(2, f) for f in hf], combined=False, oriented=False):
        gmsh.model.mesh.setTransfiniteCurve(cv, n + 1)
    for f in hf:
        gmsh.model.mesh.setTransfiniteSurface(f)
        gmsh.model.mesh.setRecombine(2, f)
    gmsh.model.mesh.setTransfiniteVolume(hexes)
    faces = [t for d, t in gmsh.model.getBoundary([(3, v) for v in vols], combined=True, oriented=False)]
    sphere = [f for f in faces if gmsh.model.getType(2, f) == "Sphere"]
    gmsh.model.addPhysicalGroup(2, sphere, name="sphere")
    gmsh.model.addPhysicalGroup(2, [f for f in faces if f not in sphere], name="box")
    gmsh.model.addPhysicalGroup(3, vols, name="fluid")
    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.18 * a.size)
    off = lambda pts: abs(((pts[..., 0] - c[0]) ** 2 + (pts[..., 1] - c[1]) ** 2 + (pts[..., 2] - c[2]) ** 2) ** 0.5 - R)
    return sphere, off


# ---------------------------------------------------------------- checks

def check_file(path):
    """Read path into a fresh model and check it (see the module's doc);
    log the counts; returns the list of failures."""
    import numpy as np

    current = gmsh.model.getCurrent()
    gmsh.model.add("check")
    gmsh.merge(path)
    fails = []
    totals = {}
    face_count = {}
    vol_tags = []
    for t, tags, nodes in zip(*gmsh.model.mesh.getElements(3)):
        name = type_name(t, len(nodes) // len(tags))
        totals[name] = len(tags)
        vol_tags.append(tags)
        dj = np.array(gmsh.model.mesh.getElementQualities(tags, "minDetJac"))
        if (dj <= 0).any():
            fails.append(f"{int((dj <= 0).sum())} {name} with minDetJac <= 0")
        log(f"  {name}: {len(tags)}, minDetJac in [{dj.min():.3g}, {dj.max():.3g}]")
        for ft, k in ((3, 3), (4, 4)):
            fn = np.array(gmsh.model.mesh.getElementFaceNodes(t, ft, -1, True), dtype=np.int64)
            for f in map(tuple, np.sort(fn.reshape(-1, k), axis=1)):
                face_count[f] = face_count.get(f, 0) + 1
    vol_tags = set(int(x) for ts in vol_tags for x in ts)
    bfaces = {}
    in_groups = set()
    for dim, tag in gmsh.model.getPhysicalGroups():
        name = gmsh.model.getPhysicalName(dim, tag)
        counts = {}
        for ent in gmsh.model.getEntitiesForPhysicalGroup(dim, tag):
            for t, tags, nodes in zip(*gmsh.model.mesh.getElements(dim, ent)):
                nn = len(nodes) // len(tags)
                tn = gmsh.model.mesh.getElementProperties(t)[0]
                counts[tn] = counts.get(tn, 0) + len(tags)
                if dim == 3:
                    in_groups.update(int(x) for x in tags)
                else:
                    for f in map(tuple, np.sort(np.reshape(nodes, (-1, nn)), axis=1)):
                        bfaces.setdefault(f, []).append(name)
        log(f"  group {name} ({dim}D): {counts}")
    if in_groups != vol_tags:
        fails.append(f"{len(vol_tags - in_groups)} 3D elements in no volume group")
    shared_by_more = sum(1 for c in face_count.values() if c > 2)
    open_faces = [f for f, c in face_count.items() if c == 1]
    orphan = sum(1 for f in open_faces if f not in bfaces)
    bad_boundary = sum(1 for f, names in bfaces.items() if face_count.get(f) != 1 or len(names) != 1)
    if shared_by_more:
        fails.append(f"{shared_by_more} faces shared by more than two 3D elements")
    if orphan:
        fails.append(f"{orphan} faces of one 3D element in no boundary group (non-conforming or unlabelled)")
    if bad_boundary:
        fails.append(f"{bad_boundary} boundary elements not the face of exactly one 3D element, or in several groups")
    log(f"  3D elements {sum(totals.values())}, faces {len(face_count)} ({len(open_faces)} on the boundary, "
        f"{len(bfaces)} boundary elements), nodes {len(gmsh.model.mesh.getNodes()[0])}")
    gmsh.model.remove()
    gmsh.model.setCurrent(current)
    return fails


# ---------------------------------------------------------------- curving

def curve_and_judge(p, method, wall, off_shape):
    import numpy as np

    t0 = time.perf_counter()
    try:
        gmsh.model.mesh.setOrder(p)
        if method != "setorder":
            gmsh.option.setNumber("Mesh.HighOrderOptimize", 4 if method == "fastcurving" else 3)
            gmsh.model.mesh.optimize("HighOrderFastCurving" if method == "fastcurving" else "HighOrderElastic")
        secs = time.perf_counter() - t0
    except Exception as e:  # e.g. FastCurving of order-3 prisms: "FaceClosureFull not implemented ..."
        print(json.dumps({"method": method, "order": p, "elements": sum(len(t) for t in gmsh.model.mesh.getElements(3)[1]),
                          "invalid": None, "min_sj": None, "boundary_sample_distance": None,
                          "seconds": time.perf_counter() - t0, "error": str(e)}))
        raise SystemExit(1)
    n, by_type, bad_by_type, errors, dj_all, sj_all = 0, {}, {}, [], [], []
    for t, tags, nodes in zip(*gmsh.model.mesh.getElements(3)):
        name = type_name(t, len(nodes) // len(tags))
        n += len(tags)
        by_type[name] = len(tags)
        try:
            dj = np.array(gmsh.model.mesh.getElementQualities(tags, "minDetJac"))
            sj = np.array(gmsh.model.mesh.getElementQualities(tags, "minSJ"))
        except Exception as e:  # Gmsh 4.15: "FaceClosureFull not implemented for prisms of order 3"
            errors.append(f"{name}: {e}")
            continue
        bad_by_type[name] = int((dj <= 0).sum())
        dj_all.append(dj)
        sj_all.append(sj)
    m = 16
    nt, xyz, _ = gmsh.model.mesh.getNodes()
    x = np.zeros((int(nt.max()) + 1, 3))
    x[nt] = np.reshape(xyz, (-1, 3))
    worst = 0.0
    for s in wall:
        for ft in gmsh.model.mesh.getElementTypes(2, s):
            if gmsh.model.mesh.getElementProperties(ft)[0].startswith("Triangle"):
                uvw = [c for j in range(m + 1) for i in range(m + 1 - j) for c in (i / m, j / m, 0)]
            else:
                uvw = [c for i in range(m + 1) for j in range(m + 1) for c in (-1 + 2 * i / m, -1 + 2 * j / m, 0)]
            bf = np.reshape(gmsh.model.mesh.getBasisFunctions(ft, uvw, "Lagrange")[1], (len(uvw) // 3, -1))
            nodes = np.reshape(gmsh.model.mesh.getElementsByType(ft, s)[1], (-1, bf.shape[1]))
            pts = np.einsum("qn,enc->eqc", bf, x[nodes])
            worst = max(worst, float(off_shape(pts).max()))
    out = {"method": method, "order": p, "elements": n,
           "invalid": None if errors else int(sum((d <= 0).sum() for d in dj_all)),
           "min_sj": None if errors else float(min(s.min() for s in sj_all)),
           "boundary_sample_distance": worst, "seconds": secs,
           "elements_by_type": by_type, "invalid_by_type": bad_by_type}
    if errors:
        out["error"] = "; ".join(errors)
    print(json.dumps(out))


# ---------------------------------------------------------------- VTK

def gmsh_reference_nodes(family, p):
    """Gmsh's reference coordinates of the nodes of its order-p element of
    `family`, in Gmsh's node order: getElementProperties, or, where Gmsh
    4.15 throws (prisms of order 3), the nodes setOrder(p) puts on one
    straight element, mapped back through the element's affine map."""
    import numpy as np

    t = gmsh.model.mesh.getElementType(family, p)
    try:
        _, dim, _, nn, coords, _ = gmsh.model.mesh.getElementProperties(t)
        return np.reshape(coords, (nn, dim))
    except Exception:
        if family != "Prism":
            raise
    current = gmsh.model.getCurrent()
    gmsh.model.add("reference_prism")
    g = gmsh.model.geo
    pts = [g.addPoint(x, y, -1.0) for x, y in [(0, 0), (1, 0), (0, 1)]]
    ls = [g.addLine(pts[k], pts[(k + 1) % 3]) for k in range(3)]
    for c in ls:
        g.mesh.setTransfiniteCurve(c, 2)
    g.extrude([(2, g.addPlaneSurface([g.addCurveLoop(ls)]))], 0, 0, 2.0, numElements=[1], recombine=True)
    g.synchronize()
    gmsh.model.mesh.generate(3)
    gmsh.model.mesh.setOrder(p)
    types, _, nodes = gmsh.model.mesh.getElements(3)
    assert list(types) == [t] and len(nodes[0]) == (p + 1) ** 2 * (p + 2) // 2, (types, t)
    x = np.array([gmsh.model.mesh.getNode(int(k))[0] for k in nodes[0]])
    gmsh.model.remove()
    gmsh.model.setCurrent(current)
    # the prism's own vertices 0, 1, 2, 3 are the reference's (0,0,-1), (1,0,-1), (0,1,-1), (0,0,1)
    A = np.column_stack([x[1] - x[0], x[2] - x[0], (x[3] - x[0]) / 2])
    xi = np.linalg.solve(A, (x - x[0]).T).T
    xi[:, 2] -= 1
    return xi


def vtk_parametric_coords(vtk_type, n):
    """VTK's parametric coordinates of the points of its cell of type
    vtk_type with n points (vtkCell::GetParametricCoords)."""
    import numpy as np
    import vtk

    grid = vtk.vtkUnstructuredGrid()
    pts = vtk.vtkPoints()
    pts.SetNumberOfPoints(n)
    for i in range(n):
        pts.SetPoint(i, 0.0, 0.0, 0.0)
    grid.SetPoints(pts)
    ids = vtk.vtkIdList()
    for i in range(n):
        ids.InsertNextId(i)
    grid.InsertNextCell(vtk_type, ids)
    cell = vtk.vtkGenericCell()
    grid.GetCell(0, cell)
    pc = cell.GetParametricCoords()
    return np.array([[pc[3 * i + k] for k in range(3)] for i in range(n)])


def gmsh_to_vtk(family, p):
    """perm with VTK's point k = Gmsh's node perm[k] of the order-p element
    of `family`: the affine map taking Gmsh's reference vertices onto VTK's
    (fitted, and checked exact) takes each Gmsh node onto the VTK point of
    the same parametric coordinates."""
    import numpy as np

    if family == "Pyramid" and p > 1:
        raise ValueError("no map for Gmsh's high-order pyramids (collapsed coordinates)")
    lin, lag = VTK_TYPES[family]
    g = gmsh_reference_nodes(family, p)
    g = np.hstack([g, np.zeros((len(g), 3 - g.shape[1]))])
    v = vtk_parametric_coords(lin if p == 1 else lag, len(g))
    nv = FAMILIES[family]
    g1 = gmsh_reference_nodes(family, 1)
    v1 = vtk_parametric_coords(lin, nv)
    M, *_ = np.linalg.lstsq(np.hstack([g1, np.ones((nv, 1))]), v1, rcond=None)
    assert np.abs(np.hstack([g1, np.ones((nv, 1))]) @ M - v1).max() < 1e-12, f"{family}: vertices not affinely matched"
    mapped = np.hstack([g, np.ones((len(g), 1))]) @ M
    d = np.linalg.norm(mapped[None, :, :] - v[:, None, :], axis=2)
    perm = d.argmin(axis=1)
    assert d.min(axis=1).max() < 1e-9 and sorted(perm) == list(range(len(g))), f"{family} {p}: nodes unmatched"
    return [int(k) for k in perm]


def write_vtu(path):
    """The current model's 3D elements as a VTU (nodes in VTK's order)."""
    import numpy as np
    import vtk

    nt, xyz, _ = gmsh.model.mesh.getNodes()
    row = np.full(int(nt.max()) + 1, -1, dtype=np.int64)
    row[nt] = np.arange(len(nt))
    pts = vtk.vtkPoints()
    pts.SetDataTypeToDouble()
    for c in np.reshape(xyz, (-1, 3)):
        pts.InsertNextPoint(*c)
    grid = vtk.vtkUnstructuredGrid()
    grid.SetPoints(pts)
    etag = vtk.vtkIntArray()
    etag.SetName("gmsh_element")
    for t, tags, nodes in zip(*gmsh.model.mesh.getElements(3)):
        fam, p = family_order(t)
        perm = gmsh_to_vtk(fam, p)
        vt = VTK_TYPES[fam][0 if p == 1 else 1]
        for tag, conn in zip(tags, np.reshape(nodes, (len(tags), -1))):
            ids = vtk.vtkIdList()
            for k in perm:
                ids.InsertNextId(int(row[conn[k]]))
            grid.InsertNextCell(vt, ids)
            etag.InsertNextValue(int(tag))
    grid.GetCellData().AddArray(etag)
    w = vtk.vtkXMLUnstructuredGridWriter()
    w.SetFileName(path)
    w.SetInputData(grid)
    w.SetDataModeToAscii()
    assert w.Write() == 1, path
    log(f"wrote {path}: {grid.GetNumberOfCells()} cells, {grid.GetNumberOfPoints()} points")


# ---------------------------------------------------------------- main

def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("kind", choices=["extruded", "ballprism", "hexpyr"])
    ap.add_argument("out")
    ap.add_argument("--size", type=float, default=1.0, help="factor on every mesh size")
    ap.add_argument("--first", type=float, help="first layer height (extruded 1e-4, ballprism 1e-3)")
    ap.add_argument("--layers", type=int, default=4, help="extruded: layers along z")
    ap.add_argument("--order", type=int)
    ap.add_argument("--method", choices=["setorder", "fastcurving", "elastic"], default="setorder")
    ap.add_argument("--vtu", help="with --order: write the curved mesh as a VTU")
    a = ap.parse_args()
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.option.setNumber("Mesh.SaveAll", 0)
    gmsh.option.setNumber("Mesh.Binary", 0)
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.model.add(a.kind)
    wall, off_shape = {"extruded": extruded, "ballprism": ballprism, "hexpyr": hexpyr}[a.kind](a)
    t0 = time.perf_counter()
    gmsh.model.mesh.generate(3)
    t1 = time.perf_counter()
    gmsh.write(a.out)
    log(f"{a.kind}: generated in {t1 - t0:.2f} s, wrote {a.out}")
    fails = check_file(a.out)
    log(f"  checked in {time.perf_counter() - t1:.2f} s: " + ("; ".join(fails) if fails else "all 3D elements positive, conforming, every boundary face in a group"))
    if fails:
        gmsh.finalize()
        raise SystemExit(1)
    if a.order:
        curve_and_judge(a.order, a.method, wall, off_shape)
        if a.vtu:
            try:
                write_vtu(a.vtu)
            except ValueError as e:  # hexpyr at order > 1
                log(f"--vtu: {e}")
                gmsh.finalize()
                raise SystemExit(1)
    gmsh.finalize()


if __name__ == "__main__":
    main()
