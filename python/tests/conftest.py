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

from models import fillet_part, prism_layer, quad_layer  # noqa: F401  (the tests' models)

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


def groups() -> dict:
    """Every physical group: its name and entities."""
    return {(d, t): (gmsh.model.getPhysicalName(d, t), sorted(gmsh.model.getEntitiesForPhysicalGroup(d, t))) for d, t in gmsh.model.getPhysicalGroups()}


def element_tags() -> dict:
    """The element tags of every entity, by (dim, tag)."""
    return {(d, t): sorted(np.concatenate([np.asarray(e) for e in gmsh.model.mesh.getElements(d, t)[1]] or [np.zeros(0)]).tolist()) for d, t in gmsh.model.getEntities()}


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
        gap = max(gap, float((np.abs(q * scale - mine) / mine).max()))
    assert gap < 2e-3, gap
    return gap
