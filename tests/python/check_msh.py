#!/usr/bin/env python3
"""Open a mesh file with the Gmsh API and print what Gmsh sees, as JSON.

Usage: check_msh.py FILE

Prints one JSON object:
  num_nodes        number of nodes Gmsh loaded
  element_types    {type number: {"name": ..., "count": ...}} over all dims
  physical_names   {dim: [names, in order of physical tag]}
  elements_2d      {"tags": [...], "minDetJac": [...], "maxDetJac": [...],
                    "minSJ": [...], "minSIGE": [...], "sampledSJ": [...]},
                   ordered by element
                   tag; minSJ is Gmsh's lower bound, sampledSJ the least
                   det J / (|dx/du| |dx/dv| (|dx/dw|)) of Gmsh's own
                   Jacobians on the (3p + 1)^dim equispaced points of the
                   reference element (corners included)
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
    """Jacobian-based qualities of every element of dimension dim, by tag."""
    _, tags, _ = gmsh.model.mesh.getElements(dim=dim)
    all_tags = sorted(int(t) for ts in tags for t in ts)
    out = {"tags": all_tags}
    for quality in ("minDetJac", "maxDetJac", "minSJ", "minSIGE"):
        values = gmsh.model.mesh.getElementQualities(all_tags, quality) if all_tags else []
        out[quality] = [float(v) for v in values]
    out["sampledSJ"] = sampled_sj(dim, all_tags)
    return out


def sampled_sj(dim, all_tags):
    """Per element (in the order of all_tags), the least scaled Jacobian
    of Gmsh's own Jacobians on a (3p + 1)^dim equispaced grid."""
    import numpy as np  # only here: the rest of the checker needs no numpy

    by_tag = {}
    for t in gmsh.model.mesh.getElementTypes(dim=dim):
        order = gmsh.model.mesh.getElementProperties(t)[2]
        g = np.linspace(-1.0, 1.0, 3 * order + 1)
        axes = [g] * dim + [np.zeros(1)] * (3 - dim)
        grid = np.array(np.meshgrid(*axes, indexing="ij")).reshape(3, -1).T
        tags, _ = gmsh.model.mesh.getElementsByType(t)
        if len(tags) == 0:
            continue
        jac, det, _ = gmsh.model.mesh.getJacobians(t, grid.ravel())
        # per point, rows are dx/du, dx/dv, dx/dw (the third a normal in 2D)
        j = np.array(jac).reshape(len(tags), len(grid), 3, 3)[:, :, :dim, :]
        d = np.array(det).reshape(len(tags), len(grid))
        sj = (d / np.linalg.norm(j, axis=3).prod(axis=2)).min(axis=1)
        by_tag.update(zip((int(x) for x in tags), (float(v) for v in sj)))
    return [by_tag[t] for t in all_tags]


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
