#!/usr/bin/env python3
"""The least scaled Jacobian of a curved mesh, sampled densely: at every
point of an (N+1)-per-side grid of each element's reference element (the
triangle's and tetrahedron's corners of the grid inside them), det J over
the product of the columns' lengths, from Gmsh's own Jacobians
(gmsh.model.mesh.getJacobians). Gmsh's `minSJ` is a bound from the
Jacobian's Bezier coefficients, loose on thin curved elements (a 1e-4
boundary-layer quad whose det J varies 3-fold along it: minSJ 0.064,
sampled 0.994); this is the same measure taken pointwise on both sides'
files.

Usage: dense_sj.py FILE.msh [N]   (N default 10; prints JSON
{"elements", "min_sj", "worst": tag})"""
import json
import sys

import gmsh
import numpy as np

path = sys.argv[1]
n = int(sys.argv[2]) if len(sys.argv) > 2 else 10
gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
gmsh.open(path)
dim = max(d for d, _ in gmsh.model.getEntities())
least, worst, count = np.inf, None, 0
for t in gmsh.model.mesh.getElementTypes(dim):
    name, _, _, _, _, _ = gmsh.model.mesh.getElementProperties(t)
    g = np.linspace(0.0, 1.0, n + 1)
    simplex = name.startswith("Triangle") or name.startswith("Tetrahedron")
    if dim == 2:
        pts = [(u, v, 0.0) for u in g for v in g if not simplex or u + v <= 1 + 1e-12]
    else:
        pts = [(u, v, w) for u in g for v in g for w in g if not simplex or u + v + w <= 1 + 1e-12]
    if not simplex:
        pts = [(2 * u - 1, 2 * v - 1, (2 * w - 1) if dim == 3 else 0.0) for u, v, w in pts]
    tags, _ = gmsh.model.mesh.getElementsByType(t)
    jac, det, _ = gmsh.model.mesh.getJacobians(t, [c for p in pts for c in p])
    jac = np.asarray(jac).reshape(len(tags), len(pts), 3, 3)
    det = np.asarray(det).reshape(len(tags), len(pts))
    # Gmsh's rows are d x / d u_k
    lengths = np.prod(np.linalg.norm(jac[:, :, :dim, :], axis=3), axis=2)
    sj = (det / lengths).min(axis=1)
    k = int(np.argmin(sj))
    if sj[k] < least:
        least, worst = float(sj[k]), int(tags[k])
    count += len(tags)
gmsh.finalize()
print(json.dumps({"elements": count, "min_sj": least, "worst": worst}))
