"""`deformesh.curve`, `certify` and `run`: the command line's results."""

from __future__ import annotations

import json
import os
import subprocess
import tempfile

import gmsh
import meshio
import numpy as np
import pytest

import deformesh
from conftest import ROOT, deformesh_cli, fillet_part


@pytest.fixture(scope="module")
def part(tmp_path_factory):
    """The filleted part's linear mesh and its STEP model, as files."""
    d = tmp_path_factory.mktemp("part")
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    try:
        fillet_part(0.3, groups=False)
        gmsh.write(str(d / "part.msh"))
        gmsh.write(str(d / "part.step"))
    finally:
        gmsh.finalize()
    return d


def cli_curve(part, out, *more):
    env = dict(os.environ, DEFORMESH_GMSH_LIB=gmsh.libpath)
    subprocess.run([*deformesh_cli(), "curve", str(part / "part.msh"), "--cad", str(part / "part.step"), "--order", "3", "-o", str(out), *more], check=True, env=env, capture_output=True)
    return meshio.read(out)


def test_curve_of_a_path_and_of_a_meshio_mesh_give_the_command_lines_nodes(part, tmp_path, monkeypatch):
    # (without out=, curve reads its MSH 2.2 back: meshio 5.3 reads every one)
    cli = cli_curve(part, tmp_path / "cli.msh", "--format", "msh22")
    scratch = tmp_path / "scratch"
    scratch.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))
    by_path = deformesh.curve(part / "part.msh", cad=part / "part.step", order=3, progress=False)
    by_mesh = deformesh.curve(meshio.read(part / "part.msh"), cad=part / "part.step", order=3, progress=False)
    # nothing is left on disk without out=
    assert by_path.path is None and not any(scratch.iterdir())
    for r in (by_path, by_mesh):
        assert r.mesh.points.shape == cli.points.shape
        assert np.abs(r.mesh.points - cli.points).max() <= 1e-15
        assert [c.type for c in r.mesh.cells] == [c.type for c in cli.cells]
        assert all(np.array_equal(a.data, b.data) for a, b in zip(r.mesh.cells, cli.cells))
        assert r.report["quality"]["invalid_elements"] == []


def test_curve_writes_out_and_refuses_a_file_it_did_not_write(part, tmp_path):
    out = tmp_path / "p2.msh"
    r = deformesh.curve(part / "part.msh", cad=part / "part.step", order=2, out=out, format="msh22", progress=False)
    assert r.path == out and out.read_text().startswith("$MeshFormat\n2.2") and (tmp_path / "p2.report.json").exists()
    assert {c.type for c in r.mesh.cells} >= {"tetra10", "triangle6"}
    (tmp_path / "mine.msh").write_text("a user's file")
    with pytest.raises(deformesh.NotOursError, match="mine.msh"):
        deformesh.curve(part / "part.msh", cad=part / "part.step", order=2, out=tmp_path / "mine.msh", progress=False)
    assert (tmp_path / "mine.msh").read_text() == "a user's file"


def test_certify_agrees_with_gmsh_and_the_command_line(part, tmp_path):
    cli_curve(part, tmp_path / "p3.msh")
    c = deformesh.certify(tmp_path / "p3.msh")
    assert (c.dimension, c.order) == (3, 3) and c.all_valid
    q = json.loads(subprocess.run([*deformesh_cli(), "quality", str(tmp_path / "p3.msh"), "--json"], check=True, capture_output=True, text=True).stdout)
    assert c.min_det.min() == q["min_det_j"] and c.scaled_jacobian.min() == q["scaled_jacobian"]["min"]
    gmsh.initialize()
    try:
        gmsh.open(str(tmp_path / "p3.msh"))
        theirs = np.asarray(gmsh.model.mesh.getElementQualities(c.tags.astype(np.uint64), "minDetJac"))
    finally:
        gmsh.finalize()
    # Gmsh's bound and ours, element by element: both lower bounds from
    # Bézier coefficients, subdivided to different tolerances
    gap = np.abs(theirs - c.min_det) / c.min_det
    assert gap.max() < 2e-3, gap.max()
    # a meshio.Mesh of the same file: the same certificates
    again = deformesh.certify(meshio.read(tmp_path / "p3.msh"))
    assert np.array_equal(again.min_det, c.min_det)


def test_an_invalid_mesh_is_named_by_its_tags(tmp_path):
    path = tmp_path / "flipped.msh"
    path.write_text("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 4 1 4\n2 1 0 4\n1\n2\n3\n4\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n$EndNodes\n$Elements\n1 1 7 7\n2 1 3 1\n7 1 4 3 2\n$EndElements\n")
    c = deformesh.certify(path)
    assert list(c.tags) == [7] and not c.valid[0] and c.min_det[0] < 0


def test_run_of_a_case_dict_is_run_of_its_file(tmp_path):
    import tomllib

    path = ROOT / "cases" / "quarter_disk.toml"
    case = tomllib.loads(path.read_text())
    by_file = deformesh.run(path, tmp_path / "file", progress=False)
    by_dict = deformesh.run(case, tmp_path / "dict", progress=False)
    assert (tmp_path / "file" / "report.json").exists() and (tmp_path / "dict" / "mesh.msh").exists()
    # the seed's Figure 2: every cell valid, J/f as the command line reports it
    assert by_file["cells"] == by_dict["cells"] == 400
    assert by_file["jf"] == by_dict["jf"] and 0.89 < by_dict["jf"]["min"] < by_dict["jf"]["max"] < 1.04
    with pytest.raises(deformesh.InputError, match="<the case dict>"):
        deformesh.run({**case, "time": {"steps": "many"}}, tmp_path / "bad", progress=False)
    assert not (tmp_path / "bad").exists()


def test_the_command_runs_in_process(tmp_path):
    import sys

    out = subprocess.run([sys.executable, "-m", "deformesh", "--version"], check=True, capture_output=True, text=True).stdout
    assert out.startswith("deformesh ")
    bad = subprocess.run([sys.executable, "-m", "deformesh", "curve", str(tmp_path / "none.msh"), "--geometry", "g.toml", "-o", str(tmp_path / "o.msh")], capture_output=True, text=True)
    assert bad.returncode == 1 and "none.msh" in bad.stderr
