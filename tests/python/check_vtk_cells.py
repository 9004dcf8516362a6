#!/usr/bin/env python3
"""Judge the cells of a VTU independently of deformesh: read FILE with VTK's
own XML reader and, for every cell, evaluate det J of the cell's map at a
lattice of parametric points, J from the cell's point coordinates and VTK's
own shape-function derivatives (vtkCell::InterpolateDerivs), for the linear,
quadratic and Lagrange tetrahedra, wedges, hexahedra, pyramids, triangles
and quadrilaterals (vtkLagrangeTetra 71, vtkLagrangeHexahedron 72,
vtkLagrangeWedge 73, vtkLagrangeTriangle 69, vtkLagrangeQuadrilateral 70,
...). The lattice has N points an edge of the cell's parametric domain
(simplices: i + j (+ k) <= N - 1; wedges: triangle x line; pyramids: the
unit cube with t = k / N, k < N, as every pyramid's det J is 0 at its apex).
The derivatives depend only on the cell type and its point count, so VTK
evaluates them once per (type, point count, HigherOrderDegrees) on the
first such cell of the file; --per-cell asks each cell instead (slow).

Which sign is valid, per cell type, decided by VTK's own code at run time:
VTK's reference cell of the type (its points at GetParametricCoords) maps
its parametric domain onto itself, so its det J is +1 (a pyramid's
collapsed cube: (1 - t)^2; checked > 0 on the lattice); VTK calls
that cell well oriented iff the faces it gives (vtkCell::GetFace, corner
points, right-hand rule) point out of it and vtkCellValidator finds no
FacesAreOrientedIncorrectly on it. Then the valid sign is +1, else -1 (both
must agree). 2D cells: in a plane z = const, the valid sign is that of VTK's
reference cell (counter-clockwise seen from +z), det J over (x, y);
otherwise the area element |dx/dr x dx/ds| (orientation-free). Vertices,
lines and other cells are counted as skipped.

Prints one JSON object: {"file", "samples", "types": {VTK type: {"name",
"cells", "invalid" (cells with any sampled normalised det J <= 0),
"min_det", "max_det" (normalised: sign * det J, over the samples),
"valid_sign", "sign_reason", "measure", "derivs_layout", "first_invalid"
(the first 10 invalid cells' ids, all with --all-invalid)}}, "overall":
{"cells", "invalid", "min_det", "max_det", "skipped"}}. InterpolateDerivs
lays the derivatives out as dim rows of npts for most cells but as npts
rows of dim for VTK 9.7's Lagrange hexahedra and quadrilaterals: the
layout is decided per type against central differences of VTK's own
EvaluateLocation ("derivs_layout").
Exit status 1 when a cell is invalid, 2 when VTK cannot read FILE.

--selftest needs no file: for each cell type (linear, Lagrange of order 1
to 3) it writes and reads back a VTU holding VTK's reference cell bent
smoothly (valid) and its mirror image (inside out), checks the checker
finds exactly the mirror invalid, and prints the sign found per type.

Usage: python check_vtk_cells.py FILE.vtu [--samples N] [--per-cell] [--all-invalid]
       python check_vtk_cells.py --selftest"""
import argparse
import json
import sys

import numpy as np
import vtk
from vtk.util.numpy_support import vtk_to_numpy

CELL_TYPES = getattr(vtk, "vtkCellTypeUtilities", vtk.vtkCellTypes)  # VTK >= 9.6 / before


def cell_types(grid):
    """The grid's cell types as a numpy array (VTK 9.6 renamed the getter)."""
    try:
        return vtk_to_numpy(grid.GetCellTypes())
    except TypeError:
        return vtk_to_numpy(grid.GetCellTypesArray())


def read(path):
    """The grid, or exit 2 with VTK's error: VTK only logs errors by default."""
    errors = []
    reader = vtk.vtkXMLUnstructuredGridReader()
    reader.AddObserver("ErrorEvent", lambda obj, ev: errors.append(ev))
    reader.GetExecutive().AddObserver("ErrorEvent", lambda obj, ev: errors.append(ev))
    reader.SetFileName(path)
    reader.Update()
    if errors or reader.GetErrorCode() != 0:
        print(f"VTK could not read {path}", file=sys.stderr)
        raise SystemExit(2)
    return reader.GetOutput()


def family(cell):
    """The parametric domain of a VTK cell, from its dimension and its edge
    and face counts: tetra, wedge, pyramid, hexahedron, triangle, quad."""
    dim, ne = cell.GetCellDimension(), cell.GetNumberOfEdges()
    if dim == 3:
        return {(4, 6): "tetra", (5, 9): "wedge", (5, 8): "pyramid", (6, 12): "hexahedron"}.get((cell.GetNumberOfFaces(), ne))
    if dim == 2:
        return {3: "triangle", 4: "quad"}.get(ne)
    return None


