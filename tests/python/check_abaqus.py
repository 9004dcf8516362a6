#!/usr/bin/env python3
"""Read an ABAQUS .inp file with meshio and print what meshio sees, as JSON.

Usage: check_abaqus.py FILE

meshio reads the linear part (the *NODE and *ELEMENT blocks); the lines
starting with "**" (HOHQMesh's high-order block) are comments to it.

Prints one JSON object:
  num_points   number of points
  cells        {cell type: number of cells}
  points       [x, y, z] of every point, in meshio's order
  connectivity {cell type: [[point index, ...], ...]} (0-based, meshio's order)
Exits non-zero if meshio cannot read the file.
"""
import json
import sys

import meshio


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    mesh = meshio.read(sys.argv[1], file_format="abaqus")
    cells = {}
    connectivity = {}
    for block in mesh.cells:
        cells[block.type] = cells.get(block.type, 0) + len(block.data)
        connectivity.setdefault(block.type, []).extend(block.data.tolist())
    report = {
        "num_points": len(mesh.points),
        "cells": cells,
        "points": mesh.points.tolist(),
        "connectivity": connectivity,
    }
    json.dump(report, sys.stdout)


if __name__ == "__main__":
    main()
