"""Models built as users build them (OCC booleans and fillets, boundary
layers, extruded prism layers) and the checks a user's solver would make
of a curved Gmsh model, each by Gmsh itself."""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
from pathlib import Path

import gmsh
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]


def deformesh_cli() -> list[str]:
    """The command line: the binary `cargo test` built, else the package's."""
    exe = os.environ.get("DEFORMESH")
    if exe and Path(exe).exists():
        return [exe]
    return [sys.executable, "-m", "deformesh"]


@pytest.fixture
def session():
    # interruptible=False: Gmsh's default sets SIGINT to end the process at
    # once; so Python's KeyboardInterrupt stays (as a user keeps it). And
    # gmsh 4.15's finalize does not put back the handler its initialize
    # replaced (it keeps it in a local): an earlier test's is undone here
    signal.signal(signal.SIGINT, signal.default_int_handler)
    gmsh.initialize(interruptible=False)
    gmsh.option.setNumber("General.Terminal", 0)
    try:
        yield gmsh
    finally:
        gmsh.finalize()


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


def groups() -> dict:
    """Every physical group: its name and entities."""
    return {(d, t): (gmsh.model.getPhysicalName(d, t), sorted(gmsh.model.getEntitiesForPhysicalGroup(d, t))) for d, t in gmsh.model.getPhysicalGroups()}


def snapshot() -> tuple:
    """The model's mesh: every node and every element."""
    tags, xyz, _ = gmsh.model.mesh.getNodes()
    elements = [gmsh.model.mesh.getElements(d) for d in range(4)]
    return np.asarray(tags), np.asarray(xyz), [(list(t), [np.asarray(x) for x in e], [np.asarray(x) for x in n]) for t, e, n in elements]


def check_curved(order: int, report: dict, before_groups: dict, tmp_path: Path) -> dict:
    """What a user checks of the model curved in place, each by Gmsh."""
    dim = gmsh.model.getDimension()
    # every element of every dimension of order `order`
    for d in range(1, dim + 1):
        for t in gmsh.model.mesh.getElementTypes(d):
            assert gmsh.model.mesh.getElementProperties(t)[2] == order, (d, t)
    # every cell valid by Gmsh's own Jacobian bound
    types, cells, _ = gmsh.model.mesh.getElements(dim)
    theirs = [np.asarray(gmsh.model.mesh.getElementQualities(e, "minDetJac")) for e in cells]
    assert all((q > 0).all() for q in theirs), f"{sum((q <= 0).sum() for q in theirs)} invalid"
    # every node of a curve or surface on its CAD entity
    far = 0.0
    for d in range(1, dim):
        for _, t in gmsh.model.getEntities(d):
            _, xyz, _ = gmsh.model.mesh.getNodes(d, t)
            if len(xyz):
                on = np.asarray(gmsh.model.getClosestPoint(d, t, xyz)[0])
                far = max(far, float(np.abs(on - np.asarray(xyz)).max()))
    assert far < 1e-10, far
    assert groups() == before_groups
    # Gmsh's file of it, read by our command line: the same figures
    path = tmp_path / "written.msh"
    gmsh.write(str(path))
    q = json.loads(subprocess.run([*deformesh_cli(), "quality", str(path), "--json"], check=True, capture_output=True, text=True).stdout)
    assert q["invalid_elements"] == []
    assert math.isclose(q["min_det_j"], report["quality"]["min_det_j"], rel_tol=1e-10), (q["min_det_j"], report["quality"]["min_det_j"])
    assert math.isclose(q["scaled_jacobian"]["min"], report["quality"]["scaled_jacobian"]["min"], rel_tol=1e-10)
    # element by element, Gmsh's bound and ours on the same file
    ours = agree_with_gmsh(path, types, cells, theirs)
    min_det = min(q.min() for q in theirs)
    return {"min_det": float(min_det), "far": far, "sj": q["scaled_jacobian"]["min"], "agreement": ours}


# det J of Gmsh's reference elements over ours: quads and hexes on
# [-1, 1]^d there, [0, 1]^d here; prisms' axis [-1, 1]; simplices alike
REFERENCE_SCALE = {"triangle": 1, "tetrahedron": 1, "quadrilateral": 4, "hexahedron": 8, "prism": 2}


def agree_with_gmsh(path: Path, types, cells, theirs) -> float:
    """The largest relative gap between Gmsh's `minDetJac` and our
    certified bound, element by element (asserted under 2e-3: both are
    lower bounds from Bézier coefficients, subdivided to different
    tolerances)."""
    import deformesh

    cert = deformesh.certify(path)
    ours = dict(zip(cert.tags.tolist(), cert.min_det.tolist()))
    gap = 0.0
    for t, e, q in zip(types, cells, theirs):
        name = gmsh.model.mesh.getElementProperties(t)[0].split(" ")[0].lower()
        scale = REFERENCE_SCALE[name]
        mine = np.asarray([ours[int(k)] for k in e])
        gap = max(gap, float(np.abs(q * scale - mine).max() / np.abs(mine).max()))
    assert gap < 2e-3, gap
    return gap