def lattice(fam, n):
    """Parametric sample points (VTK's domains: [0, 1] based) of a family."""
    m = n - 1 if n > 1 else 1
    u = [k / m for k in range(n)] if n > 1 else [1 / 3]
    if fam == "tetra":
        return [(i / m, j / m, k / m) for k in range(n) for j in range(n - k) for i in range(n - j - k)] if n > 1 else [(0.25,) * 3]
    if fam == "wedge":
        tri = [(i / m, j / m) for j in range(n) for i in range(n - j)] if n > 1 else [(1 / 3, 1 / 3)]
        return [(r, s, t) for t in (u if n > 1 else [0.5]) for r, s in tri]
    if fam == "pyramid":
        return [(r, s, k / n) for k in range(n) for s in (u if n > 1 else [0.5]) for r in (u if n > 1 else [0.5])]
    if fam == "hexahedron":
        c = u if n > 1 else [0.5]
        return [(r, s, t) for t in c for s in c for r in c]
    if fam == "triangle":
        return [(i / m, j / m, 0.0) for j in range(n) for i in range(n - j)] if n > 1 else [(1 / 3, 1 / 3, 0.0)]
    if fam == "quad":
        c = u if n > 1 else [0.5]
        return [(r, s, 0.0) for s in c for r in c]
    raise ValueError(fam)


def derivs(cell, pcoords, point_major=False):
    """VTK's shape-function derivatives of `cell` at the points: array
    (samples, dim, points), d N_i / d r_a, from vtkCell::InterpolateDerivs.
    Most cells lay them out as dim rows of npts; VTK 9.7's Lagrange
    hexahedra and quadrilaterals as npts rows of dim (point_major): see
    derivs_layout."""
    npts, dim = cell.GetNumberOfPoints(), cell.GetCellDimension()
    out = np.empty((len(pcoords), dim, npts))
    buf = [0.0] * (dim * npts)
    for q, pc in enumerate(pcoords):
        cell.InterpolateDerivs(list(pc), buf)
        out[q] = np.reshape(buf, (npts, dim)).T if point_major else np.reshape(buf, (dim, npts))
    return out


def derivs_layout(ctype, npts):
    """True when InterpolateDerivs of this cell type lays its derivatives out
    point by point: decided against VTK's own map, by central differences of
    vtkCell::EvaluateLocation on VTK's reference cell bent smoothly."""
    cell, ref = reference_cell(ctype, npts)
    dim = cell.GetCellDimension()
    cell, _ = reference_cell(ctype, npts, [bend(p, dim) for p in ref])
    pc, h = (0.21, 0.17, 0.33 if dim == 3 else 0.0), 1e-6
    weights = [0.0] * npts

    def at(p):
        x = [0.0, 0.0, 0.0]
        cell.EvaluateLocation(vtk.reference(0), list(p), x, weights)
        return np.array(x)

    fd = np.array([(at(np.add(pc, h * np.eye(3)[a])) - at(np.subtract(pc, h * np.eye(3)[a]))) / (2 * h) for a in range(dim)])
    x = np.array([cell.GetPoints().GetPoint(i) for i in range(npts)])
    err = {pm: np.abs(derivs(cell, [pc], pm)[0] @ x - fd).max() for pm in (False, True)}
    best = min(err, key=err.get)
    if err[best] > 1e-6:
        raise SystemExit(f"VTK type {ctype} ({npts} points): InterpolateDerivs matches EvaluateLocation in no layout ({err})")
    return best


def dets(d, x, measure):
    """det J per cell and sample: d (samples, dim, npts) derivatives, x
    (cells, npts, 3) points; J[c, q, a, b] = d x_b / d r_a."""
    J = np.einsum("qan,cnb->cqab", d, x)
    if measure == "volume":
        return np.linalg.det(J)
    if measure == "xy":
        return np.linalg.det(J[..., :2])
    return np.linalg.norm(np.cross(J[..., 0, :], J[..., 1, :]), axis=-1)  # "area"


def one_cell_grid(ctype, points):
    grid = vtk.vtkUnstructuredGrid()
    pts = vtk.vtkPoints()
    pts.SetDataTypeToDouble()
    for p in points:
        pts.InsertNextPoint(*p)
    grid.SetPoints(pts)
    ids = vtk.vtkIdList()
    for i in range(len(points)):
        ids.InsertNextId(i)
    grid.InsertNextCell(ctype, ids)
    return grid


