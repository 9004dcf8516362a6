#!/usr/bin/env python3
"""Open a mesh file (any MSH version Gmsh reads, meant for MSH 2.2) with
the Gmsh API and print what Gmsh sees, as JSON.

Usage: check_msh22.py FILE

Prints one JSON object:
  num_nodes       number of nodes Gmsh loaded
  element_types   {type number: count} over all dimensions
  physical_groups [[dim, tag, name, number of elements in the group], ...]
                  sorted by (dim, tag)
  cells           {"dim", "tags": [...], "minDetJac": [...]} for the
                  elements of the model's dimension, by tag
                  (getElementQualities)
Exits non-zero (with Gmsh's message on stderr) if Gmsh cannot read FILE.
"""
import json
import sys

import gmsh


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    gmsh.initialize(readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.open(sys.argv[1])
        types, tags, _ = gmsh.model.mesh.getElements()
        counts = {str(int(t)): len(ts) for t, ts in zip(types, tags)}
        groups = []
        for dim, tag in sorted(gmsh.model.getPhysicalGroups()):
            n = 0
            for e in gmsh.model.getEntitiesForPhysicalGroup(dim, tag):
                _, ts, _ = gmsh.model.mesh.getElements(dim, int(e))
                n += sum(len(t) for t in ts)
            groups.append([dim, tag, gmsh.model.getPhysicalName(dim, tag), n])
        dim = gmsh.model.getDimension()
        _, ts, _ = gmsh.model.mesh.getElements(dim=dim)
        cell_tags = sorted(int(t) for block in ts for t in block)
        det = gmsh.model.mesh.getElementQualities(cell_tags, "minDetJac") if cell_tags else []
        report = {
            "num_nodes": len(gmsh.model.mesh.getNodes()[0]),
            "element_types": counts,
            "physical_groups": groups,
            "cells": {"dim": dim, "tags": cell_tags, "minDetJac": [float(v) for v in det]},
        }
    finally:
        gmsh.finalize()
    json.dump(report, sys.stdout)
    print()


if __name__ == "__main__":
    main()
