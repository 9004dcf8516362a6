"""Gmsh's own curving of the mesh in the current Gmsh model, judged like
`deformesh curve` judges its result (used by cylinder_bl.py and
sphere_bl.py).

curve_and_judge(p, method, surfaces, off_shape): setOrder(p), then for
method "fastcurving" / "elastic" the optimiser HighOrderFastCurving /
HighOrderElastic (Mesh.HighOrderOptimize 4 / 3), timed; prints JSON
{"method", "order", "elements", "invalid" (3D elements with minDetJac <= 0),
"min_sj" (Gmsh's bound), "boundary_sample_distance" (the largest
off_shape(points) of 17 x 17 points per quad face of the given surfaces),
"seconds"}, or {"method", "error"} and exit status 1 when Gmsh throws.
curve_and_judge_simplices: the same for triangle and tetrahedral meshes,
and for 2D meshes of quadrangles and triangles (over all their elements),
with the counts per element type too."""
import json, time
import gmsh


def _curve(p, method):
    """setOrder(p), then the optimiser of `method`; the seconds both took.
    Prints {"method", "error"} and exits 1 when Gmsh throws."""
    try:
        t0 = time.perf_counter()
        gmsh.model.mesh.setOrder(p)
        if method != "setorder":
            gmsh.option.setNumber("Mesh.HighOrderOptimize", 4 if method == "fastcurving" else 3)
            gmsh.model.mesh.optimize("HighOrderFastCurving" if method == "fastcurving" else "HighOrderElastic")
        return time.perf_counter() - t0
    except Exception as e:
        print(json.dumps({"method": method, "error": str(e)}))
        raise SystemExit(1)


def _qualities(dim):
    """The tags of the elements of dimension dim (of every type), their
    minDetJac and minSJ, and the name of each one's type."""
    import numpy as np

    types, per_type, _ = gmsh.model.mesh.getElements(dim)
    tags = np.concatenate(per_type)
    names = np.concatenate([[gmsh.model.mesh.getElementProperties(t)[0]] * len(ts) for t, ts in zip(types, per_type)])
    return tags, np.array(gmsh.model.mesh.getElementQualities(tags, "minDetJac")), np.array(gmsh.model.mesh.getElementQualities(tags, "minSJ")), names


def curve_and_judge(p, method, surfaces, off_shape):
    # numpy only now: imported before the mesh is generated, it changes
    # Gmsh's element connectivity (pointer-ordered sets)
    import numpy as np

    secs = _curve(p, method)
    tags, dj, sj, _ = _qualities(3)
    qt = gmsh.model.mesh.getElementType("Quadrangle", p)
    uv = [c for i in range(17) for j in range(17) for c in (-1 + i / 8, -1 + j / 8, 0)]
    bf = np.reshape(gmsh.model.mesh.getBasisFunctions(qt, uv, "Lagrange")[1], (289, -1))
    nt, xyz, _ = gmsh.model.mesh.getNodes()
    x = np.zeros((int(nt.max()) + 1, 3))
    x[nt] = np.reshape(xyz, (-1, 3))
    worst = 0.0
    for s in surfaces:
        nodes = np.reshape(gmsh.model.mesh.getElementsByType(qt, s)[1], (-1, bf.shape[1]))
        pts = np.einsum("qn,enc->eqc", bf, x[nodes])
        worst = max(worst, float(off_shape(pts).max()))
    print(json.dumps({"method": method, "order": p, "elements": len(tags), "invalid": int((dj <= 0).sum()),
                      "min_sj": float(sj.min()), "boundary_sample_distance": worst, "seconds": secs}))


def curve_and_judge_simplices(p, method, dim, curves, off_shape):
    """curve_and_judge for a mesh of triangles, or of quadrangles and
    triangles (dim 2: `curves` are the wall's curves, each line sampled at
    17 points), or of tetrahedra (dim 3: `curves` are the wall's surfaces,
    each triangle sampled on the lattice of 17 points per edge);
    off_shape(points) the distance to the wall. Besides curve_and_judge's
    figures (over all the elements of dimension dim), "elements_by_type"
    and "invalid_by_type" ({type name: count}, e.g. "Triangle 10")."""
    import numpy as np

    secs = _curve(p, method)
    tags, dj, sj, names = _qualities(dim)
    m = 16
    if dim == 2:
        ft = gmsh.model.mesh.getElementType("Line", p)
        uvw = [c for k in range(m + 1) for c in (-1 + 2 * k / m, 0, 0)]
    else:
        ft = gmsh.model.mesh.getElementType("Triangle", p)
        uvw = [c for j in range(m + 1) for i in range(m + 1 - j) for c in (i / m, j / m, 0)]
    bf = np.reshape(gmsh.model.mesh.getBasisFunctions(ft, uvw, "Lagrange")[1], (len(uvw) // 3, -1))
    nt, xyz, _ = gmsh.model.mesh.getNodes()
    x = np.zeros((int(nt.max()) + 1, 3))
    x[nt] = np.reshape(xyz, (-1, 3))
    worst = 0.0
    for c in curves:
        nodes = np.reshape(gmsh.model.mesh.getElementsByType(ft, c)[1], (-1, bf.shape[1]))
        pts = np.einsum("qn,enc->eqc", bf, x[nodes])
        worst = max(worst, float(off_shape(pts).max()))
    kinds = sorted(set(names))
    print(json.dumps({"method": method, "order": p, "elements": int(len(tags)), "invalid": int((dj <= 0).sum()),
                      "min_sj": float(sj.min()), "boundary_sample_distance": worst, "seconds": secs,
                      "elements_by_type": {k: int((names == k).sum()) for k in kinds},
                      "invalid_by_type": {k: int(((names == k) & (dj <= 0)).sum()) for k in kinds}}))
