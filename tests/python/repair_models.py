#!/usr/bin/env python3
"""Models for the repair in patches (issue 42), made as a user makes them:
built with Gmsh's OpenCASCADE kernel (booleans, fillets), written as
STEP, opened again in a fresh model and meshed with tetrahedra there.

  torus    the torus R = 1, r = 0.3 about the z axis
  ballbox  the box [-1.5, 1.5]^3 minus the ball r = 0.5 (a boolean cut)
  sphere   the ball r = 1
  bracket  an L bracket (2 x 1 x 0.25 plate and 0.25 x 1 x 1.5 upright,
           fused), its inner edge filleted (r = 0.2), two holes (r = 0.2)
           cut through it

Sizes: Mesh.MeshSizeMax SIZE, MeshSizeMin SIZE / 3, 12 elements per 2 pi
of curvature. Writes DIR/KIND.step and DIR/KIND.msh (MSH 4.1, linear, no
physical groups: every entity's elements saved).

--peers P: Gmsh's own curving of that mesh on that STEP, each method from
the file (setOrder P, HighOrderFastCurving, HighOrderElastic per
--methods), judged by check_cad.judge(); prints JSON {method: {"invalid",
"min_sj", "min_det_jac", "seconds"}}.

Usage: repair_models.py KIND DIR SIZE [--peers P] [--methods setorder,fastcurving]"""
import argparse
import json
import os
import sys
import time

import gmsh

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import check_cad  # noqa: E402

ap = argparse.ArgumentParser()
ap.add_argument("kind", choices=["torus", "ballbox", "sphere", "bracket"])
ap.add_argument("dir")
ap.add_argument("size", type=float)
ap.add_argument("--peers", type=int)
ap.add_argument("--methods", default="setorder,fastcurving")
a = ap.parse_args()
step = os.path.join(a.dir, a.kind + ".step")
msh = os.path.join(a.dir, a.kind + ".msh")


def build(occ):
    if a.kind == "torus":
        occ.addTorus(0, 0, 0, 1, 0.3)
    elif a.kind == "sphere":
        occ.addSphere(0, 0, 0, 1)
    elif a.kind == "ballbox":
        box = occ.addBox(-1.5, -1.5, -1.5, 3, 3, 3)
        occ.cut([(3, box)], [(3, occ.addSphere(0, 0, 0, 0.5))])
    else:
        plate, upright = occ.addBox(0, 0, 0, 2, 1, 0.25), occ.addBox(0, 0, 0, 0.25, 1, 1.5)
        fused, _ = occ.fuse([(3, plate)], [(3, upright)])
        occ.synchronize()

        def inner(e):
            x0, y0, z0, x1, y1, z1 = gmsh.model.getBoundingBox(1, e)
            return all(abs(v - 0.25) < 1e-6 for v in (x0, x1, z0, z1))

        edges = [e for _, e in gmsh.model.getEntities(1) if inner(e)]
        filleted = occ.fillet([fused[0][1]], edges, [0.2])
        holes = [(3, occ.addCylinder(1.3, 0.5, -0.1, 0, 0, 0.5, 0.2)), (3, occ.addCylinder(-0.1, 0.5, 0.9, 0.5, 0, 0, 0.2))]
        occ.cut(filleted, holes)
    occ.synchronize()


gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
build(gmsh.model.occ)
check_cad.write_quietly(step)
gmsh.clear()
gmsh.open(step)
gmsh.option.setNumber("Mesh.MeshSizeMax", a.size)
gmsh.option.setNumber("Mesh.MeshSizeMin", a.size / 3)
gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 12)
gmsh.model.mesh.generate(3)
gmsh.write(msh)
if a.peers:
    out = {}
    for method in a.methods.split(","):
        gmsh.clear()
        gmsh.open(step)
        gmsh.merge(msh)
        t0 = time.perf_counter()
        gmsh.model.mesh.setOrder(a.peers)
        if method != "setorder":
            gmsh.option.setNumber("Mesh.HighOrderOptimize", 4 if method == "fastcurving" else 3)
            gmsh.model.mesh.optimize("HighOrderFastCurving" if method == "fastcurving" else "HighOrderElastic")
        secs = time.perf_counter() - t0
        j = check_cad.judge()
        out[method] = {"invalid": j["invalid"], "min_sj": j["min_sj"], "min_det_jac": j["min_det_jac"], "seconds": secs}
    print(json.dumps(out))
gmsh.finalize()