def reference_cell(ctype, npts, points=None):
    """VTK's cell of type ctype with npts points placed at its own
    parametric coordinates (or at `points`), as a vtkGenericCell, and its
    parametric coordinates."""
    cell = vtk.vtkGenericCell()
    one_cell_grid(ctype, [(0.0, 0.0, 0.0)] * npts).GetCell(0, cell)
    pc = cell.GetParametricCoords()
    ref = [tuple(pc[3 * i + k] for k in range(3)) for i in range(npts)]
    cell = vtk.vtkGenericCell()
    one_cell_grid(ctype, ref if points is None else points).GetCell(0, cell)
    return cell, np.array(ref)


def valid_sign(ctype, npts, fam, samples, point_major):
    """(+1 or -1, reason): the sign of det J that VTK's own orientation
    judges call valid for cells of this type (see the module's doc)."""
    cell, ref = reference_cell(ctype, npts)
    d = derivs(cell, lattice(fam, samples), point_major)
    dim = cell.GetCellDimension()
    det = np.linalg.det(np.einsum("qan,nb->qab", d, ref)[..., :dim])
    # +1 (the identity map), but a pyramid's collapsed cube: (1 - t)^2
    what = "det J = +1" if np.abs(det - 1).max() < 1e-9 else f"det J in [{det.min():.3g}, {det.max():.3g}]"
    if det.min() <= 0:
        raise SystemExit(f"VTK type {ctype} ({npts} points): the reference cell has {what}")
    if dim == 2:
        return 1, f"reference cell {what}, counter-clockwise seen from +z (its right-hand normal)"
    centre = ref.mean(axis=0)
    out = inward = 0
    for f in range(cell.GetNumberOfFaces()):
        face = cell.GetFace(f)
        k = 3 if family(face) == "triangle" else 4
        corners = np.array([face.GetPoints().GetPoint(i) for i in range(k)])
        normal = sum(np.cross(corners[i], corners[(i + 1) % k]) for i in range(k))
        if np.dot(normal, corners.mean(axis=0) - centre) > 0:
            out += 1
        else:
            inward += 1
    state = vtk.vtkCellValidator.Check(cell, 1e-9)
    faces_ok = state & 32 == 0  # vtkCellValidator::State::FacesAreOrientedIncorrectly
    if inward == 0 and faces_ok:
        return 1, (f"reference cell {what}; its {out} faces (GetFace) point outward and "
                   f"vtkCellValidator finds it valid (state {state})")
    if out == 0 and not faces_ok:
        return -1, (f"reference cell {what} but its {inward} faces point inward and "
                    f"vtkCellValidator finds FacesAreOrientedIncorrectly (state {state})")
    raise SystemExit(f"VTK type {ctype}: faces {out} out / {inward} in, validator state {state}: no consistent sign")


def check(grid, samples, per_cell=False, list_all=False):
    """The report (see the module's doc) for a vtkUnstructuredGrid."""
    n = grid.GetNumberOfCells()
    x = vtk_to_numpy(grid.GetPoints().GetData()).astype(float) if n else np.zeros((0, 3))
    types = cell_types(grid) if n else np.zeros(0, int)
    offsets = vtk_to_numpy(grid.GetCells().GetOffsetsArray()) if n else np.zeros(1, int)
    conn = vtk_to_numpy(grid.GetCells().GetConnectivityArray()) if n else np.zeros(0, int)
    degrees = grid.GetCellData().GetArray("HigherOrderDegrees")
    groups = {}
    for c in range(n):
        key = (int(types[c]), int(offsets[c + 1] - offsets[c]),
               tuple(degrees.GetTuple(c)) if degrees is not None else ())
        groups.setdefault(key, []).append(c)
    dim = max((CELL_TYPES.GetDimension(int(t)) for t in set(types.tolist())), default=0)
    report, skipped = {}, 0
    cell = vtk.vtkGenericCell()
    for (ctype, npts, _), ids in sorted(groups.items()):
        grid.GetCell(ids[0], cell)
        fam = family(cell)
        entry = report.setdefault(str(ctype), {"name": CELL_TYPES.GetClassNameFromTypeId(ctype), "cells": 0, "invalid": 0, "min_det": None, "max_det": None})
        entry["cells"] += len(ids)
        if fam is None:
            entry["skipped"] = entry.get("skipped", 0) + len(ids)
            skipped += len(ids)
            continue
        pcs = lattice(fam, samples)
        pts = np.stack([x[conn[offsets[c]:offsets[c + 1]]] for c in ids])
        if cell.GetCellDimension() == 3:
            measure = "volume"
        elif dim == 2 and np.ptp(pts[..., 2]) <= 1e-12 * max(1.0, np.abs(pts).max()):
            measure = "xy"
        else:
            measure = "area"
        pm = derivs_layout(ctype, npts)
        sign, reason = valid_sign(ctype, npts, fam, samples, pm) if measure != "area" else (1, "area element, no orientation")
        if per_cell:
            det = np.empty((len(ids), len(pcs)))
            for k, c in enumerate(ids):
                grid.GetCell(c, cell)
                det[k] = dets(derivs(cell, pcs, pm), pts[k:k + 1], measure)[0]
        else:
            det = dets(derivs(cell, pcs, pm), pts, measure)
        det = sign * det
        bad = (det <= 0).any(axis=1)
        entry["invalid"] += int(bad.sum())
        lo, hi = float(det.min()), float(det.max())
        entry["min_det"] = lo if entry["min_det"] is None else min(entry["min_det"], lo)
        entry["max_det"] = hi if entry["max_det"] is None else max(entry["max_det"], hi)
        entry["valid_sign"], entry["sign_reason"], entry["measure"] = sign, reason, measure
        entry["derivs_layout"] = "npts rows of dim" if pm else "dim rows of npts"
        first = entry.setdefault("first_invalid", [])
        first += [int(ids[k]) for k in np.flatnonzero(bad)[:(None if list_all else 10 - len(first))]]
    judged = [e for e in report.values() if e["min_det"] is not None]
    overall = {"cells": n, "invalid": sum(e["invalid"] for e in report.values()),
               "min_det": min((e["min_det"] for e in judged), default=None),
               "max_det": max((e["max_det"] for e in judged), default=None), "skipped": skipped}
    return {"samples": samples, "types": report, "overall": overall}


