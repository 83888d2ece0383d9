"""chessarm: from a chess move to the joint torques of a 4-DOF arm, verified in simulation.

The arm's kinematics and dynamics on NumPy arrays (SI units: m, rad, rad/s, rad/s², N·m), the
same numbers as the ``chessarm`` command::

    import chessarm
    arm = chessarm.Arm.default()            # or Arm.from_file("my-arm.toml"), Arm.from_urdf(path)
    M = arm.mass_matrix([0.1, 0.5, -0.3, 0.2])
    tau = arm.rnea(Q, V, A)                 # Q, V, A of shape (n, 4): n states at once
    game = chessarm.play(moves="e4 e5 Nf3")  # the CLI's commands, results as NumPy arrays
    rows = chessarm.tune(kp="100..900:10", kd="10..60:10")
"""

from ._chessarm import (  # noqa: F401
    Arm,
    CommandError,
    DynamicsError,
    Error,
    ModelError,
    UnreachableError,
    __version__,
)
from ._commands import Game, Plan, Result, Simulation, Sweep, Table, play, plan, robustness, run, simulate, tune

__all__ = [
    "Arm",
    "Error",
    "ModelError",
    "UnreachableError",
    "DynamicsError",
    "CommandError",
    "run",
    "plan",
    "simulate",
    "play",
    "tune",
    "robustness",
    "Result",
    "Plan",
    "Simulation",
    "Game",
    "Sweep",
    "Table",
    "__version__",
]
