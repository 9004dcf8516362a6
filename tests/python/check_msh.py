#!/usr/bin/env python3
"""Open a mesh file with the Gmsh API and print what Gmsh sees, as JSON.

Usage: check_msh.py FILE

Prints one JSON object:
  num_nodes        number of nodes Gmsh loaded
  element_types    {type number: {"name": ..., "count": ...}} over all dims
  physical_names   {dim: [names, in order of physical tag]}
  elements_2d      {"tags": [...], "types": [...], "minDetJac": [...],
                    "maxDetJac": [...], "minSJ": [...], "minSIGE": [...],
                    "sampledSJ": [...], "elements_by_type": {...}}, over
                   every 2D element whatever its type (a mixed mesh of
                   quadrangles and triangles: both blocks), ordered by
                   element tag; types the MSH type number of each;
                   minSJ is Gmsh's lower bound, sampledMinDet the least
                   det J of Gmsh's getJacobians on the points below,
                   sampledSJ the least
                   signed det J / (|dx/du| |dx/dv| (|dx/dw|)) of Gmsh's
                   own Jacobians on the points of the reference element
                   of spacing 1 / (3p) (corners included: (3p + 1)^dim for
                   quads and hexes, the simplex lattice for triangles and
                   tets, the triangle's times the line's for prisms, the
                   pyramid's layers without its apex for pyramids, where the ratio is the raw one on Gmsh's
                   right-angled reference: an equilateral triangle gives
                   sin 60 degrees); elements_by_type {type number: {"name",
                   "count", "invalid" (minDetJac <= 0), "minSJ",
                   "minSIGE" (the least of each)}}
  elements_3d      the same for the 3D elements (empty lists for a 2D mesh)
Exits non-zero (with Gmsh's message on stderr) if Gmsh cannot read FILE.
"""
import json
import sys

import gmsh


def element_types():
    """Element counts per type over the whole model."""
    types, tags, _ = gmsh.model.mesh.getElements()
    out = {}
    for t, ts in zip(types, tags):
        name = gmsh.model.mesh.getElementProperties(t)[0]
        out[str(int(t))] = {"name": name, "count": len(ts)}
    return out


def physical_names():
    """Names of the physical groups, per dimension, by tag."""
    out = {}
    for dim, tag in sorted(gmsh.model.getPhysicalGroups()):
        out.setdefault(str(dim), []).append(gmsh.model.getPhysicalName(dim, tag))
    return out


def elements(dim):
    """Jacobian-based qualities of every element of dimension dim (of
    every type), by tag."""
    types, tags, _ = gmsh.model.mesh.getElements(dim=dim)
    type_of = {int(t): int(ty) for ty, ts in zip(types, tags) for t in ts}
    all_tags = sorted(type_of)
    out = {"tags": all_tags, "types": [type_of[t] for t in all_tags]}
    for quality in ("minDetJac", "maxDetJac", "minSJ", "minSIGE"):
        values = gmsh.model.mesh.getElementQualities(all_tags, quality) if all_tags else []
        out[quality] = [float(v) for v in values]
    out["sampledSJ"], out["sampledMinDet"] = sampled_sj(dim, all_tags)
    by_type = {}
    for k, ty in enumerate(out["types"]):
        b = by_type.setdefault(str(ty), {"name": gmsh.model.mesh.getElementProperties(ty)[0], "count": 0, "invalid": 0,
                                         "minSJ": float("inf"), "minSIGE": float("inf")})
        b["count"] += 1
        b["invalid"] += out["minDetJac"][k] <= 0
        b["minSJ"] = min(b["minSJ"], out["minSJ"][k])
        b["minSIGE"] = min(b["minSIGE"], out["minSIGE"][k])
    out["elements_by_type"] = by_type
    return out


