#!/usr/bin/env python3
"""One of Gmsh's curvings of a linear mesh, as a whole process (for
benches/repair.sh): opens MODEL (STEP, BREP, ...) or none, merges MESH,
setOrder(P), then HighOrderFastCurving or HighOrderElastic for those
methods, and writes OUT (MSH 4.1). Prints the curving call's seconds.

Usage: gmsh_peer.py MODEL|- MESH P setorder|fastcurving|elastic OUT"""
import sys
import time

import gmsh

model, mesh, p, method, out = sys.argv[1:6]
gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
if model != "-":
    gmsh.open(model)
gmsh.merge(mesh)
t0 = time.perf_counter()
gmsh.model.mesh.setOrder(int(p))
if method != "setorder":
    gmsh.option.setNumber("Mesh.HighOrderOptimize", 4 if method == "fastcurving" else 3)
    gmsh.model.mesh.optimize("HighOrderFastCurving" if method == "fastcurving" else "HighOrderElastic")
print(f"{time.perf_counter() - t0:.4f}")
gmsh.write(out)
gmsh.finalize()
