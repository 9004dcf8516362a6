#!/usr/bin/env python3
"""Evaluate high-order quad/hex meshes with the real Gmsh and VTK, as JSON.

Usage: check_highorder.py REQUEST.json

REQUEST holds {"gmsh": [{"file": F, "points": [[u, v(, w)], ...]}, ...],
               "vtk":  [{"file": F, "points": [[u, v(, w)], ...]}, ...]}
with Gmsh points on its reference cell [-1,1]^d and VTK points on [0,1]^d.

Prints one JSON object:
  gmsh_types  {type: {"name", "dim", "order", "nodes": [reference coords of
              the local nodes, flattened, Gmsh's order]}} for the line, quad
              and hex types of order 1..4 (getElementProperties)
  gmsh        per request file: {"types": {type: count}, "physical_names":
              {dim: [names by tag]}, "cell_type", "tags", "coords": per
              element the physical points (3 per point), "dets": per element
              det J at the points (getJacobians), "minDetJac", "maxDetJac",
              "minSJ" per element (getElementQualities)}
  vtk         per request file: {"cells": [{"type", "npts", "pcoords":
              [parametric coords of the cell's points, flattened],
              "points": [EvaluateLocation at each request point, xyz]}]}
  vtk_ijk     {"quad": {p: [PointIndexFromIJK(i, j) for tensor index]},
               "hex": {p: [...]}} straight from vtkHigherOrder* cells
"""
import json
import sys

import gmsh
import vtk

LINE, QUAD, HEX = [1, 8, 26, 27], [3, 10, 36, 37], [5, 12, 92, 93]


def gmsh_types():
    out = {}
    for t in LINE + QUAD + HEX:
        name, dim, order, nn, coords, _ = gmsh.model.mesh.getElementProperties(t)
        out[str(t)] = {"name": name, "dim": dim, "order": order,
                       "nodes": [float(c) for c in coords]}
    return out


def gmsh_file(req):
    gmsh.clear()
    gmsh.open(req["file"])
    types, tags, _ = gmsh.model.mesh.getElements()
    counts = {str(int(t)): len(ts) for t, ts in zip(types, tags)}
    dim = gmsh.model.getDimension()
    names = {}
    for d, tag in sorted(gmsh.model.getPhysicalGroups()):
        names.setdefault(str(d), []).append(gmsh.model.getPhysicalName(d, tag))
    cell_type = [int(t) for t in gmsh.model.mesh.getElementTypes(dim)][0]
    cell_tags, _ = gmsh.model.mesh.getElementsByType(cell_type)
    cell_tags = [int(t) for t in cell_tags]
    pts = req["points"]
    local = []
    for p in pts:
        local += list(p) + [0.0] * (3 - len(p))
    _, dets, coords = gmsh.model.mesh.getJacobians(cell_type, local)
    n, m = len(cell_tags), len(pts)
    out = {"types": counts, "physical_names": names, "cell_type": cell_type,
           "tags": cell_tags,
           "coords": [[float(c) for c in coords[3 * m * e:3 * m * (e + 1)]] for e in range(n)],
           "dets": [[float(d) for d in dets[m * e:m * (e + 1)]] for e in range(n)]}
    for q in ("minDetJac", "maxDetJac", "minSJ"):
        out[q] = [float(v) for v in gmsh.model.mesh.getElementQualities(cell_tags, q)]
    return out


def vtk_file(req):
    reader = vtk.vtkXMLUnstructuredGridReader()
    reader.SetFileName(req["file"])
    reader.Update()
    grid = reader.GetOutput()
    cells = []
    for c in range(grid.GetNumberOfCells()):
        cell = vtk.vtkGenericCell()
        grid.GetCell(c, cell)
        n = cell.GetNumberOfPoints()
        pc = cell.GetParametricCoords()
        pts = []
        for p in req["points"]:
            pcoords = list(p) + [0.0] * (3 - len(p))
            x = [0.0, 0.0, 0.0]
            w = [0.0] * n
            cell.EvaluateLocation(vtk.reference(0), pcoords, x, w)
            pts += x
        cells.append({"type": grid.GetCellType(c), "npts": n,
                      "pcoords": [pc[i] for i in range(3 * n)], "points": pts})
    return {"cells": cells}


def vtk_ijk():
    out = {"quad": {}, "hex": {}}
    for p in range(1, 5):
        n = p + 1
        out["quad"][str(p)] = [vtk.vtkLagrangeQuadrilateral.PointIndexFromIJK(t % n, t // n, [p, p])
                               for t in range(n * n)]
        out["hex"][str(p)] = [vtk.vtkLagrangeHexahedron.PointIndexFromIJK(t % n, t // n % n, t // (n * n), [p, p, p])
                              for t in range(n ** 3)]
    return out


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    with open(sys.argv[1]) as f:
        request = json.load(f)
    gmsh.initialize(readConfigFiles=False)
    try:
        # Keep stdout clean for the JSON; errors still raise exceptions.
        gmsh.option.setNumber("General.Terminal", 0)
        report = {"gmsh_types": gmsh_types(),
                  "gmsh": [gmsh_file(r) for r in request.get("gmsh", [])]}
    finally:
        gmsh.finalize()
    report["vtk"] = [vtk_file(r) for r in request.get("vtk", [])]
    report["vtk_ijk"] = vtk_ijk()
    json.dump(report, sys.stdout)
    print()


if __name__ == "__main__":
    main()
