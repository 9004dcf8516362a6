"""The meshes of benches/level_sets.sh, made by Gmsh (MSH 4.1), and their
geometry files: each surface bound once by a built-in shape and once by
the same surface as a level set.

  hollow_cylinder.msh  the annulus 0.5 <= r <= 1 extruded along z over
                       [0, 1]: 32 x 6 x 6 = 1,152 hexes (transfinite,
                       recombined); groups inner, outer, bottom, top, solid
  torus.msh            the solid torus (sqrt(x^2 + y^2) - 1)^2 + z^2 <= 0.25
                       (R = 1, r = 0.5): an O-grid disk of 64 quads (a 4 x 4
                       square and four 4 x 3 blocks) revolved in 40 steps,
                       2,560 hexes; groups surface, solid

Usage: python level_sets_meshes.py OUT_DIR"""
import math
import os
import sys

import gmsh
from ogrid import ogrid_disk

out = sys.argv[1]
os.makedirs(out, exist_ok=True)


def start(name):
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.option.setNumber("Mesh.SaveAll", 0)
    gmsh.model.add(name)


def hollow_cylinder(path, around=32, radial=6, axial=6, r0=0.5, r1=1.0):
    start("hollow_cylinder")
    g = gmsh.model.geo
    c = g.addPoint(0, 0, 0)
    pin = [g.addPoint(r0 * math.cos(k * math.pi / 2), r0 * math.sin(k * math.pi / 2), 0) for k in range(4)]
    pout = [g.addPoint(r1 * math.cos(k * math.pi / 2), r1 * math.sin(k * math.pi / 2), 0) for k in range(4)]
    ain = [g.addCircleArc(pin[k], c, pin[(k + 1) % 4]) for k in range(4)]
    aout = [g.addCircleArc(pout[k], c, pout[(k + 1) % 4]) for k in range(4)]
    rad = [g.addLine(pin[k], pout[k]) for k in range(4)]
    faces = []
    for k in range(4):
        loop = g.addCurveLoop([rad[k], aout[k], -rad[(k + 1) % 4], -ain[k]])
        faces.append(g.addPlaneSurface([loop]))
    for a in ain + aout:
        g.mesh.setTransfiniteCurve(a, around // 4 + 1)
    for l in rad:
        g.mesh.setTransfiniteCurve(l, radial + 1)
    for s in faces:
        g.mesh.setTransfiniteSurface(s)
        g.mesh.setRecombine(2, s)
    ex = g.extrude([(2, s) for s in faces], 0, 0, 1.0, numElements=[axial], recombine=True)
    g.synchronize()
    # per face: top, volume, then the four sides in the loop's order
    # (rad[k], aout[k], rad[k+1], ain[k])
    tops, vols, inner, outer = [], [], [], []
    for k in range(4):
        block = ex[6 * k:6 * k + 6]
        tops.append(block[0][1])
        vols.append(block[1][1])
        outer.append(block[3][1])
        inner.append(block[5][1])
    gmsh.model.addPhysicalGroup(2, inner, name="inner")
    gmsh.model.addPhysicalGroup(2, outer, name="outer")
    gmsh.model.addPhysicalGroup(2, faces, name="bottom")
    gmsh.model.addPhysicalGroup(2, tops, name="top")
    gmsh.model.addPhysicalGroup(3, vols, name="solid")
    gmsh.model.mesh.generate(3)
    gmsh.write(path)
    gmsh.finalize()


def torus(path, around=40, centre=4, ring=3, R=1.0, r=0.5):
    """The cross-section in the (x, z) half-plane x > 0, centred at (R, 0):
    a square of half-width r/2.5 (centre x centre quads) and four blocks out
    to the circle of radius r (centre x ring quads), revolved about z."""
    start("torus")
    g = gmsh.model.geo
    c = g.addPoint(R, 0, 0)
    faces, _ = ogrid_disk(g, lambda u, v: (R + u, 0, v), c, r / 2.5, r, centre, ring)
    # four quarter turns (Gmsh revolves by less than pi at a time)
    surf, vols, base = [], [], [(2, s) for s in faces]
    for q in range(4):
        ex = g.revolve(base, 0, 0, 0, 0, 0, 1, math.pi / 2, numElements=[around // 4], recombine=True)
        # per face: its image, the volume, then its sides; the outer arc's
        # side is the one of loop position 1 in the four blocks
        base = []
        i = 0
        for j, s in enumerate(faces):
            nsides = 4
            block = ex[i:i + 2 + nsides]
            base.append(block[0])
            vols.append(block[1][1])
            if j > 0:
                surf.append(block[3][1])
            i += 2 + nsides
    g.synchronize()
    gmsh.model.addPhysicalGroup(2, surf, name="surface")
    gmsh.model.addPhysicalGroup(3, vols, name="solid")
    gmsh.option.setNumber("Geometry.Tolerance", 1e-10)
    g.removeAllDuplicates()
    gmsh.model.mesh.generate(3)
    gmsh.model.mesh.removeDuplicateNodes()
    gmsh.write(path)
    gmsh.finalize()


GEOMETRY = {
    "hollow_cylinder.shapes.toml": """# benches/level_sets.sh: the hollow cylinder bound by built-in shapes
[[group]]
name = "inner"
kind = "curve"
shape = { type = "cylinder", point = [0.0, 0.0, 0.0], axis = [0.0, 0.0, 1.0], radius = 0.5 }
[[group]]
name = "outer"
kind = "curve"
shape = { type = "cylinder", point = [0.0, 0.0, 0.0], axis = [0.0, 0.0, 1.0], radius = 1.0 }
[[group]]
name = "bottom"
kind = "slip"
[[group]]
name = "top"
kind = "slip"
""",
    "hollow_cylinder.level_sets.toml": """# benches/level_sets.sh: the hollow cylinder bound by the same surfaces as level sets
[[group]]
name = "inner"
kind = "curve"
level_set = "x^2 + y^2 - 0.25"
[[group]]
name = "outer"
kind = "curve"
level_set = "x^2 + y^2 - 1"
[[group]]
name = "bottom"
kind = "slip"
[[group]]
name = "top"
kind = "slip"
""",
    "torus.level_sets.toml": """# benches/level_sets.sh: the solid torus R = 1, r = 0.5 as a level set
[[group]]
name = "surface"
kind = "curve"
level_set = "(sqrt(x^2 + y^2) - 1)^2 + z^2 - 0.25"
""",
}

hollow_cylinder(os.path.join(out, "hollow_cylinder.msh"))
torus(os.path.join(out, "torus.msh"))
for name, text in GEOMETRY.items():
    with open(os.path.join(out, name), "w") as f:
        f.write(text)
