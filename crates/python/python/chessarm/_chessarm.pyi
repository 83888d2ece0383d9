"""Type stubs of the compiled part of chessarm (``chessarm._chessarm``)."""

from os import PathLike
from typing import Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

ArrayLike = Union[npt.ArrayLike, Sequence[float], Sequence[Sequence[float]]]
"""One joint state, shape (4,), or many, shape (n, 4)."""

class Error(Exception):
    """Every error of chessarm's own (not a wrong argument, which is ValueError)."""

class ModelError(Error):
    """A setup file or URDF that chessarm cannot use."""

class UnreachableError(Error):
    """Inverse kinematics has no solution (reach or joint limits)."""

class DynamicsError(Error):
    """A dynamics computation failed (e.g. M(q) not positive definite)."""

class CommandError(Error):
    """A chessarm command failed (the CLI's one-line message)."""

def run_cli(args: List[str]) -> Tuple[str, str]:
    """Runs ``chessarm ARGS --json`` in this process: (stdout, stderr) of the command."""

class Arm:
    """A 4-DOF arm (base yaw, three pitch joints) in standard DH with its links' masses."""

    @staticmethod
    def default() -> "Arm":
        """The report's arm (the CLI's default)."""
    @staticmethod
    def from_file(path: Union[str, "PathLike[str]"]) -> "Arm":
        """The arm of a setup file (TOML), as ``chessarm --arm FILE``."""
    @staticmethod
    def from_urdf(
        path: Union[str, "PathLike[str]"],
        lock: Optional[Dict[str, float]] = None,
        tool: Optional[str] = None,
        tool_offset: Optional[Sequence[float]] = None,
    ) -> "Arm":
        """The arm of a URDF file, as ``chessarm --urdf FILE [--lock …] [--tool …] [--tool-offset …]``:
        ``lock`` holds joints at values (rad, m for a prismatic joint), ``tool`` names the tool
        link, ``tool_offset`` the tool point in its frame (m). Every array in and out is in the
        file's own joint convention (a base yaw about −z included)."""
    @property
    def joint_names(self) -> List[str]: ...
    @property
    def dh(self) -> npt.NDArray[np.float64]:
        """Rows (a m, alpha rad, d m, theta_offset rad), one per joint: shape (4, 4)."""
    def to_urdf(self) -> str: ...
    def fk(self, q: ArrayLike) -> npt.NDArray[np.float64]:
        """Tool-frame pose, 4×4 homogeneous (m): shape (4, 4), or (n, 4, 4) for n states."""
    def tool_point(self, q: ArrayLike) -> npt.NDArray[np.float64]:
        """(x, y, z, pitch) in m and rad: shape (4,) or (n, 4)."""
    def jacobian(self, q: ArrayLike) -> npt.NDArray[np.float64]:
        """Tool-tip geometric Jacobian (v; ω) in the base frame: shape (6, 4) or (n, 6, 4)."""
    def ik(self, xyz: Sequence[float], pitch: float = -1.5707963267948966) -> npt.NDArray[np.float64]:
        """Joint angles (rad) putting the tool tip at xyz (m) with pitch (rad, default −π/2)."""
    def mass_matrix(self, q: ArrayLike) -> npt.NDArray[np.float64]:
        """M(q), kg·m²: shape (4, 4) or (n, 4, 4)."""
    def rnea(self, q: ArrayLike, v: ArrayLike, a: ArrayLike) -> npt.NDArray[np.float64]:
        """τ = M(q) a + C(q, v) v + g(q), N·m: shape (4,) or (n, 4)."""
    def aba(self, q: ArrayLike, v: ArrayLike, tau: ArrayLike) -> npt.NDArray[np.float64]:
        """The inverse of rnea: a = M(q)⁻¹ (τ − C(q, v) v − g(q)), rad/s²: (4,) or (n, 4)."""
    def forward_dynamics(self, q: ArrayLike, v: ArrayLike, tau: ArrayLike) -> npt.NDArray[np.float64]:
        """The plant's: a = M(q)⁻¹ (τ + τ_friction(v) − C(q, v) v − g(q)), rad/s²."""
    def gravity(self, q: ArrayLike) -> npt.NDArray[np.float64]:
        """g(q), N·m: shape (4,) or (n, 4)."""
    def coriolis(self, q: ArrayLike, v: ArrayLike) -> npt.NDArray[np.float64]:
        """C(q, v), N·m·s/rad: shape (4, 4) or (n, 4, 4)."""
