#!/usr/bin/env python3
"""Which nodes of a curved mesh are where Gmsh puts a straight mesh's.

Usage: straight_nodes.py LINEAR.msh CURVED.msh ORDER

Gmsh opens LINEAR.msh (no CAD: its entities are discrete, so setOrder
places the new nodes on the straight edges, faces and cells), raises it to
ORDER, and compares its nodes with those of CURVED.msh. Prints JSON:
{"nodes": curved nodes, "straight": curved nodes within 1e-12 of a node of
Gmsh's straight mesh, "moved": [[x, y, z], ...] the others}.
"""
import json
import sys

import gmsh
import numpy as np


def nodes_of(path, order=None):
    gmsh.clear()
    gmsh.open(path)
    if order is not None:
        gmsh.model.mesh.setOrder(order)
    _, xyz, _ = gmsh.model.mesh.getNodes()
    return np.asarray(xyz).reshape(-1, 3)


def main():
    linear, curved, order = sys.argv[1], sys.argv[2], int(sys.argv[3])
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    straight = nodes_of(linear, order)
    ours = nodes_of(curved)
    gmsh.finalize()
    # match on a grid of 1e-9, then check the distance exactly
    key = lambda p: tuple(np.round(p / 1e-9).astype(np.int64))
    cells = {}
    for p in straight:
        cells.setdefault(key(p), []).append(p)
    moved = []
    for p in ours:
        k = key(p)
        near = [q for dk in np.ndindex(3, 3, 3) for q in cells.get(tuple(np.add(k, np.subtract(dk, 1))), [])]
        if not any(np.linalg.norm(p - q) <= 1e-12 for q in near):
            moved.append(p.tolist())
    print(json.dumps({"nodes": len(ours), "straight": len(ours) - len(moved), "moved": moved}))


main()
