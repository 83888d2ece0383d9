"""Type stubs of the compiled part of chessarm (``chessarm._chessarm``)."""

from os import PathLike
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

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

PathArg = Union[str, "PathLike[str]"]
PerJoint = Union[float, Sequence[float], npt.ArrayLike]
"""One number for every joint, or 4 (one per joint)."""
Array = npt.NDArray[np.float64]

class PlanError(Error):
    """A motion chessarm cannot plan (a table the arm cannot serve, a path it cannot follow)."""

class SimulationError(Error):
    """A simulation that failed (it diverged, a controller that cannot be built)."""

class GameError(Error):
    """A game that stopped (a move the arm cannot make, an engine that failed)."""

class ChessarmWarning(UserWarning):
    """What chessarm says about a setup or a study (a URDF's notes, angles outside the limits)."""

class Setup:
    """The arm, board, pieces, motion limits and actuators of a study, resolved once as the
    ``chessarm`` command resolves its global flags (``--arm``, ``--urdf``, ``--lock``, ``--tool``,
    ``--tool-offset``, ``--actuator``, ``--servo-command``, ``--bus-rate``). A URDF's notes and
    warnings are given as :class:`ChessarmWarning` (and kept in ``notes``)."""

    def __init__(
        self,
        arm: Optional[PathArg] = None,
        urdf: Optional[PathArg] = None,
        *,
        lock: Optional[Dict[str, float]] = None,
        tool: Optional[str] = None,
        tool_offset: Optional[Sequence[float]] = None,
        actuator: Optional[Union[str, Sequence[str]]] = None,
        servo_command: Optional[Union[str, Sequence[str]]] = None,
        bus_rate: Optional[float] = None,
    ) -> None: ...
    @staticmethod
    def default(
        *,
        actuator: Optional[Union[str, Sequence[str]]] = None,
        servo_command: Optional[Union[str, Sequence[str]]] = None,
        bus_rate: Optional[float] = None,
    ) -> "Setup":
        """The report's arm, board and pieces (the CLI's default)."""
    @staticmethod
    def from_file(
        path: PathArg,
        *,
        actuator: Optional[Union[str, Sequence[str]]] = None,
        servo_command: Optional[Union[str, Sequence[str]]] = None,
        bus_rate: Optional[float] = None,
    ) -> "Setup":
        """The setup of a setup file (TOML), as ``chessarm --arm FILE``."""
    @staticmethod
    def from_urdf(
        path: PathArg,
        *,
        lock: Optional[Dict[str, float]] = None,
        tool: Optional[str] = None,
        tool_offset: Optional[Sequence[float]] = None,
        actuator: Optional[Union[str, Sequence[str]]] = None,
        arm: Optional[PathArg] = None,
        servo_command: Optional[Union[str, Sequence[str]]] = None,
        bus_rate: Optional[float] = None,
    ) -> "Setup":
        """The arm of a URDF, as ``chessarm --urdf FILE [--arm SETUP]``."""
    @property
    def arm(self) -> Arm:
        """The arm's kinematics and dynamics, in this setup's joint convention."""
    @property
    def joint_names(self) -> List[str]: ...
    @property
    def actuator_names(self) -> List[str]: ...
    @property
    def servos(self) -> bool:
        """Whether the joints take goal positions (servos, steppers)."""
    @property
    def servo_commands(self) -> List[str]: ...
    @property
    def bus_rate(self) -> float: ...
    @property
    def torque_limits(self) -> Array:
        """N·m, shape (4,)."""
    @property
    def velocity_limits(self) -> Array:
        """rad/s, shape (4,)."""
    @property
    def joint_limits(self) -> Array:
        """(lower, upper) rad per joint, shape (4, 2)."""
    @property
    def square_size(self) -> float:
        """m."""
    @property
    def board(self) -> Dict[str, Any]:
        """square_size, center (x, y), surface_height, yaw, base_clearance (m, rad), squares_turned (bool)."""
    @property
    def pieces(self) -> Dict[str, Dict[str, float]]:
        """By kind: height, base_diameter, grip_height (m), mass (kg)."""
    def square_center(self, square: str) -> Array:
        """The centre of a square ("e4") on the board's surface, m: shape (3,)."""
    @property
    def sensor_profiles(self) -> List[str]: ...
    @property
    def scenarios(self) -> List[str]: ...
    @property
    def path(self) -> Optional[str]: ...
    @property
    def urdf_path(self) -> Optional[str]: ...
    @property
    def base_link(self) -> str: ...
    @property
    def notes(self) -> List[str]: ...
    def to_toml(self) -> str:
        """The setup as a setup file, as ``chessarm arm`` prints it."""

