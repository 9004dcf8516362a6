#!/usr/bin/env python3
"""Writes OUT.step: a cylinder of radius 0.5 about the z axis over
0 <= z <= 1 and a sphere of radius 0.3 at (2, 0, 0.5), made with Gmsh's
OpenCASCADE kernel, for the tests of the CAD shapes against their exact
forms. Prints nothing.

Usage: cad_primitives.py OUT.step"""
import sys
import gmsh

gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
gmsh.model.occ.addCylinder(0, 0, 0, 0, 0, 1, 0.5)
gmsh.model.occ.addSphere(2, 0, 0.5, 0.3)
gmsh.model.occ.synchronize()
gmsh.write(sys.argv[1])
gmsh.finalize()