def bend(p, dim):
    """A smooth map close to the identity (keeps a reference cell valid)."""
    x, y, z = p
    if dim == 2:
        return (x + 0.05 * np.sin(3 * y), y + 0.05 * np.sin(2 * x), 0.0)
    return (x + 0.05 * np.sin(3 * y + z), y + 0.05 * np.sin(2 * z + x), z + 0.05 * np.sin(2 * x - y))


def selftest(samples):
    import os
    import tempfile

    cases = [(10, 4), (12, 8), (13, 6), (14, 5), (5, 3), (9, 4)]
    for p in (1, 2, 3):
        cases += [(71, (p + 1) * (p + 2) * (p + 3) // 6), (72, (p + 1) ** 3), (73, (p + 1) ** 2 * (p + 2) // 2),
                  (69, (p + 1) * (p + 2) // 2), (70, (p + 1) ** 2)]
    results, ok = {}, True
    with tempfile.TemporaryDirectory() as tmp:
        for ctype, npts in cases:
            _, ref = reference_cell(ctype, npts)
            dim = CELL_TYPES.GetDimension(ctype)
            good = [bend(p, dim) for p in ref]
            mirror = [(-a, b, c) for a, b, c in good]  # a reflection: the same points, inside out
            grid = vtk.vtkUnstructuredGrid()
            pts = vtk.vtkPoints()
            pts.SetDataTypeToDouble()
            for p in good + mirror:
                pts.InsertNextPoint(*p)
            grid.SetPoints(pts)
            for base in (0, npts):
                ids = vtk.vtkIdList()
                for i in range(npts):
                    ids.InsertNextId(base + i)
                grid.InsertNextCell(ctype, ids)
            path = os.path.join(tmp, f"{ctype}_{npts}.vtu")
            w = vtk.vtkXMLUnstructuredGridWriter()
            w.SetFileName(path)
            w.SetInputData(grid)
            w.Write()
            r = check(read(path), samples)
            e = r["types"][str(ctype)]
            r2 = check(read(path), samples, per_cell=True)["types"][str(ctype)]
            passed = e["invalid"] == 1 and e["first_invalid"] == [1] and e["min_det"] == r2["min_det"] and e["max_det"] == r2["max_det"]
            ok &= passed
            results[f"{ctype}/{npts}"] = {"name": e["name"], "valid_sign": e["valid_sign"], "derivs_layout": e["derivs_layout"], "invalid": e["invalid"],
                                          "first_invalid": e["first_invalid"], "passed": passed}
    print(json.dumps({"selftest": results, "passed": bool(ok)}))
    return 0 if ok else 1


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("file", nargs="?")
    ap.add_argument("--samples", type=int, default=5, help="lattice points an edge (default 5)")
    ap.add_argument("--per-cell", action="store_true", help="ask VTK for the derivatives cell by cell")
    ap.add_argument("--all-invalid", action="store_true", help="list every invalid cell in first_invalid, not 10")
    ap.add_argument("--selftest", action="store_true")
    a = ap.parse_args()
    if a.selftest:
        raise SystemExit(selftest(a.samples))
    if not a.file:
        ap.error("FILE is required")
    report = {"file": a.file, **check(read(a.file), a.samples, a.per_cell, a.all_invalid)}
    print(json.dumps(report))
    raise SystemExit(1 if report["overall"]["invalid"] else 0)


if __name__ == "__main__":
    main()
