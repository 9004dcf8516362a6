#!/usr/bin/env python3
"""What the real Gmsh and VTK say about simplices and reference shapes, as JSON.

Usage: simplex_orders.py REQUEST

REQUEST is a JSON string {"points2": [[u, v], ...], "points3": [[u, v, w], ...],
"points_prism": [[u, v, w], ...], "points_pyramid": [[u, v, w], ...]}: points on
the unit triangle and tetrahedron (Gmsh's and VTK's reference simplex, which is
also ours), on the unit triangle x [0, 1] (our prism and VTK's wedge; Gmsh's
prism is the triangle x [-1, 1], the script maps w to 2 w - 1 for it) and on
our pyramid (base [0, 1]^2, apex (1/2, 1/2, 1); Gmsh's has the base [-1, 1]^2,
the script maps u, v to 2 u - 1, 2 v - 1) at which the Lagrange bases are
evaluated.

Prints one JSON object:
  gmsh         {type: {"name", "dim", "order", "nodes": local node coordinates
               flattened (dim per node, getElementProperties), "values":
               getBasisFunctions "Lagrange" at the points ([point][function]),
               "grads": "GradLagrange" ([point][function][xyz])}} for the
               triangles 2, 9, 21, 23, tetrahedra 4, 11, 29, 30, prisms
               6, 13 (4.15 has no nodal basis for the prisms 90, 91:
               "FaceClosureFull not implemented for prisms of order 3") and
               pyramids 7, 14, 118, 119
  gmsh_meshed  {p: {"type", "nodes": Gmsh's reference coordinates (the
               unit triangle x [-1, 1]) of the nodes of the one prism Gmsh
               itself meshes at order p (an extruded triangle, setOrder), in
               its local order, flattened 3 per node, found from their
               physical places through the prism's affine map}} for p = 1..4:
               Gmsh's own placement of its prism nodes, the one source for
               types 90, 91
  gmsh_shapes  {family: {"dim", "vertices": order-1 node coordinates flattened
               3 per node, "num_nodes": {p: node count} for the orders 1..4
               whose properties Gmsh gives (4.15 has none for prisms of order
               3), "edges": getElementEdgeNodes, "tri_faces" / "quad_faces":
               getElementFaceNodes (vertex numbers, flattened)}} for Line,
               Triangle, Quadrangle, Tetrahedron, Hexahedron, Prism, Pyramid,
               from a model holding one element of each
  vtk          {"triangle" | "tetra" | "wedge": {p: {"pcoords":
               GetParametricCoords flattened 3 per node, "values":
               InterpolateFunctions per point, "derivs": InterpolateDerivs per
               point ([direction][function])}}} of vtkLagrangeTriangle /
               vtkLagrangeTetra / vtkLagrangeWedge, p = 1..4, the order
               inferred from the number of points
  vtk_linear   {class: {"pcoords", "edges": [[a, b]], "faces": [[loop]]}} of
               vtkLine, vtkTriangle, vtkQuad, vtkTetra, vtkHexahedron, vtkWedge,
               vtkPyramid (point ids set to 0..n so edges and faces name vertices)
  warburton    {p: [[x, y], ...]} Warburton's warp & blend nodes of order p
               (Nodes2D of Hesthaven & Warburton, in their equilateral triangle
               with Legendre Vandermondes), mapped to the unit triangle: an
               independent construction of the set the crate builds in
               barycentric coordinates
"""
import json
import sys

import gmsh
import numpy as np
import vtk

TRIANGLES, TETS, PRISMS, PYRAMIDS = [2, 9, 21, 23], [4, 11, 29, 30], [6, 13], [7, 14, 118, 119]
FAMILIES = {"Line": 1, "Triangle": 2, "Quadrangle": 2, "Tetrahedron": 3,
            "Hexahedron": 3, "Prism": 3, "Pyramid": 3}


def flat(points, dim):
    out = []
    for p in points:
        out += list(p)[:dim] + [0.0] * (3 - dim)
    return out


def gmsh_points(request, t, dim):
    """The request's points of the cell of type t, in Gmsh's reference cell."""
    if t in PRISMS:
        return flat([[u, v, 2.0 * w - 1.0] for u, v, w in request["points_prism"]], 3)
    if t in PYRAMIDS:
        return flat([[2.0 * u - 1.0, 2.0 * v - 1.0, w] for u, v, w in request["points_pyramid"]], 3)
    return flat(request["points2"] if dim == 2 else request["points3"], dim)


def gmsh_types(request):
    out = {}
    for t in TRIANGLES + TETS + PRISMS + PYRAMIDS:
        name, dim, order, nn, coords, _ = gmsh.model.mesh.getElementProperties(t)
        pts = gmsh_points(request, t, dim)
        _, values, _ = gmsh.model.mesh.getBasisFunctions(t, pts, "Lagrange")
        _, grads, _ = gmsh.model.mesh.getBasisFunctions(t, pts, "GradLagrange")
        out[str(t)] = {"name": name, "dim": dim, "order": order,
                       "nodes": [float(c) for c in coords],
                       "values": [float(v) for v in values],
                       "grads": [float(g) for g in grads]}
    return out


