"""kincal: kinematic calibration of robot arms (modified DH / Hayati), from Python.

A thin layer over kincal's Rust core and file formats: the same numbers as the ``kincal``
command line. Units are SI: metres and radians (prismatic joints in metres), unless a name
says ``_mm``/``_deg``. Poses are 4x4 homogeneous numpy arrays ``T_e^b`` (tool in base).

>>> import kincal
>>> robot = kincal.aria()
>>> robot.fk([0, 0, 0, 0, 0, 0]).shape
(4, 4)
"""

from ._errors import FileFormatError, KincalError, NumericError, OutputError, UsageError
from ._kincal import (
    Measurements,
    Robot,
    __version__,
    aria,
    calibrate,
    crossval,
    design_tool,
    diagnose,
    evaluate_designs,
    load_robot,
    read_measurements,
    select_poses,
)

__all__ = [
    "FileFormatError",
    "KincalError",
    "Measurements",
    "NumericError",
    "OutputError",
    "Robot",
    "UsageError",
    "__version__",
    "aria",
    "calibrate",
    "crossval",
    "design_tool",
    "diagnose",
    "evaluate_designs",
    "load_robot",
    "read_measurements",
    "select_poses",
]
