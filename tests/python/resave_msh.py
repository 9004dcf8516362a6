#!/usr/bin/env python3
"""Open a mesh file with Gmsh and write it again as ASCII MSH 4.1 and as
ASCII MSH 2.2 (Mesh.MshFileVersion), from the same loaded model: twins
that hold the same mesh in the two formats.

Usage: resave_msh.py IN.msh OUT41.msh OUT22.msh"""
import sys

import gmsh

if len(sys.argv) != 4:
    sys.exit(__doc__)
gmsh.initialize(readConfigFiles=False)
try:
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.option.setNumber("Mesh.Binary", 0)
    gmsh.open(sys.argv[1])
    for version, out in [(4.1, sys.argv[2]), (2.2, sys.argv[3])]:
        gmsh.option.setNumber("Mesh.MshFileVersion", version)
        gmsh.write(out)
finally:
    gmsh.finalize()
