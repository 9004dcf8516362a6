"""deformesh: curved, boundary-conforming high-order meshes of every
element kind by the deformation method.

- `deformesh.gmsh.curve(order=3)`: the live Gmsh model's mesh curved in
  place onto its own CAD.
- `deformesh.curve(mesh, order=3, cad=..., geometry=..., out=...)`: a mesh
  file or a `meshio.Mesh`; the curved mesh as a `meshio.Mesh`, and the report.
- `deformesh.certify(mesh)`: per-element certificates as numpy arrays.
- `deformesh.run(case)`: a case file or a dict of the same schema.

Errors are the exceptions of `deformesh.errors`, one class per meaning of
the command line's exit codes, with its messages.
"""

from __future__ import annotations

import contextlib
import json
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

from . import _deformesh, errors
from . import gmsh  # noqa: F401  (deformesh.gmsh.curve)
from ._options import method_flags
from ._progress import reporter
from .errors import (  # noqa: F401
    DeformeshError,
    InputError,
    InvalidMeshError,
    LibraryMissingError,
    MemoryLimitError,
    NotOursError,
    SolverError,
    UsageError,
    WriteError,
)

__version__ = _deformesh.__version__
__all__ = ["curve", "certify", "run", "Result", "Certificate", "gmsh", "errors", "DeformeshError"]


@dataclass
class Result:
    """What `curve` gives: the curved mesh (a `meshio.Mesh`, or None for a
    format meshio does not read back: MFEM, ABAQUS), the report (the
    command line's report.json) and the file written (None where `out`
    was not given)."""

    mesh: object
    report: dict
    path: Path | None


@dataclass
class Certificate:
    """The certificate of every element (cells of the mesh's dimension, in
    the file's order): `tags` the file's element tags; `min_det` the
    certified lower bound of det J over the element (Bézier bounds);
    `scaled_jacobian` its least scaled Jacobian; `valid` whether det J is
    certified positive throughout."""

    tags: object
    min_det: object
    scaled_jacobian: object
    valid: object
    dimension: int
    order: int

    @property
    def all_valid(self) -> bool:
        return bool(self.valid.all())


def _call(f, *args):
    try:
        return f(*args)
    except _deformesh.Failure as e:
        raise errors.from_failure(e) from None


def _as_file(mesh, folder: str) -> Path:
    """A path for `mesh`: itself, or a `meshio.Mesh` written as MSH 2.2
    (meshio 5.3's MSH 4.1 writer needs every block in a physical group;
    its 2.2 writer keeps the tags where the mesh has them)."""
    if isinstance(mesh, (str, os.PathLike)):
        return Path(mesh)
    import meshio

    if not isinstance(mesh, meshio.Mesh):
        raise TypeError(f"mesh must be a path or a meshio.Mesh, not {type(mesh).__name__}")
    path = Path(folder) / "input.msh"
    meshio.write(path, mesh, file_format="gmsh22", binary=False)
    return path


@contextlib.contextmanager
def _gmsh_for(cad):
    """Gmsh's library for a CAD model (the `gmsh` module's, where it is
    installed) and whether to attach to it (always, when the module is
    there: one Gmsh per process). The model is read into the Python
    module's Gmsh, initialised for the call if it was not (and finalised
    after); the user's current model is made current again and ours
    removed afterwards."""
    if cad is None:
        yield None, False
        return
    try:
        import gmsh
    except ImportError:
        yield None, False
        return
    ours = not gmsh.isInitialized()
    if ours:
        gmsh.initialize(interruptible=False)
        gmsh.option.setNumber("General.Terminal", 0)
    current = gmsh.model.getCurrent()
    before = set(gmsh.model.list())
    try:
        yield gmsh.libpath, True
    finally:
        if ours:
            gmsh.finalize()
        else:
            for name in set(gmsh.model.list()) - before:
                gmsh.model.setCurrent(name)
                gmsh.model.remove()
            gmsh.model.setCurrent(current)


def curve(mesh, *, order: int = 3, cad=None, geometry=None, out=None, format=None, cad_scale=None, force: bool = False, progress=True, **options) -> Result:
    """`deformesh curve` on `mesh` (a path or a `meshio.Mesh`), bound to
    the CAD model `cad` (STEP, IGES, BREP, XAO, .geo) and/or the geometry
    file `geometry`. With `out`, the curved mesh is written there (its
    extension chooses the format: .msh, .mesh MFEM, .inp ABAQUS; VTU, PNG
    and report beside it); without, nothing is left on disk. `options`:
    the method's (spacing, steps, mode, solver, shape_tolerance, band,
    snap, optimise), as on the command line."""
    if cad is None and geometry is None:
        raise TypeError("deformesh.curve: give cad= (the CAD model) or geometry= (a geometry file): nothing else binds the boundary")
    with tempfile.TemporaryDirectory(prefix="deformesh-") as tmp:
        path = _as_file(mesh, tmp)
        target = Path(out) if out is not None else Path(tmp) / "curved.msh"
        if out is None and format is None:
            # meshio 5.3 reads every MSH 2.2 file back; not every MSH 4.1
            format = "msh22"
        argv = ["deformesh", "curve", os.fspath(path), "-o", os.fspath(target), *method_flags(order=order, **options)]
        if cad is not None:
            argv += ["--cad", os.fspath(cad)]
        if cad_scale is not None:
            argv += ["--cad-scale", repr(float(cad_scale))]
        if geometry is not None:
            argv += ["--geometry", os.fspath(geometry)]
        if format is not None:
            argv += ["--format", format]
        if force:
            argv.append("--force")
        f, close = reporter(progress)
        try:
            with _gmsh_for(cad) as (library, attach):
                report = json.loads(_call(_deformesh.curve, argv, f, library, attach))
        finally:
            close()
        curved = None
        if target.suffix.lower() == ".msh":
            import meshio

            try:
                curved = meshio.read(target)
            except Exception as e:
                keep = "" if out is not None else "; pass out='curved.msh' to keep the file"
                raise DeformeshError(f"the curved mesh is certified valid, but meshio {meshio.__version__} cannot read it back ({e}){keep}") from None
        return Result(curved, report, Path(out) if out is not None else None)


def certify(mesh) -> Certificate:
    """The certificates of every element of `mesh` (a path to an MSH file
    or a `meshio.Mesh`), linear or high order."""
    import numpy as np

    with tempfile.TemporaryDirectory(prefix="deformesh-") as tmp:
        path = _as_file(mesh, tmp)
        tags, min_det, sj, valid, dim, order = _call(_deformesh.certify, os.fspath(path))
    return Certificate(np.asarray(tags, dtype=np.uint64), np.asarray(min_det), np.asarray(sj), np.asarray(valid, dtype=bool), dim, order)


def run(case, out=None, *, force: bool = False, progress=True) -> dict:
    """`deformesh run`: `case` a case file (TOML) or a dict of the same
    schema (its relative paths then from the working folder); writes
    mesh.msh, mesh.vtu, mesh.png and report.json into `out` (default, as
    the command line's: out/<case name>) and returns the report."""
    if isinstance(case, dict):
        text = _call(_deformesh.toml_of_json, json.dumps(case))
        name, base = "<the case dict>", Path.cwd()
    else:
        path = Path(case)
        try:
            text = path.read_text()
        except OSError as e:
            raise InputError(f"cannot read the case file `{path}`: {e.strerror}") from None
        name, base = str(path), path.parent
    f, close = reporter(progress)
    try:
        report = _call(_deformesh.run, text, name, os.fspath(base), None if out is None else os.fspath(out), force, f)
    finally:
        close()
    return json.loads(report)