def node_coords(t):
    _, dim, _, nn, coords, _ = gmsh.model.mesh.getElementProperties(t)
    return flat([coords[dim * k:dim * (k + 1)] for k in range(nn)], dim)


def num_nodes(family):
    out = {}
    for p in range(1, 5):
        try:
            props = gmsh.model.mesh.getElementProperties(gmsh.model.mesh.getElementType(family, p))
        except Exception:  # Gmsh 4.15: "FaceClosureFull not implemented for prisms of order 3"
            continue
        out[str(p)] = props[3]
    return out


def gmsh_shapes():
    """One order-1 element of each family in one model; Gmsh's own edge and
    face tables from it, as local vertex numbers."""
    gmsh.model.add("reference_shapes")
    out = {}
    first = 1
    for family, dim in FAMILIES.items():
        t1 = gmsh.model.mesh.getElementType(family, 1)
        nv = gmsh.model.mesh.getElementProperties(t1)[5]
        tag = gmsh.model.addDiscreteEntity(dim)
        nodes = list(range(first, first + nv))
        gmsh.model.mesh.addNodes(dim, tag, nodes, [0.0] * (3 * nv))
        gmsh.model.mesh.addElements(dim, tag, [t1], [[first]], [nodes])
        local = lambda tags: [int(x) - first for x in tags]
        entry = {"dim": dim, "vertices": node_coords(t1), "num_nodes": num_nodes(family),
                 "edges": local(gmsh.model.mesh.getElementEdgeNodes(t1, tag, True)) if dim > 1 else [0, 1]}
        if dim > 1:
            entry["tri_faces"] = local(gmsh.model.mesh.getElementFaceNodes(t1, 3, tag, True))
            entry["quad_faces"] = local(gmsh.model.mesh.getElementFaceNodes(t1, 4, tag, True))
        out[family] = entry
        first += nv
    return out


def gmsh_meshed():
    """Gmsh's own order-p prism: one straight prism meshed and raised to
    order p by Gmsh, its nodes taken back to Gmsh's reference prism through
    the affine map of its six vertices (an extruded triangle's prism is
    affine). Works where getElementProperties does not (types 90, 91)."""
    out = {}
    for p in range(1, 5):
        gmsh.model.add(f"prism{p}")
        geo = gmsh.model.geo
        corners = [geo.addPoint(*x) for x in ((0.1, 0.2, 0.0), (1.3, 0.1, 0.0), (0.4, 1.1, 0.0))]
        lines = [geo.addLine(corners[k], corners[(k + 1) % 3]) for k in range(3)]
        base = geo.addPlaneSurface([geo.addCurveLoop(lines)])
        geo.extrude([(2, base)], 0.2, 0.1, 0.9, numElements=[1], recombine=True)
        geo.synchronize()
        for _, curve in gmsh.model.getEntities(1):
            gmsh.model.mesh.setTransfiniteCurve(curve, 2)
        gmsh.model.mesh.generate(3)
        gmsh.model.mesh.setOrder(p)
        (t,) = gmsh.model.mesh.getElementTypes(3)
        _, tags = gmsh.model.mesh.getElementsByType(t)
        x = np.array([gmsh.model.mesh.getNode(n)[0] for n in tags])
        frame = np.array([x[1] - x[0], x[2] - x[0], x[3] - x[0]]).T
        local = np.linalg.solve(frame, (x - x[0]).T).T
        local[:, 2] = 2.0 * local[:, 2] - 1.0
        out[str(p)] = {"type": int(t), "nodes": [float(c) for c in local.flatten()]}
        gmsh.model.remove()
    return out


def lagrange_cell(cls, n):
    cell = cls()
    cell.GetPointIds().SetNumberOfIds(n)
    cell.GetPoints().SetNumberOfPoints(n)
    for i in range(n):
        cell.GetPointIds().SetId(i, i)
        cell.GetPoints().SetPoint(i, 0.0, 0.0, 0.0)
    cell.Initialize()
    # a wedge does not infer its order from its points by itself
    if hasattr(cell, "SetUniformOrderFromNumPoints"):
        cell.SetUniformOrderFromNumPoints(n)
    return cell


