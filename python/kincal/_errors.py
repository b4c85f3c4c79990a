"""The exceptions kincal raises (the Rust extension raises these classes).

Every kincal failure is a :class:`KincalError`; its subclasses say whose fault it is, as the
command line's exit statuses do (2 usage, 3 bad input, 4 numerical failure, 1 output).
"""

from typing import Optional


class KincalError(Exception):
    """Base class of every error kincal raises."""


class UsageError(KincalError, ValueError):
    """A bad argument (wrong length, non-finite number, contradictory options).

    Also a :class:`ValueError`, so ``except ValueError`` catches it.
    """


class FileFormatError(KincalError):
    """A bad input file: where, and what was expected.

    Attributes:
        path: the file as given.
        line: 1-based line, when known.
        column: 1-based column (characters), when known (robot descriptions, URDF,
            model files).
        field: the CSV column name (measurement files) or the key, when known.
        reason: the message without the position.
    """

    def __init__(
        self,
        message: str,
        path: Optional[str] = None,
        line: Optional[int] = None,
        column: Optional[int] = None,
        field: Optional[str] = None,
    ) -> None:
        super().__init__(message)
        self.path = path
        self.line = line
        self.column = column
        self.field = field


class NumericError(KincalError):
    """A numerical failure: rank too low, no convergence, unreachable pose."""


class OutputError(KincalError, OSError):
    """An output file could not be written."""
