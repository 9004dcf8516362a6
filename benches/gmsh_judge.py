#!/usr/bin/env python3
"""Gmsh's own measure of a curved mesh, the same for every tool's file
(for benches/repair.sh): merges MESH and prints JSON {"elements",
"invalid" (minDetJac <= 0), "min_det_jac", "min_sj"} over the elements of
the mesh's dimension (the tetrahedra of benches/repair.sh are not thin:
there minSJ is not the loose bound it is on a thin layer).

Usage: gmsh_judge.py MESH"""
import json
import sys

import gmsh
import numpy as np

gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
gmsh.merge(sys.argv[1])
dim = max(d for d, _ in gmsh.model.getEntities())
out = {"elements": 0, "invalid": 0, "min_det_jac": float("inf"), "min_sj": float("inf")}
types = gmsh.model.mesh.getElementTypes(dim)
for t in types:
    tags, _ = gmsh.model.mesh.getElementsByType(t)
    det = np.array(gmsh.model.mesh.getElementQualities(tags, "minDetJac"))
    sj = np.array(gmsh.model.mesh.getElementQualities(tags, "minSJ"))
    out["elements"] += len(tags)
    out["invalid"] += int((det <= 0).sum())
    out["min_det_jac"] = min(out["min_det_jac"], float(det.min()))
    out["min_sj"] = min(out["min_sj"], float(sj.min()))
print(json.dumps(out))
gmsh.finalize()
