"""Curve the mesh of the live Gmsh model in place: `deformesh.gmsh.curve`."""

from __future__ import annotations

import json
import os

from . import _deformesh
from ._options import method_flags
from ._progress import reporter
from .errors import from_failure


def curve(order: int = 3, *, cad: bool = True, geometry=None, progress=True, **options) -> dict:
    """Curves the mesh of the current Gmsh model in place, order `order`.

    Its elements become Lagrange elements of that order, every node where
    the deformation method puts it and every element certified valid: the
    new nodes are added on their entities (with their parameters there),
    each element replaced by its curved one of the same tag; physical
    groups and classification stay. A model with periodic links goes
    through Gmsh's own `setOrder`, which links the new nodes. The CAD is the model itself
    (`cad=True`): each boundary element is curved onto the model entity it
    lies on. `geometry`: a geometry file (TOML) that sets groups to slip,
    fixed or another shape (with cad=False it binds the boundary alone).

    `options`: the method's, as on the command line: spacing, steps, mode,
    solver, shape_tolerance, band, snap, optimise.

    Refuses, raising and changing nothing, when any element would be
    invalid (InvalidMeshError) or the input is wrong (InputError, …).
    Ctrl-C raises KeyboardInterrupt and leaves the model as it was, where
    Gmsh was initialised with `interruptible=False` (its default makes
    Ctrl-C end the process).
    Returns the report (the command line's report.json, and
    `written_back`: elements and nodes given to Gmsh).
    """
    import gmsh

    if not gmsh.isInitialized():
        raise RuntimeError("deformesh.gmsh.curve: call gmsh.initialize() and make a mesh first")
    library = gmsh.libpath
    if not library or not os.path.exists(library):
        raise RuntimeError(f"deformesh.gmsh.curve: the gmsh module's library is not a file ({library!r})")
    if not cad and geometry is None:
        raise TypeError("deformesh.gmsh.curve: with cad=False give a geometry file: nothing else binds the boundary")
    argv = method_flags(order=order, **options)
    if geometry is not None:
        argv += ["--geometry", os.fspath(geometry)]
    f, close = reporter(progress)
    try:
        text = _deformesh.curve_live(library, argv, cad, f)
    except _deformesh.Failure as e:
        raise from_failure(e) from None
    finally:
        close()
    return json.loads(text)
