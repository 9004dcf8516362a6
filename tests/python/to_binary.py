#!/usr/bin/env python3
"""Re-save a mesh as binary MSH 4.1 with Gmsh: to_binary.py IN.msh OUT.msh"""
import sys, gmsh
gmsh.initialize(); gmsh.option.setNumber("General.Terminal", 0)
gmsh.open(sys.argv[1])
gmsh.option.setNumber("Mesh.MshFileVersion", 4.1); gmsh.option.setNumber("Mesh.Binary", 1)
gmsh.write(sys.argv[2]); gmsh.finalize()
