"""The method's options as command-line flags: one spelling for Python and
the command line, checked by the same code."""

from __future__ import annotations

_FLAGS = {
    "order": "--order",
    "spacing": "--spacing",
    "steps": "--steps",
    "mode": "--mode",
    "solver": "--solver",
    "shape_tolerance": "--shape-tolerance",
    "band": "--band",
    "snap": "--snap",
    "optimise": "--optimise",
}


def method_flags(**options) -> list[str]:
    """`--flag value` for each option given (None: the default)."""
    argv = []
    for name, value in options.items():
        if name not in _FLAGS:
            raise TypeError(f"unknown option {name!r}: the options are {', '.join(_FLAGS)}")
        if value is not None:
            argv += [_FLAGS[name], repr(value) if isinstance(value, float) else str(value)]
    return argv
