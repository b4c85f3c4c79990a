"""Type stubs of the Rust extension (units: metres, radians unless ``_mm``/``_deg``)."""

import os
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

_Path = Union[str, "os.PathLike[str]"]
_Vec = Union[Sequence[float], npt.NDArray[np.float64]]

class Robot:
    """A robot model: nominal (built-in, robot description, URDF chain) or calibrated."""

    @property
    def name(self) -> str: ...
    @property
    def n_joints(self) -> int: ...
    @property
    def joint_limits(self) -> npt.NDArray[np.float64]:
        """(n_joints, 2): lower, upper [rad] ([m] for prismatic joints)."""
    @property
    def prismatic(self) -> List[bool]: ...
    @property
    def param_labels(self) -> List[str]:
        """Every parameter's label in the core's order (theta0_1, d_1, …, tool_rz, effects)."""
    @property
    def params(self) -> npt.NDArray[np.float64]:
        """Every parameter's value, in the order of param_labels [m, rad, effect units]."""
    def fk(
        self,
        q: Union[_Vec, npt.NDArray[np.float64]],
        approach: Optional[_Vec] = None,
        temp_c: Optional[float] = None,
    ) -> npt.NDArray[np.float64]:
        """T_e^b, (4, 4) [m] for q (n_joints,) [rad]; (M, 4, 4) for q (M, n_joints)."""
    def frames(
        self, q: _Vec, approach: Optional[_Vec] = None, temp_c: Optional[float] = None
    ) -> npt.NDArray[np.float64]:
        """(n_joints + 2, 4, 4) [m]: frame 0, frames 1..n_joints, tool."""
    def jacobian(
        self,
        q: _Vec,
        effects: bool = False,
        approach: Optional[_Vec] = None,
        temp_c: Optional[float] = None,
    ) -> Tuple[npt.NDArray[np.float64], List[str]]:
        """(6, P) identification Jacobian, rows [Δp [m]; Δφ [rad]] in the base frame, and
        the column labels."""
    def ik(
        self,
        target: npt.NDArray[np.float64],
        seed: Optional[_Vec] = None,
        max_iterations: int = 200,
        tol_pos_m: float = 1e-11,
        tol_rot_rad: float = 1e-11,
        extra_seeds: int = 16,
    ) -> Tuple[npt.NDArray[np.float64], float, float, int]:
        """(q [rad], residual_pos_m, residual_rot_rad, iterations) reaching target (4, 4)."""
    def pose_errors(
        self, data: Union[_Path, "Measurements"], allow_out_of_limits: bool = False
    ) -> Dict[str, npt.NDArray[np.float64]]:
        """Measured minus model (as kincal validate): pos_m (M, 3) [m], rot_rad (M, 3)
        [rad], pos_norm_m (M,), rot_norm_rad (M,)."""
    def with_params(self, values: _Vec) -> "Robot":
        """A copy with every parameter (order of param_labels) set to values."""
    def model_file(self) -> dict: ...
    def save(self, path: _Path) -> None: ...

class Measurements:
    """Rows of a measurement CSV (spec/measurements.md), in SI units."""

    @staticmethod
    def from_arrays(
        q: npt.NDArray[np.float64],
        poses: Optional[npt.NDArray[np.float64]] = None,
        pose_ids: Optional[Sequence[str]] = None,
    ) -> "Measurements": ...
    @property
    def source(self) -> str: ...
    @property
    def n_joints(self) -> int: ...
    @property
    def sha256(self) -> str: ...
    @property
    def q(self) -> npt.NDArray[np.float64]:
        """(M, n_joints) [rad]."""
    @property
    def position_m(self) -> npt.NDArray[np.float64]:
        """(M, 3) [m], NaN where not measured."""
    @property
    def poses(self) -> npt.NDArray[np.float64]:
        """(M, 4, 4) [m], NaN for rows without a measured orientation."""
    @property
    def lines(self) -> List[int]: ...
    @property
    def pose_ids(self) -> List[Optional[str]]: ...
    def write(self, path: _Path) -> None: ...
    def __len__(self) -> int: ...

def aria(variant: str = "nominal") -> Robot:
    """ARIA: "nominal" (Table 1), "virtual_truth" (Table 3) or "real_identified"."""
