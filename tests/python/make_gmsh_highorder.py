#!/usr/bin/env python3
"""Make a high-order quad mesh of the unit disk with Gmsh itself.

Usage: make_gmsh_highorder.py OUT.msh ORDER

Writes MSH 4.1 (ASCII) and prints JSON: {"elements": n, "type": t,
"tags": [...], "minDetJac": [...], "minSJ": [...]} for the 2D elements,
by tag.
"""
import json
import sys

import gmsh


def main():
    out, order = sys.argv[1], int(sys.argv[2])
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add("disk")
    gmsh.model.occ.addDisk(0, 0, 0, 1, 1)
    gmsh.model.occ.synchronize()
    gmsh.model.addPhysicalGroup(1, [1], name="circle")
    gmsh.model.addPhysicalGroup(2, [1], name="disk")
    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.3)
    gmsh.option.setNumber("Mesh.RecombineAll", 1)
    gmsh.option.setNumber("Mesh.Algorithm", 8)
    gmsh.model.mesh.generate(2)
    gmsh.model.mesh.setOrder(order)
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.option.setNumber("Mesh.Binary", 0)
    gmsh.write(out)
    types = gmsh.model.mesh.getElementTypes(2)
    tags, _ = gmsh.model.mesh.getElementsByType(types[0])
    tags = sorted(int(t) for t in tags)
    res = {"elements": len(tags), "type": int(types[0]), "tags": tags,
           "minDetJac": [float(v) for v in gmsh.model.mesh.getElementQualities(tags, "minDetJac")],
           "minSJ": [float(v) for v in gmsh.model.mesh.getElementQualities(tags, "minSJ")]}
    gmsh.finalize()
    print(json.dumps(res))


if __name__ == "__main__":
    main()
