#!/usr/bin/env python3
"""Gmsh's quality figures of a few p = 2 prisms (MSH type 13, 18 nodes).

Usage: prism_qualities.py [OUTDIR]

The prisms are those of `gmsh_prisms` in src/quality/prism.rs, built from
the same formulas of our reference coordinates (unit triangle x [0,1]) at
Gmsh's own reference nodes (getElementProperties(13): unit triangle x
[-1,1], so z = (w + 1) / 2), written to OUTDIR/NAME.msh (default /tmp),
read back, and measured with getElementQualities. Prints one line per
prism: minDetJac maxDetJac minSJ minSIGE minSICN. The Rust test
`gmsh_figures_of_p2_prisms` holds the values Gmsh 4.15.2 printed.
"""
import math
import sys

import gmsh


def affine(x):
    a = [[2.0, 0.5, 0.0], [0.0, 1.5, 0.25], [0.5, 0.0, 0.75]]
    t = [1.0, 2.0, 3.0]
    return [sum(a[r][c] * x[c] for c in range(3)) + t[r] for r in range(3)]


def equilateral(x):
    return [x[0] + 0.5 * x[1], math.sqrt(0.75) * x[1], 0.4 * x[2]]


def curved(x):
    u, v, w = x
    return [u + 0.15 * v * v - 0.1 * w * w, v + 0.2 * u * w, w + 0.1 * u * v + 0.05 * (u + v) * (u + v)]


def bent(x):
    u, v, w = x
    return [u + 0.3 * u * v * (1.0 - w), v + 0.25 * u * u - 0.2 * v * w, 0.8 * w + 0.3 * u * v]


def twisted(x):
    m, h, th, t = [[1.3, 0.4], [-0.2, 0.9]], 0.7, math.radians(100.0), [0.3, -0.2]
    c, s = math.cos(th), math.sin(th)
    b = [m[0][0] * x[0] + m[0][1] * x[1], m[1][0] * x[0] + m[1][1] * x[1]]
    top = [c * b[0] - s * b[1] + t[0], s * b[0] + c * b[1] + t[1]]
    z = x[2]
    return [(1 - z) * b[0] + z * top[0], (1 - z) * b[1] + z * top[1], h * z]


def pulled(x):
    # the bottom hypotenuse node (1/2, 1/2, 0) pulled towards the axis (lam = 0.75)
    if x == [0.5, 0.5, 0.0]:
        return [0.5 - 0.75 * 0.46875, 0.5 - 0.75 * 0.4375, 0.0]
    return list(x)


def wavy(x):
    u, v, w = x
    return [u + 0.12 * math.sin(3.0 * v + 2.0 * w), v + 0.1 * math.sin(2.5 * u - w), 0.6 * w + 0.08 * math.cos(2.0 * u + 3.0 * v)]


MAPS = {"affine": affine, "equilateral": equilateral, "curved": curved, "bent": bent, "twisted": twisted, "pulled": pulled, "wavy": wavy}


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "/tmp"
    gmsh.initialize()
    gmsh.option.setNumber("General.Verbosity", 0)
    _, _, _, nn, local, _ = gmsh.model.mesh.getElementProperties(13)
    ref = [[local[3 * i], local[3 * i + 1], (local[3 * i + 2] + 1.0) / 2.0] for i in range(nn)]
    for key, f in MAPS.items():
        gmsh.clear()
        gmsh.model.add(key)
        tag = gmsh.model.addDiscreteEntity(3)
        gmsh.model.mesh.addNodes(3, tag, list(range(1, nn + 1)), [c for x in ref for c in f(x)])
        gmsh.model.mesh.addElementsByType(tag, 13, [1], list(range(1, nn + 1)))
        path = f"{out}/{key}.msh"
        gmsh.write(path)
        gmsh.clear()
        gmsh.open(path)
        tags = list(gmsh.model.mesh.getElementsByType(13)[0])
        q = {m: gmsh.model.mesh.getElementQualities(tags, m)[0] for m in ("minDetJac", "maxDetJac", "minSJ", "minSIGE", "minSICN")}
        print(key, " ".join(f"{m} {v:.15g}" for m, v in q.items()))
    gmsh.finalize()


if __name__ == "__main__":
    main()