class PlannedMove:
    """One move of a plan of moves."""

    ply: int
    san: str
    uci: str
    kind: str
    start: float
    duration: float
    events: List[Tuple[float, str]]
    longest_limit: Optional[Tuple[str, float]]
    phases: Dict[str, float]

class Plan:
    """A planned motion sampled every ``dt`` s: the joints' trajectory (``t`` (n,), ``q``,
    ``qd``, ``qdd`` (n, 4)) and the tool tip's path (``tool``, ``tool_velocity``,
    ``tool_acceleration`` (n, 3)); read-only arrays."""

    kind: str
    name: str
    fen: Optional[str]
    dt: float
    duration: float
    t: Array
    q: Array
    qd: Array
    qdd: Array
    tool: Array
    tool_velocity: Array
    tool_acceleration: Array
    events: List[Tuple[float, str]]
    plies: List[PlannedMove]
    def __len__(self) -> int: ...

class Run:
    """One controller's simulated run: every step (``t`` (n,); ``q``, ``qd``, ``q_des``,
    ``qd_des``, ``qdd_des``, ``q_estimate``, ``qd_estimate``, ``tau`` (n, 4); ``tip``,
    ``tip_desired`` (n, 3)) and the metrics (m, rad, N·m)."""

    controller: str
    kp: Optional[Array]
    kd: Optional[Array]
    ki: Optional[Array]
    t: Array
    q: Array
    qd: Array
    q_des: Array
    qd_des: Array
    qdd_des: Array
    q_estimate: Array
    qd_estimate: Array
    tau: Array
    tip: Array
    tip_desired: Array
    servo_goal: Optional[Array]
    servo_target: Optional[Array]
    rms_tip_error: float
    max_tip_error: float
    rms_joint_error: Array
    max_joint_error: Array
    placement_error: Optional[float]
    tip_error_at_events: List[Tuple[float, str, float]]
    peak_torque: Array
    saturated_samples: int
    saturated_per_joint: List[int]
    duration: float
    steps: int
    tracked_steps: int
    wall_time: float
    @property
    def summary(self) -> Dict[str, Any]:
        """The command line's summary.json entry of this controller (tip errors in mm)."""
    def __len__(self) -> int: ...

class Simulation:
    """A scenario simulated with one or more controllers; with one, its :class:`Run`'s
    attributes are the simulation's own (``sim.q`` is ``sim.runs["pd"].q``)."""

    runs: Dict[str, Run]
    controllers: List[str]
    plan: Plan
    scenario: str
    dt: float
    control_rate: float
    notes: List[str]
    @property
    def conditions(self) -> Optional[Dict[str, Any]]: ...
    def __getattr__(self, name: str) -> Any: ...

class Ply:
    """One ply of a game (SI units); robot moves also have every 10th simulated step."""

    ply: int
    san: str
    uci: str
    kind: str
    by: str
    tasks: List[str]
    start: float
    duration: float
    planned_duration: float
    max_tip_error: Optional[float]
    place_errors: List[float]
    placement_error: Optional[float]
    clearance: Optional[float]
    clearance_part: Optional[str]
    clearance_obstacle: Optional[str]
    executed_clearance: Optional[float]
    contact: bool
    clearance_adjustments: List[str]
    pace: Optional[float]
    too_near_tries: List[float]
    misplaced: List[str]
    waits: Tuple[int, float, float, int]
    saturated_samples: Optional[int]
    peak_torque: Optional[Array]
    t: Optional[Array]
    q: Optional[Array]
    q_des: Optional[Array]
    tau: Optional[Array]
    tip: Optional[Array]
    tip_desired: Optional[Array]

class Game:
    """A game played with the simulated arm."""

    result: str
    result_reason: str
    plies: List[Ply]
    misplaced: List[Dict[str, Any]]
    final_fen_rules: str
    final_fen_physical: str
    final_table: List[Dict[str, Any]]
    robot_time: float
    wall_time: float
    controller: str
    notes: List[str]
    @property
    def placement_errors(self) -> Array: ...
    def __len__(self) -> int: ...

