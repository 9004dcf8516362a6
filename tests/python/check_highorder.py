#!/usr/bin/env python3
"""Evaluate high-order quad/hex/prism meshes with the real Gmsh and VTK, as JSON.

Usage: check_highorder.py REQUEST.json

REQUEST holds {"gmsh": [{"file": F, "points": [[u, v(, w)], ...](,
                         "evaluate": false)}, ...],
               "vtk":  [{"file": F, "points": [[u, v(, w)], ...]}, ...]}
with Gmsh points on its reference cell ([-1,1]^d; a prism's: the unit
triangle x [-1,1]) and VTK points on its parametric cell ([0,1]^d; a
wedge's: the unit triangle x [0,1]). "evaluate": false asks Gmsh only to
read the file (Gmsh 4.15 cannot evaluate prisms of order 3 and 4).

Prints one JSON object:
  gmsh_types  {type: {"name", "dim", "order", "nodes": [reference coords of
              the local nodes, flattened, Gmsh's order]}} for the line, quad
              and hex types of order 1..4 (getElementProperties)
  gmsh        per request file: {"types": {type: count}, "physical_names":
              {dim: [names by tag]}, "cell_type", "tags", "coords": per
              element the physical points (3 per point), "dets": per element
              det J at the points (getJacobians), "minDetJac", "maxDetJac",
              "minSJ" per element (getElementQualities)}; without evaluating,
              "element_nodes" (per element the coordinates of its nodes in
              Gmsh's local order, flattened) instead of coords, dets and
              qualities
  vtk         per request file: {"cells": [{"type", "npts", "pcoords":
              [parametric coords of the cell's points, flattened],
              "points": [EvaluateLocation at each request point, xyz],
              and for 3D cells VTK's own verdict on their orientation:
              "dets": det J of VTK's map at the request points
              (InterpolateDerivs and the cell's points), "volume":
              vtkCellSizeFilter's signed volume, "validity":
              vtkCellValidator's state bits (0 valid, 32 faces oriented
              incorrectly, ...), "faces_outward": per GetFace face whether
              the normal of its corner polygon (right-hand rule) points away
              from the mean of the cell's points}]}
  vtk_ijk     {"quad": {p: [PointIndexFromIJK(i, j) for tensor index]},
               "hex": {p: [...]}} straight from vtkHigherOrder* cells
"""
import json
import sys

import gmsh
import numpy as np
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
    out = {"types": counts, "physical_names": names, "cell_type": cell_type,
           "tags": cell_tags}
    if not req.get("evaluate", True):
        _, node_tags = gmsh.model.mesh.getElementsByType(cell_type)
        per = len(node_tags) // len(cell_tags)
        xyz = [gmsh.model.mesh.getNode(t)[0] for t in node_tags]
        out["element_nodes"] = [[float(c) for x in xyz[per * e:per * (e + 1)] for c in x]
                                for e in range(len(cell_tags))]
        return out
    pts = req["points"]
    local = []
    for p in pts:
        local += list(p) + [0.0] * (3 - len(p))
    _, dets, coords = gmsh.model.mesh.getJacobians(cell_type, local)
    n, m = len(cell_tags), len(pts)
    out["coords"] = [[float(c) for c in coords[3 * m * e:3 * m * (e + 1)]] for e in range(n)]
    out["dets"] = [[float(d) for d in dets[m * e:m * (e + 1)]] for e in range(n)]
    for q in ("minDetJac", "maxDetJac", "minSJ"):
        out[q] = [float(v) for v in gmsh.model.mesh.getElementQualities(cell_tags, q)]
    return out


def cell_verdicts(grid):
    """Per cell, VTK's signed volume (vtkCellSizeFilter) and validity state
    (vtkCellValidator)."""
    size = vtk.vtkCellSizeFilter()
    size.SetInputData(grid)
    size.Update()
    volume = size.GetOutput().GetCellData().GetArray("Volume")
    validator = vtk.vtkCellValidator()
    validator.SetInputData(grid)
    validator.Update()
    state = validator.GetOutput().GetCellData().GetArray("ValidityState")
    cells = range(grid.GetNumberOfCells())
    return [volume.GetTuple1(c) for c in cells], [int(state.GetTuple1(c)) for c in cells]


def orientation(cell, points):
    """det J of VTK's own map at the parametric points, and whether each of
    the faces VTK lists turns its right-hand normal away from the cell."""
    n = cell.GetNumberOfPoints()
    x = np.array([cell.GetPoints().GetPoint(k) for k in range(n)])
    dets = []
    for p in points:
        d = [0.0] * (3 * n)
        cell.InterpolateDerivs(list(p), d)
        dets.append(float(np.linalg.det(np.array(d).reshape(3, n) @ x)))
    centre = x.mean(axis=0)
    outward = []
    for f in range(cell.GetNumberOfFaces()):
        face = cell.GetFace(f)
        corners = np.array([face.GetPoints().GetPoint(k) for k in range(face.GetNumberOfEdges())])
        normal = sum(np.cross(corners[k], corners[(k + 1) % len(corners)]) for k in range(len(corners)))
        outward.append(bool(normal @ (corners.mean(axis=0) - centre) > 0.0))
    return dets, outward


def vtk_file(req):
    reader = vtk.vtkXMLUnstructuredGridReader()
    reader.SetFileName(req["file"])
    reader.Update()
    grid = reader.GetOutput()
    volumes, states = cell_verdicts(grid)
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
        out = {"type": grid.GetCellType(c), "npts": n,
               "pcoords": [pc[i] for i in range(3 * n)], "points": pts}
        if cell.GetCellDimension() == 3:
            out["dets"], out["faces_outward"] = orientation(cell, req["points"])
            out["volume"], out["validity"] = volumes[c], states[c]
        cells.append(out)
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