def vtk_lagrange(request):
    out = {"triangle": {}, "tetra": {}, "wedge": {}}
    for key, cls, count, pts in (
            ("triangle", vtk.vtkLagrangeTriangle, lambda p: (p + 1) * (p + 2) // 2, request["points2"]),
            ("tetra", vtk.vtkLagrangeTetra, lambda p: (p + 1) * (p + 2) * (p + 3) // 6, request["points3"]),
            ("wedge", vtk.vtkLagrangeWedge, lambda p: (p + 1) ** 2 * (p + 2) // 2, request["points_prism"])):
        for p in range(1, 5):
            n = count(p)
            cell = lagrange_cell(cls, n)
            pc = cell.GetParametricCoords()
            values, derivs = [], []
            for x in pts:
                pcoords = list(x) + [0.0] * (3 - len(x))
                w = [0.0] * n
                d = [0.0] * (3 * n)
                cell.InterpolateFunctions(pcoords, w)
                cell.InterpolateDerivs(pcoords, d)
                values.append(w)
                derivs.append(d)
            out[key][str(p)] = {"pcoords": [pc[i] for i in range(3 * n)],
                                "values": values, "derivs": derivs}
    return out


def vtk_linear():
    out = {}
    for cls in (vtk.vtkLine, vtk.vtkTriangle, vtk.vtkQuad, vtk.vtkTetra,
                vtk.vtkHexahedron, vtk.vtkWedge, vtk.vtkPyramid):
        cell = cls()
        n = cell.GetNumberOfPoints()
        for i in range(n):
            cell.GetPointIds().SetId(i, i)
        pc = cell.GetParametricCoords()
        ids = lambda c: [c.GetPointId(k) for k in range(c.GetNumberOfPoints())]
        out[cell.GetClassName()] = {
            "pcoords": [pc[i] for i in range(3 * n)],
            "edges": [ids(cell.GetEdge(e)) for e in range(cell.GetNumberOfEdges())],
            "faces": [ids(cell.GetFace(f)) for f in range(cell.GetNumberOfFaces())]}
    return out


def gauss_lobatto(n):
    """The n + 1 Gauss-Lobatto-Legendre points on [-1, 1]."""
    inner = np.polynomial.legendre.Legendre.basis(n).deriv().roots()
    return np.concatenate(([-1.0], np.sort(inner.real), [1.0]))


def warp_factor(n, r):
    """Warpfactor of Hesthaven & Warburton: the equispaced-to-GLL shift,
    interpolated with a Legendre Vandermonde and divided by 1 - r^2."""
    req = np.linspace(-1.0, 1.0, n + 1)
    veq = np.polynomial.legendre.legvander(req, n)
    pmat = np.polynomial.legendre.legvander(r, n).T
    lmat = np.linalg.solve(veq.T, pmat)
    warp = lmat.T @ (gauss_lobatto(n) - req)
    inner = np.abs(r) < 1.0 - 1.0e-10
    sf = 1.0 - (inner * r) ** 2
    return warp / sf + warp * (inner - 1)


def nodes2d(n):
    alpopt = [0.0, 0.0, 1.4152, 0.1001, 0.2751, 0.9800, 1.0999, 1.2832, 1.3648,
              1.4773, 1.4959, 1.5743, 1.5770, 1.6223, 1.6258]
    alpha = alpopt[n - 1]
    l1, l3 = [], []
    for a in range(n + 1):
        for b in range(n + 1 - a):
            l1.append(a / n)
            l3.append(b / n)
    l1, l3 = np.array(l1), np.array(l3)
    l2 = 1.0 - l1 - l3
    x, y = -l2 + l3, (-l2 - l3 + 2.0 * l1) / np.sqrt(3.0)
    warp1 = 4 * l2 * l3 * warp_factor(n, l3 - l2) * (1 + (alpha * l1) ** 2)
    warp2 = 4 * l1 * l3 * warp_factor(n, l1 - l3) * (1 + (alpha * l2) ** 2)
    warp3 = 4 * l1 * l2 * warp_factor(n, l2 - l1) * (1 + (alpha * l3) ** 2)
    x = x + warp1 + np.cos(2 * np.pi / 3) * warp2 + np.cos(4 * np.pi / 3) * warp3
    y = y + np.sin(2 * np.pi / 3) * warp2 + np.sin(4 * np.pi / 3) * warp3
    # back to barycentrics of the equilateral triangle, then to the unit one
    b1 = (np.sqrt(3.0) * y + 1.0) / 3.0
    b3 = (1.0 - b1 + x) / 2.0
    b2 = 1.0 - b1 - b3
    return [[float(u), float(v)] for u, v in zip(b2, b3)]


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    request = json.loads(sys.argv[1])
    gmsh.initialize(readConfigFiles=False)
    try:
        # keep stdout clean for the JSON; errors still raise exceptions
        gmsh.option.setNumber("General.Terminal", 0)
        report = {"gmsh": gmsh_types(request), "gmsh_shapes": gmsh_shapes(),
                  "gmsh_meshed": gmsh_meshed()}
    finally:
        gmsh.finalize()
    report["vtk"] = vtk_lagrange(request)
    report["vtk_linear"] = vtk_linear()
    report["warburton"] = {str(p): nodes2d(p) for p in range(1, 5)}
    json.dump(report, sys.stdout)
    print()


if __name__ == "__main__":
    main()