def load_robot(
    source: _Path, base_link: Optional[str] = None, tip_link: Optional[str] = None
) -> Robot: ...
def read_measurements(
    path: _Path, robot: Robot, require_pose: bool = False, allow_out_of_limits: bool = False
) -> Measurements: ...
def calibrate(
    data: Union[_Path, Measurements],
    robot: Robot,
    *,
    algorithm: str = "ols",
    effects: Sequence[str] = (),
    bounds_mm: float = 5.0,
    bounds_deg: float = 5.0,
    weight_pos: Optional[float] = None,
    weight_rot: Optional[float] = None,
    sigma_pos_mm: Optional[float] = None,
    sigma_rot_deg: Optional[float] = None,
    orientation_error: str = "exact",
    allow_data_deficiency: bool = False,
    max_iterations: int = 200,
    robust: Optional[str] = None,
    robust_tuning: Optional[float] = None,
    prior: Optional[Tuple[float, float]] = None,
    init_frames: bool = False,
    allow_out_of_limits: bool = False,
    allow_implausible: bool = False,
) -> Robot: ...
def crossval(
    data: Union[_Path, Measurements],
    robot: Robot,
    *,
    effects: Sequence[str] = (),
    init_frames: bool = False,
    folds: int = 5,
    seed: int = 1,
    geometry: Sequence[str] = ("theta0", "d", "a", "alpha"),
    sigma_pos_mm: Optional[float] = None,
    sigma_rot_deg: Optional[float] = None,
    unit_weights: bool = False,
    robust: Optional[str] = None,
    max_iterations: int = 200,
    prior: Union[None, Tuple[float, float], str] = None,
    allow_out_of_limits: bool = False,
    constraints: Optional[_Path] = None,
    group_by: Optional[str] = None,
) -> Dict[str, Any]:
    """K-fold cross-validation by pose_id, as ``kincal crossval``; returns the dict of
    ``kincal crossval --json`` (held-out and in-sample RMS/max in mm and degrees, per fold,
    per pose, noise floor, outliers; weights in 1/m² and 1/rad²). ``prior``: ``(mm, deg)``
    or ``"auto"``. Target/plane rows (or a ``constraints`` TOML file): whole groups held out
    by ``group_by`` (``"session"``, ``"target"``, ``"pose_id"``), scored in mm about each
    target/plane re-estimated from the held-out contacts, as ``kincal crossval
    --constraints``."""

def diagnose(
    data: Union[_Path, Measurements],
    robot: Robot,
    *,
    sigma_pos_mm: Optional[float] = None,
    sigma_rot_deg: Optional[float] = None,
    candidates: Sequence[str] = (),
    pairs: bool = True,
    folds: int = 5,
    seed: Optional[int] = None,
    allow_out_of_limits: bool = False,
    constraints: Optional[_Path] = None,
) -> Dict[str, Any]:
    """The sim-to-real diagnosis of ``kincal diagnose``; returns REPORT.json's dict
    (spec/cli.md) without ``files``: ``verdict`` (``status``, ``effects``, ``reason``,
    ``parameters`` in SI units), ``noise_floor``, ``baseline``, ``candidates``, ``where``;
    each field names its unit (``_mm``, ``_deg``). ``sigma_*``: the instrument's 1σ per axis
    [mm, deg] (default: from repeated pose_ids); ``seed``: the fold seed (default: the
    CLI's). Target/plane rows (or a ``constraints`` TOML file): leave-one-session-out, as
    ``kincal diagnose --constraints`` (its REPORT.json: ``method``
    ``"leave_one_group_out_contacts"``; ``sigma_pos_mm`` states the floor)."""

_Box = Tuple[float, float, float, float, float, float]

def select_poses(
    robot: Robot,
    *,
    design: str = "standard",
    m: int = 10,
    index: str = "o",
    pool: int = 2000,
    starts: int = 8,
    refine: int = 200,
    workspace: _Box = (-1.0, -1.0, 0.05, 1.0, 1.0, 1.5),
    cube_mm: float = 100.0,
    tolerance: float = 0.1,
    min_dexterity: float = 0.08,
    robust_robots: int = 32,
    compare_random: int = 1000,
    length_error_mm: float = 5.0,
    angle_error_deg: float = 5.0,
    region: Optional[_Box] = None,
    working_rpy_deg: Optional[Sequence[Tuple[float, float, float]]] = None,
    cone_deg: float = 20.0,
    grid: Tuple[int, int, int] = (4, 4, 2),
    margin_deg: float = 5.0,
    seed: int = 1,
    out: Optional[_Path] = None,
) -> Dict[str, Any]:
    """m observability-optimal poses, as ``kincal select-poses``: ``design`` ``"standard"``
    (end effector in ``workspace`` [m]), ``"region"`` (working ``region`` [m], cone
    ``cone_deg`` about ``working_rpy_deg`` [deg], reachable by ``robust_robots`` random
    robots off by ``length_error_mm``/``angle_error_deg``) or ``"clustering"`` (cubes of
    ``cube_mm``). Returns ``q`` (m, N) [rad], ``poses`` (m, 4, 4) [m], ``indices``,
    ``random_indices`` (arrays over ``compare_random`` random sets), ``pool_size``,
    ``admitted``, ``min_margin_deg``, ``name``, ``note``. ``out``: the command's pose CSV."""

