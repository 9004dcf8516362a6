"""Loads a mesh with the real MFEM (PyMFEM, `import mfem.ser`) and prints
what MFEM makes of it as JSON: counts, dimension, the nodal FE space, the
element and boundary attributes, the area/volume integrated with MFEM's
own element transformations (and with `GetElementVolume`, whose rule is
not exact for curved elements), the corner coordinates of every boundary
element, and the map x(xi) and det J of every element
at fixed reference points (MFEM's reference cell is [0,1]^d, as ours), so
that a test can compare every element with its own evaluation.

Usage: check_mfem.py MESH   (an MFEM `.mesh` or a `.vtu`)
"""

import json
import sys

import mfem.ser as mfem

# reference coordinates per axis: not symmetric about 1/2 and off the
# nodes of every order <= 4, so a permuted node shows in x(xi)
AXIS = [0.13, 0.41, 0.77]


def reference_points(dim):
    if dim == 2:
        return [[a, b] for b in AXIS for a in AXIS]
    return [[a, b, c] for c in AXIS for b in AXIS for a in AXIS]


def integrate_one(mesh, i, order):
    """The integral of det J over element i with a rule exact to `order`."""
    trans = mesh.GetElementTransformation(i)
    rule = mfem.IntRules.Get(mesh.GetElementBaseGeometry(i), order)
    total = 0.0
    for k in range(rule.GetNPoints()):
        ip = rule.IntPoint(k)
        trans.SetIntPoint(ip)
        total += ip.weight * trans.Weight()
    return total


def evaluate(mesh, i, points):
    """x(xi) and det J of element i at the reference points."""
    trans = mesh.GetElementTransformation(i)
    xs, dets = [], []
    for p in points:
        ip = mfem.IntegrationPoint()
        if len(p) == 2:
            ip.Set2(p[0], p[1])
        else:
            ip.Set3(p[0], p[1], p[2])
        trans.SetIntPoint(ip)
        # PyMFEM returns the image as an array
        xs.append([float(c) for c in trans.Transform(ip)])
        dets.append(trans.Weight())
    return xs, dets


def main():
    path = sys.argv[1]
    mesh = mfem.Mesh(path, 1, 1)
    dim = mesh.Dimension()
    fes = mesh.GetNodalFESpace()
    if fes is None:
        order, fec = 1, None
    else:
        order, fec = fes.GetMaxElementOrder(), fes.FEColl().Name()
    # det J of an order-p map has degree <= D p - 1 per variable
    rule_order = 2 * dim * order + 2
    volumes = [integrate_one(mesh, i, rule_order) for i in range(mesh.GetNE())]
    points = reference_points(dim)
    maps = [evaluate(mesh, i, points) for i in range(mesh.GetNE())]
    attrs = [mesh.GetAttribute(i) for i in range(mesh.GetNE())]
    battrs = [mesh.GetBdrAttribute(i) for i in range(mesh.GetNBE())]
    out = {
        "elements": mesh.GetNE(),
        "boundary_elements": mesh.GetNBE(),
        "vertices": mesh.GetNV(),
        "edges": mesh.GetNEdges(),
        "faces": mesh.GetNFaces() if dim == 3 else 0,
        "dimension": dim,
        "space_dimension": mesh.SpaceDimension(),
        "order": order,
        "fec": fec,
        "attributes": attrs,
        "attribute_set": sorted(set(attrs)),
        "bdr_attributes": battrs,
        "bdr_attribute_set": sorted(set(battrs)),
        "mesh_attributes": list(mesh.attributes.ToList()),
        "mesh_bdr_attributes": list(mesh.bdr_attributes.ToList()),
        "bdr_vertices": [
            [[float(c) for c in mesh.GetVertexArray(v)] for v in mesh.GetBdrElementVertices(i)]
            for i in range(mesh.GetNBE())
        ],
        "element_volumes": volumes,
        "volume": sum(volumes),
        "volume_mfem": sum(mesh.GetElementVolume(i) for i in range(mesh.GetNE())),
        "points": points,
        "x": [m[0] for m in maps],
        "det": [m[1] for m in maps],
    }
    json.dump(out, sys.stdout)


if __name__ == "__main__":
    main()