class Simulator:
    """The closed loop one step at a time, in the setup's joint convention: ``step_torque(tau)``
    applies a torque for one step in the plant; ``step(q_des, qd_des, qdd_des)`` runs the
    controller (sampled every control period, clipped, through the sensors) towards a reference."""

    controller: Optional[str]
    def __init__(
        self,
        setup: Setup,
        *,
        dt: float = 0.001,
        controller: Optional[str] = "pd",
        kp: Optional[PerJoint] = None,
        kd: Optional[PerJoint] = None,
        ki: Optional[PerJoint] = None,
        control_rate: Optional[float] = None,
        integrator: str = "rkn4",
        sensors: Optional[PathArg] = None,
        estimator: Optional[str] = None,
        seed: int = 0,
        torque_lag: Optional[PerJoint] = None,
        plant: Optional[PathArg] = None,
        uncertainty: Optional[PathArg] = None,
        controller_knows_friction: Optional[bool] = None,
        kalman_acceleration_noise: Optional[float] = None,
        lowpass_time_constant: Optional[float] = None,
        q0: Optional[Sequence[float]] = None,
    ) -> None: ...
    def reset(self, q: Optional[Sequence[float]] = None, qd: Optional[Sequence[float]] = None) -> None: ...
    def step_torque(self, tau: Sequence[float], *, clip: bool = True) -> Array: ...
    def step(
        self, q_des: Sequence[float], qd_des: Optional[Sequence[float]] = None, qdd_des: Optional[Sequence[float]] = None
    ) -> Array: ...
    def grip(self, mass: float, *, controller_knows: bool = False) -> None: ...
    def release(self) -> None: ...
    @property
    def t(self) -> float: ...
    @property
    def steps(self) -> int: ...
    @property
    def dt(self) -> float: ...
    @property
    def control_period(self) -> float: ...
    @property
    def state(self) -> Tuple[Array, Array]: ...
    @property
    def q(self) -> Array: ...
    @property
    def qd(self) -> Array: ...
    @property
    def estimate(self) -> Tuple[Array, Array]: ...
    @property
    def tip(self) -> Array: ...
    @property
    def torque_limits(self) -> Array: ...
    @property
    def saturated_samples(self) -> int: ...

def plan(
    setup: Setup,
    scenario: Optional[str] = None,
    *,
    moves: Optional[str] = None,
    fen: Optional[str] = None,
    dt: float = 0.001,
    timing: Optional[str] = None,
    motion: Optional[Dict[str, Any]] = None,
) -> Plan: ...
def simulate(
    setup: Setup,
    plan: Optional[Plan] = None,
    *,
    scenario: Optional[str] = None,
    controller: Optional[Union[str, Sequence[str]]] = None,
    kp: Optional[PerJoint] = None,
    kd: Optional[PerJoint] = None,
    ki: Optional[PerJoint] = None,
    sensors: Optional[PathArg] = None,
    estimator: Optional[str] = None,
    seed: int = 0,
    trial_seed: Optional[int] = None,
    dt: float = 0.001,
    control_rate: Optional[float] = None,
    integrator: str = "rkn4",
    q0: Optional[Sequence[float]] = None,
    payload_mass: float = 0.0,
    controller_knows_payload: bool = False,
    controller_knows_friction: Optional[bool] = None,
    tracking_from: float = 0.0,
    torque_lag: Optional[PerJoint] = None,
    plant: Optional[PathArg] = None,
    uncertainty: Optional[PathArg] = None,
    kalman_acceleration_noise: Optional[float] = None,
    lowpass_time_constant: Optional[float] = None,
) -> Simulation: ...
def play(
    setup: Setup,
    moves: Optional[str] = None,
    *,
    pgn: Optional[PathArg] = None,
    game: int = 1,
    fen: Optional[str] = None,
    engine: Optional[str] = None,
    plies: int = 120,
    depth: int = 3,
    movetime: int = 100,
    robot: str = "both",
    controller: Optional[str] = None,
    kp: Optional[PerJoint] = None,
    kd: Optional[PerJoint] = None,
    ki: Optional[PerJoint] = None,
    sensors: Optional[PathArg] = None,
    estimator: Optional[str] = None,
    seed: int = 0,
    trial_seed: Optional[int] = None,
    dt: float = 0.001,
    integrator: str = "rkn4",
    tolerance: float = 0.005,
    timing: Optional[str] = None,
    motion: Optional[Dict[str, Any]] = None,
    controller_knows_payload: bool = False,
    payload_feedforward: bool = True,
    release_by_clock: bool = False,
    in_position_band: Optional[float] = None,
    in_position_speed: Optional[float] = None,
    in_position_timeout: Optional[float] = None,
    controller_knows_friction: Optional[bool] = None,
    torque_lag: Optional[PerJoint] = None,
    plant: Optional[PathArg] = None,
    uncertainty: Optional[PathArg] = None,
    kalman_acceleration_noise: Optional[float] = None,
    lowpass_time_constant: Optional[float] = None,
    keep_pace: bool = False,
) -> Game: ...

GainRangeArg = Union[str, Tuple[float, float, int]]

