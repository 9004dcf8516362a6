#!/usr/bin/env python3
"""Read a .vtu file with VTK's own XML reader and print what VTK sees, as JSON.

Usage: check_vtu.py FILE

Prints one JSON object:
  num_points, num_cells
  cell_types     VTK cell type of every cell
  cell_arrays    {name: number of components} of the CellData arrays
  point_arrays   {name: number of components} of the PointData arrays
  cells          for every cell, the [x, y, z] of its points in order
Exits non-zero if VTK reports an error while reading.
"""
import json
import sys

import vtk


def arrays(data):
    """Name -> number of components of every array in a vtkDataSetAttributes."""
    out = {}
    for i in range(data.GetNumberOfArrays()):
        a = data.GetArray(i)
        out[a.GetName()] = a.GetNumberOfComponents()
    return out


def read(path):
    """The grid, or exit with VTK's error: VTK only logs errors by default."""
    errors = []
    reader = vtk.vtkXMLUnstructuredGridReader()
    reader.AddObserver("ErrorEvent", lambda obj, ev: errors.append(ev))
    reader.GetExecutive().AddObserver("ErrorEvent", lambda obj, ev: errors.append(ev))
    reader.SetFileName(path)
    reader.Update()
    if errors or reader.GetErrorCode() != 0:
        sys.exit(f"VTK could not read {path}")
    return reader.GetOutput()


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    grid = read(sys.argv[1])
    points = grid.GetPoints()
    cells = []
    types = []
    for c in range(grid.GetNumberOfCells()):
        cell = grid.GetCell(c)
        types.append(cell.GetCellType())
        ids = cell.GetPointIds()
        cells.append([list(points.GetPoint(ids.GetId(k))) for k in range(ids.GetNumberOfIds())])
    report = {
        "num_points": grid.GetNumberOfPoints(),
        "num_cells": grid.GetNumberOfCells(),
        "cell_types": types,
        "cell_arrays": arrays(grid.GetCellData()),
        "point_arrays": arrays(grid.GetPointData()),
        "cells": cells,
    }
    json.dump(report, sys.stdout)
    print()


if __name__ == "__main__":
    main()
