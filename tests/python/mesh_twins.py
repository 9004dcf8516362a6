#!/usr/bin/env python3
"""Twins of a Gmsh mesh as other tools would hand it over, and a
comparison of two curved meshes element by element.

  msh22 IN OUT [--one-entity | --no-tags]
                       meshio reads IN and writes OUT as ASCII MSH 2.2
                       (a mesh from another tool: no $Entities; elementary
                       and physical tags as meshio keeps them; with
                       --one-entity every boundary element on elementary
                       entity 1, as a mesher that merged the faces; with
                       --no-tags no tags at all, written as 0, as meshio
                       writes a mesh it read from a format without them)
  scaled IN OUT S      IN with every node's coordinates times S, written
                       by Gmsh as MSH 4.1 (a mesh in other units)
  compare A B          Gmsh reads both; the elements of the highest
                       dimension are matched by their corner coordinates
                       and their nodes compared; prints JSON {"elements",
                       "matched", "max_difference"}

Usage: mesh_twins.py msh22 IN OUT [--one-entity | --no-tags] | scaled IN OUT S | compare A B"""
import json
import sys

import gmsh


def msh22(src, out, how=None):
    import meshio

    m = meshio.read(src)
    if how == "--no-tags":
        m.cell_data = {}
        m.field_data = {}
    if how == "--one-entity":
        dim = max(meshio._mesh.topological_dimension.get(c.type, 0) for c in m.cells)
        for c, tags in zip(m.cells, m.cell_data["gmsh:geometrical"]):
            if meshio._mesh.topological_dimension.get(c.type, 0) == dim - 1:
                tags[:] = 1
    meshio.write(out, m, file_format="gmsh22", binary=False)


def scaled(src, out, s):
    gmsh.initialize(readConfigFiles=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.open(src)
    tags, xyz, _ = gmsh.model.mesh.getNodes()
    for t, k in zip(tags, range(0, len(xyz), 3)):
        gmsh.model.mesh.setNode(int(t), [c * s for c in xyz[k:k + 3]], [])
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.write(out)
    gmsh.finalize()


def elements(path):
    """{sorted corner coordinates: node coordinates} of the elements of
    the highest dimension."""
    import numpy as np

    gmsh.initialize(readConfigFiles=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.open(path)
    dim = max(d for d, _ in gmsh.model.getEntities() if len(gmsh.model.mesh.getElements(d)[0]) > 0)
    nt, xyz, _ = gmsh.model.mesh.getNodes()
    x = np.zeros((int(nt.max()) + 1, 3))
    x[nt] = np.reshape(xyz, (-1, 3))
    out = {}
    types, _, enodes = gmsh.model.mesh.getElements(dim)
    for et, en in zip(types, enodes):
        corners = gmsh.model.mesh.getElementProperties(et)[5]
        nodes = np.reshape(en, (-1, gmsh.model.mesh.getElementProperties(et)[3]))
        for e in nodes:
            key = tuple(sorted(tuple(np.round(x[n], 8)) for n in e[:corners]))
            out[key] = x[e]
    gmsh.finalize()
    return out


def compare(a, b):
    ea, eb = elements(a), elements(b)
    diff, matched = 0.0, 0
    for k, xa in ea.items():
        xb = eb.get(k)
        if xb is not None and xb.shape == xa.shape:
            matched += 1
            diff = max(diff, float(abs(xa - xb).max()))
    print(json.dumps({"elements": len(ea), "matched": matched, "max_difference": diff}))


if __name__ == "__main__":
    cmd = sys.argv[1:2]
    if cmd == ["msh22"] and (len(sys.argv) == 4 or sys.argv[4:] in (["--one-entity"], ["--no-tags"])):
        msh22(sys.argv[2], sys.argv[3], (sys.argv[4:] or [None])[0])
    elif cmd == ["scaled"] and len(sys.argv) == 5:
        scaled(sys.argv[2], sys.argv[3], float(sys.argv[4]))
    elif cmd == ["compare"] and len(sys.argv) == 4:
        compare(sys.argv[2], sys.argv[3])
    else:
        sys.exit(__doc__)