def design_tool(
    robot: Robot,
    *,
    m: int = 10,
    starts: int = 8,
    min_dexterity: float = 0.08,
    robust_robots: int = 32,
    plate_z_mm: Optional[Sequence[float]] = None,
    grid_mm: float = 25.0,
    rolls_deg: Sequence[float] = (-150.0, -160.0),
    yaws_deg: Sequence[float] = (-90.0, 0.0, 90.0, 180.0),
    min_separation_mm: float = 60.0,
    objectives: Sequence[str] = ("pv", "pv01", "o", "dopt"),
    baseline: Optional[Tuple[str, _Path]] = None,
    screen_runs: int = 1000,
    runs: int = 10000,
    length_error_mm: float = 5.0,
    angle_error_deg: float = 5.0,
    noise_pos_mm: float = 0.05,
    noise_rot_deg: float = 0.02,
    tool_tol_mm: float = 0.05,
    tool_tol_deg: float = 0.02,
    region: Optional[_Box] = None,
    working_rpy_deg: Optional[Sequence[Tuple[float, float, float]]] = None,
    cone_deg: float = 20.0,
    grid: Tuple[int, int, int] = (4, 4, 2),
    margin_deg: float = 5.0,
    seed: int = 1,
    out: Optional[_Path] = None,
) -> Dict[str, Any]:
    """A calibration tool that beats ``baseline`` (``(name, tool file)``; ARIA: Table 2), as
    ``kincal design-tool``: sockets on a plate at ``plate_z_mm`` [mm], grid ``grid_mm``
    [mm], orientations from ``rolls_deg`` × ``yaws_deg`` [deg], ``min_separation_mm`` apart.
    Returns ``kincal design-tool --json``'s dict (``plate_z_m`` [m], ``objective``,
    ``screening_score``, ``beats_baseline``, ``designs`` in mm and degrees) plus ``tool``
    (``q`` [rad], ``poses`` [m]) and ``plate_sockets``. ``out``: the command's tool file."""

def evaluate_designs(
    robot: Robot,
    *,
    designs: Sequence[str] = ("standard", "clustering", "table2"),
    tools: Sequence[Tuple[str, _Path]] = (),
    commanded: Sequence[Tuple[str, _Path]] = (),
    plates: Sequence[Tuple[str, float, int, int]] = (),
    runs: int = 10000,
    m: int = 10,
    index: str = "o",
    pool: int = 2000,
    starts: int = 8,
    refine: int = 200,
    workspace: _Box = (-1.0, -1.0, 0.05, 1.0, 1.0, 1.5),
    cube_mm: float = 100.0,
    tolerance: float = 0.1,
    min_dexterity: float = 0.08,
    robust_robots: int = 32,
    length_error_mm: float = 5.0,
    angle_error_deg: float = 5.0,
    noise_pos_mm: float = 0.05,
    noise_rot_deg: float = 0.02,
    tool_tol_mm: float = 0.05,
    tool_tol_deg: float = 0.02,
    region: Optional[_Box] = None,
    working_rpy_deg: Optional[Sequence[Tuple[float, float, float]]] = None,
    cone_deg: float = 20.0,
    grid: Tuple[int, int, int] = (4, 4, 2),
    margin_deg: float = 5.0,
    seed: int = 1,
) -> Dict[str, Any]:
    """Monte-Carlo comparison of designs on the same random robots, as ``kincal
    evaluate-designs``: returns its ``--json`` dict (per design the worst-pose e_p [mm] and
    e_φ [deg] median, p95, max, mean; scenario in m and rad). ``plates``: socket plates
    ``(name, d_mm, placements, contacts)`` as ``--plate NAME=D_MM,PLACEMENTS,CONTACTS``
    (sockets ``d_mm`` [mm] apart); with plates the dict has ``plates``: per design and plate
    the absolute and registered worst-pose errors [mm, deg]."""
