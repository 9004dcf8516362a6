"""One exception class per meaning of the command line's exit codes; the
message is the command line's."""

from __future__ import annotations


class DeformeshError(Exception):
    """A job of deformesh failed. `code` is the command line's exit code."""

    code = 1

    def __init__(self, message: str, code: int | None = None):
        super().__init__(message)
        if code is not None:
            self.code = code


class InputError(DeformeshError, ValueError):
    """Bad input (exit 1): the message names the file, line, field or element."""

    code = 1


class InvalidMeshError(DeformeshError):
    """The mesh is or would be invalid (exit 2): the elements are named, nothing is written or changed."""

    code = 2


class SolverError(DeformeshError):
    """A linear solver failed, or no candidate of curve was certified valid (exit 3)."""

    code = 3


class MemoryLimitError(DeformeshError, MemoryError):
    """The run needs more memory than it may have (exit 4); the estimate and what would fit are said."""

    code = 4


class UsageError(DeformeshError, TypeError):
    """An option's value is wrong (exit 64), or an output is an input."""

    code = 64


class LibraryMissingError(DeformeshError, ImportError):
    """A library the job needs is absent (exit 69): Gmsh's, for CAD."""

    code = 69


class NotOursError(DeformeshError, FileExistsError):
    """An output would replace a file no run of deformesh wrote (exit 73): pass force=True to replace it."""

    code = 73


class WriteError(DeformeshError, OSError):
    """Writing the outputs failed (exit 74): a full disk, an I/O error; nothing is written."""

    code = 74


_BY_CODE = {c.code: c for c in (InputError, InvalidMeshError, SolverError, MemoryLimitError, UsageError, LibraryMissingError, NotOursError, WriteError)}


def from_failure(failure: Exception) -> Exception:
    """The exception of the extension's `Failure(code, message)`."""
    code, message = failure.args
    if code == 130:
        return KeyboardInterrupt()
    return _BY_CODE.get(code, DeformeshError)(message, code)
