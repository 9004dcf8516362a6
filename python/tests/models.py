"""Models built as users build them: OCC booleans and fillets, a boundary
layer of quads, an extruded prism layer (the tests' and
benches/python_overhead.py's)."""

import gmsh


def fillet_part(size: float = 0.2, groups: bool = True) -> None:
    """A block with a hole bored through it (an OCC cut) and one edge
    rounded (an OCC fillet), in tets; groups on the solid and three faces
    (none with `groups=False`: meshio 5.3 cannot read an MSH 4.1 file where
    some entities are in no group)."""
    gmsh.model.add("part")
    box = gmsh.model.occ.addBox(0, 0, 0, 2, 1, 1)
    hole = gmsh.model.occ.addCylinder(1, 0.5, -0.1, 0, 0, 1.2, 0.25)
    out, _ = gmsh.model.occ.cut([(3, box)], [(3, hole)])
    gmsh.model.occ.fillet([out[0][1]], [1], [0.2])
    gmsh.model.occ.synchronize()
    if groups:
        gmsh.model.addPhysicalGroup(3, [v[1] for v in gmsh.model.getEntities(3)], name="solid")
        faces = [s[1] for s in gmsh.model.getEntities(2)]
        gmsh.model.addPhysicalGroup(2, faces[:3], name="walls")
    gmsh.option.setNumber("Mesh.MeshSizeMax", size)
    gmsh.model.mesh.generate(3)


def quad_layer() -> None:
    """A plate with a round hole (an OCC cut) meshed in quads, with a
    boundary layer of quads on the hole: a 2D CFD mesh."""
    gmsh.model.add("plate")
    plate = gmsh.model.occ.addRectangle(-2, -1.5, 0, 4, 3)
    hole = gmsh.model.occ.addDisk(0, 0, 0, 0.5, 0.5)
    gmsh.model.occ.cut([(2, plate)], [(2, hole)])
    gmsh.model.occ.synchronize()
    circle = [c[1] for c in gmsh.model.getEntities(1) if gmsh.model.getType(1, c[1]) == "Circle"]
    f = gmsh.model.mesh.field.add("BoundaryLayer")
    gmsh.model.mesh.field.setNumbers(f, "CurvesList", circle)
    gmsh.model.mesh.field.setNumber(f, "Size", 0.01)
    gmsh.model.mesh.field.setNumber(f, "Ratio", 1.3)
    gmsh.model.mesh.field.setNumber(f, "Thickness", 0.1)
    gmsh.model.mesh.field.setNumber(f, "Quads", 1)
    gmsh.model.mesh.field.setAsBoundaryLayer(f)
    gmsh.model.addPhysicalGroup(1, circle, name="wall")
    gmsh.model.addPhysicalGroup(2, [s[1] for s in gmsh.model.getEntities(2)], name="fluid")
    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.2)
    gmsh.option.setNumber("Mesh.RecombineAll", 1)
    gmsh.model.mesh.generate(2)


def prism_layer() -> None:
    """A plate with a round hole, triangles extruded into three layers of
    prisms (OCC extrude)."""
    gmsh.model.add("slab")
    plate = gmsh.model.occ.addRectangle(-1.5, -1, 0, 3, 2)
    hole = gmsh.model.occ.addDisk(0, 0, 0, 0.4, 0.4)
    out, _ = gmsh.model.occ.cut([(2, plate)], [(2, hole)])
    gmsh.model.occ.extrude(out, 0, 0, 0.3, numElements=[3], recombine=True)
    gmsh.model.occ.synchronize()
    gmsh.model.addPhysicalGroup(3, [v[1] for v in gmsh.model.getEntities(3)], name="slab")
    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.15)
    gmsh.model.mesh.generate(3)


def periodic_channel() -> None:
    """A channel with a round hole whose inlet and outlet are periodic
    (Gmsh's setPeriodic, by translation), in triangles."""
    gmsh.model.add("channel")
    plate = gmsh.model.occ.addRectangle(0, 0, 0, 3, 1)
    hole = gmsh.model.occ.addDisk(1.5, 0.5, 0, 0.25, 0.25)
    gmsh.model.occ.cut([(2, plate)], [(2, hole)])
    gmsh.model.occ.synchronize()
    left = [c for _, c in gmsh.model.getEntities(1) if abs(gmsh.model.occ.getCenterOfMass(1, c)[0]) < 1e-9]
    right = [c for _, c in gmsh.model.getEntities(1) if abs(gmsh.model.occ.getCenterOfMass(1, c)[0] - 3) < 1e-9]
    gmsh.model.mesh.setPeriodic(1, right, left, [1, 0, 0, 3, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1])
    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.15)
    gmsh.model.mesh.generate(2)
