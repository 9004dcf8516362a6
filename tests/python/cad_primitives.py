#!/usr/bin/env python3
"""Small CAD models made with Gmsh's OpenCASCADE kernel, for the tests of
the CAD shapes against their exact forms. Prints nothing.

Usage:
  cad_primitives.py shapes OUT.step
      a cylinder of radius 0.5 about the z axis over 0 <= z <= 1 and a
      sphere of radius 0.3 at (2, 0, 0.5)
  cad_primitives.py disk OUT.step OUT.msh
      the square [-2, 2]^2 minus the disk of radius 0.5 (z = 0), then, as a
      user would, that STEP opened again and meshed with quads (size 0.2,
      Frontal-Delaunay for quads, recombined) into OUT.msh (MSH 4.1, no
      physical groups: every entity's elements are saved)"""
import os
import sys

import gmsh

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from check_cad import write_quietly  # noqa: E402

gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
occ = gmsh.model.occ
if sys.argv[1] == "shapes":
    occ.addCylinder(0, 0, 0, 0, 0, 1, 0.5)
    occ.addSphere(2, 0, 0.5, 0.3)
    occ.synchronize()
    write_quietly(sys.argv[2])
else:
    square = occ.addRectangle(-2, -2, 0, 4, 4)
    disk = occ.addDisk(0, 0, 0, 0.5, 0.5)
    occ.cut([(2, square)], [(2, disk)])
    occ.synchronize()
    write_quietly(sys.argv[2])
    gmsh.clear()
    gmsh.open(sys.argv[2])
    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.2)
    gmsh.option.setNumber("Mesh.Algorithm", 8)
    gmsh.option.setNumber("Mesh.RecombineAll", 1)
    gmsh.model.mesh.generate(2)
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.write(sys.argv[3])
gmsh.finalize()