def reference_points(t):
    """The points of spacing 1 / (3p) on the reference element of Gmsh's
    type t: [-1, 1]^dim for quads and hexes, the unit simplex for
    triangles and tets (as Gmsh's getJacobians takes them, 3 per point)."""
    import numpy as np

    _, dim, order, nn, _, nv = gmsh.model.mesh.getElementProperties(t)
    m = 3 * order
    if nv == dim + 1:  # a simplex
        pts = [p for p in np.ndindex(*([m + 1] * dim)) if sum(p) <= m]
        grid = np.array(pts, dtype=float) / m
    elif nv == 6:  # a prism: the triangle's lattice times [-1, 1]
        tri = [(i / m, j / m) for i, j in np.ndindex(m + 1, m + 1) if i + j <= m]
        grid = np.array([(u, v, w) for u, v in tri for w in np.linspace(-1.0, 1.0, m + 1)])
    elif nv == 5:  # a pyramid: its layers, the apex (no single J) left out
        # 1e-9 in from the sides: Gmsh 4.15's GradLagrange of a pyramid
        # jumps by 1e-3 relative within a few ulps of a side (at z = 1/3,
        # p = 3: 1.39666e-3, 1.39444e-3, 1.39406e-3 at x = y = 1 - z - k
        # ulps, k = 0, 1, 2; continuous 1e-9 in)
        s = 1.0 - 1e-9
        grid = np.array([(s * (-(1 - k / m) + 2 * i / m), s * (-(1 - k / m) + 2 * j / m), k / m)
                         for k in range(m) for i in range(m - k + 1) for j in range(m - k + 1)])
    else:
        g = np.linspace(-1.0, 1.0, m + 1)
        grid = np.array(np.meshgrid(*[g] * dim, indexing="ij")).reshape(dim, -1).T
    return np.hstack([grid, np.zeros((len(grid), 3 - dim))])


def sampled_sj(dim, all_tags):
    """Per element (in the order of all_tags), the least scaled Jacobian
    and the least det J of Gmsh's own Jacobians on reference_points."""
    import numpy as np  # only here: the rest of the checker needs no numpy

    by_tag = {}
    for t in gmsh.model.mesh.getElementTypes(dim=dim):
        tags, nodes = gmsh.model.mesh.getElementsByType(t)
        if len(tags) == 0:
            continue
        grid = reference_points(t)
        jac, _, _ = gmsh.model.mesh.getJacobians(t, grid.ravel())
        # per point, rows are dx/du, dx/dv, dx/dw
        j = np.array(jac).reshape(len(tags), len(grid), 3, 3)
        if dim == 3:
            d = np.linalg.det(j)
        else:
            # Gmsh's determinant of a 2D element is |dx/du x dx/dv| (its
            # third row the unit normal along that cross product), never
            # negative: signed here by the side of the cross product from
            # the normal of the element's straight cell, (x2 - x0) x
            # (x_last - x1) of its vertices
            nv = gmsh.model.mesh.getElementProperties(t)[5]
            nt, xyz, _ = gmsh.model.mesh.getNodes()
            xs = np.zeros((int(nt.max()) + 1, 3))
            xs[nt] = np.reshape(xyz, (-1, 3))
            v = xs[np.reshape(nodes, (len(tags), -1))[:, :nv]]
            n = np.cross(v[:, 2] - v[:, 0], v[:, nv - 1] - v[:, 1])
            c = np.cross(j[:, :, 0, :], j[:, :, 1, :])
            d = np.linalg.norm(c, axis=2) * np.sign(np.einsum("eqc,ec->eq", c, n))
        sj = (d / np.linalg.norm(j[:, :, :dim, :], axis=3).prod(axis=2)).min(axis=1)
        by_tag.update(zip((int(x) for x in tags), ((float(v), float(w)) for v, w in zip(sj, d.min(axis=1)))))
    return [by_tag[t][0] for t in all_tags], [by_tag[t][1] for t in all_tags]


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    gmsh.initialize(readConfigFiles=False)
    try:
        # Keep stdout clean for the JSON; errors still raise exceptions.
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.open(sys.argv[1])
        report = {
            "num_nodes": len(gmsh.model.mesh.getNodes()[0]),
            "element_types": element_types(),
            "physical_names": physical_names(),
            "elements_2d": elements(2),
            "elements_3d": elements(3),
        }
    finally:
        gmsh.finalize()
    json.dump(report, sys.stdout)
    print()


if __name__ == "__main__":
    main()