class Tuning:
    """A gain sweep's candidates in sweep order (SI: tip errors in m)."""

    @property
    def index(self) -> Array: ...
    @property
    def kp(self) -> Array: ...
    @property
    def kd(self) -> Array: ...
    @property
    def ki(self) -> Array: ...
    @property
    def servo_command(self) -> List[Optional[str]]: ...
    @property
    def p_gain(self) -> Array: ...
    @property
    def status(self) -> List[str]: ...
    @property
    def max_tip_error(self) -> Array: ...
    @property
    def rms_tip_error(self) -> Array: ...
    @property
    def place_error(self) -> Array: ...
    @property
    def rms_joint_error(self) -> Array: ...
    @property
    def max_joint_error(self) -> Array: ...
    @property
    def peak_torque(self) -> Array: ...
    @property
    def peak_torque_ratio(self) -> Array: ...
    @property
    def saturated_samples(self) -> List[int]: ...
    @property
    def misplaced(self) -> List[int]: ...
    @property
    def sweep_size(self) -> int: ...
    @property
    def servos(self) -> bool: ...
    @property
    def tracking_from(self) -> float: ...
    @property
    def wall_time(self) -> float: ...
    def best(self, metric: str = "max-tip-error", top: int = 5) -> List[int]: ...
    def edge_warning(self, metric: str = "max-tip-error") -> Optional[str]: ...
    def __len__(self) -> int: ...

class Campaign:
    """A robustness campaign's rows, one per trial and controller (SI: errors in m)."""

    @property
    def trial(self) -> List[int]: ...
    @property
    def trial_seed(self) -> List[int]: ...
    @property
    def controller(self) -> List[str]: ...
    @property
    def status(self) -> List[str]: ...
    @property
    def success(self) -> List[bool]: ...
    @property
    def place_error(self) -> Array: ...
    @property
    def pieces(self) -> List[int]: ...
    @property
    def misplaced(self) -> List[int]: ...
    @property
    def max_tip_error(self) -> Array: ...
    @property
    def rms_tip_error(self) -> Array: ...
    @property
    def peak_torque(self) -> Array: ...
    @property
    def peak_torque_ratio(self) -> Array: ...
    @property
    def saturated_samples(self) -> List[int]: ...
    @property
    def rms_rate_estimate_error(self) -> Array: ...
    @property
    def robot_time(self) -> Array: ...
    @property
    def plies(self) -> List[int]: ...
    @property
    def contacts(self) -> List[int]: ...
    @property
    def clearance(self) -> Array: ...
    @property
    def drawn(self) -> Dict[str, Array]: ...
    @property
    def statistics(self) -> List[Dict[str, Any]]: ...
    @property
    def wall_time(self) -> float: ...
    def __len__(self) -> int: ...

def tune(
    setup: Setup,
    *,
    kp: Optional[GainRangeArg] = None,
    kd: Optional[GainRangeArg] = None,
    ki: Optional[GainRangeArg] = None,
    p_gain: Optional[GainRangeArg] = None,
    controller: str = "pd",
    scenario: Optional[str] = None,
    pgn: Optional[PathArg] = None,
    game: int = 1,
    payload_mass: float = 0.0,
    controller_knows_payload: bool = False,
    q0: Optional[Sequence[float]] = None,
    tracking_from: Optional[float] = None,
    sensors: Optional[PathArg] = None,
    estimator: Optional[str] = None,
    seed: int = 0,
    torque_lag: Optional[PerJoint] = None,
    plant: Optional[PathArg] = None,
    uncertainty: Optional[PathArg] = None,
    controller_knows_friction: Optional[bool] = None,
    kalman_acceleration_noise: Optional[float] = None,
    lowpass_time_constant: Optional[float] = None,
    integrator: str = "rkn4",
    shard: Optional[Tuple[int, int]] = None,
    threads: Optional[int] = None,
) -> Tuning: ...
def robustness(
    setup: Setup,
    *,
    trials: int = 100,
    controller: Optional[Union[str, Sequence[str]]] = None,
    kp: Optional[PerJoint] = None,
    kd: Optional[PerJoint] = None,
    ki: Optional[PerJoint] = None,
    scenario: Optional[str] = None,
    pgn: Optional[PathArg] = None,
    game: int = 1,
    payload_mass: Optional[float] = None,
    controller_knows_payload: bool = False,
    tolerance: float = 0.005,
    sensors: Optional[PathArg] = None,
    estimator: Optional[str] = None,
    seed: int = 0,
    torque_lag: Optional[PerJoint] = None,
    plant: Optional[PathArg] = None,
    uncertainty: Optional[PathArg] = None,
    controller_knows_friction: Optional[bool] = None,
    kalman_acceleration_noise: Optional[float] = None,
    lowpass_time_constant: Optional[float] = None,
    integrator: str = "rkn4",
    shard: Optional[Tuple[int, int]] = None,
    threads: Optional[int] = None,
) -> Campaign: ...
