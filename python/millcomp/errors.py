"""The exceptions of millcomp: one class per error family, all under :class:`MillcompError`.

The message is the one the CLI prints after ``error:`` — the error, then each cause on a
``  caused by:`` line — with a design option named as the Python argument (``argument `factors```)
rather than the CLI flag.

Example::

    >>> import millcomp
    >>> try:
    ...     millcomp.doe.design("full", "a=1:1")
    ... except millcomp.ArgumentError as e:
    ...     print(str(e).splitlines()[0])
    argument `factors`
"""

from __future__ import annotations


class MillcompError(Exception):
    """Any error of a millcomp call."""


class ArgumentError(MillcompError, ValueError):
    """A wrong argument: a name, a type, a value out of range (named in the message)."""


class DatasetError(MillcompError, ValueError):
    """A table or data file problem: a missing column, a cell that is not a number (file, row, column named)."""


class ModelFileError(MillcompError):
    """A model file that cannot be read, or is of another kind than asked for."""


class DoeError(MillcompError):
    """A design that cannot be built or analysed."""


class IdentifyError(MillcompError):
    """A fit that cannot be made from the data."""


class DiagnoseError(MillcompError):
    """A diagnosis that cannot be made."""


class ClosedLoopError(MillcompError):
    """A scenario, controller or batch problem."""


class SimulationError(MillcompError):
    """A simulator problem (a session file, a plan)."""


class ControllerError(MillcompError):
    """A controller (MPC) problem."""


class BatchInterrupted(ClosedLoopError):
    """A batch stopped before its end; the finished runs are stored and the same call resumes."""


__all__ = [
    "MillcompError",
    "ArgumentError",
    "DatasetError",
    "ModelFileError",
    "DoeError",
    "IdentifyError",
    "DiagnoseError",
    "ClosedLoopError",
    "SimulationError",
    "ControllerError",
    "BatchInterrupted",
]
