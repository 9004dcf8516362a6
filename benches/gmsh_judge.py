#!/usr/bin/env python3
"""Gmsh's own measure of a curved mesh, the same for every tool's file
(for benches/repair.sh): merges MESH and prints JSON {"elements",
"invalid" (minDetJac <= 0), "min_det_jac", "min_sj"} over the elements of
the mesh's dimension, and "min_sj_dense": the least scaled Jacobian
sampled densely (Gmsh's minSJ is a loose bound on thin elements): det J
over the product of the lengths of the columns of J at the points of
Gmsh's integration rule of order 3p, each element's own reference.

Usage: gmsh_judge.py MESH"""
import json
import sys

import gmsh
import numpy as np

gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
gmsh.merge(sys.argv[1])
dim = max(d for d, _ in gmsh.model.getEntities())
out = {"elements": 0, "invalid": 0, "min_det_jac": float("inf"), "min_sj": float("inf"), "min_sj_dense": float("inf")}
types = gmsh.model.mesh.getElementTypes(dim)
for t in types:
    tags, _ = gmsh.model.mesh.getElementsByType(t)
    det = np.array(gmsh.model.mesh.getElementQualities(tags, "minDetJac"))
    sj = np.array(gmsh.model.mesh.getElementQualities(tags, "minSJ"))
    out["elements"] += len(tags)
    out["invalid"] += int((det <= 0).sum())
    out["min_det_jac"] = min(out["min_det_jac"], float(det.min()))
    out["min_sj"] = min(out["min_sj"], float(sj.min()))
    order = gmsh.model.mesh.getElementProperties(t)[2]
    pts, _ = gmsh.model.mesh.getIntegrationPoints(t, "Gauss" + str(3 * order))
    jac, dets, _ = gmsh.model.mesh.getJacobians(t, pts)
    n = len(dets) // len(tags)
    jac = np.reshape(jac, (len(tags), n, 3, 3))
    dets = np.reshape(dets, (len(tags), n))
    # columns of J: d x / d u_c (Gmsh returns J row-major as [dx/du, dy/du, dz/du, ...])
    lengths = np.linalg.norm(jac, axis=3)
    prod = np.prod(lengths[:, :, :dim], axis=2)
    out["min_sj_dense"] = min(out["min_sj_dense"], float((dets / prod).min()))
print(json.dumps(out))
gmsh.finalize()
