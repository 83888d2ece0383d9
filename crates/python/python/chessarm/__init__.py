"""chessarm: from a chess move to the joint torques of a 4-DOF arm, verified in simulation.

The arm's kinematics and dynamics on NumPy arrays (SI units: m, rad, rad/s, rad/s², N·m), the
same numbers as the ``chessarm`` command::

    import chessarm
    arm = chessarm.Arm.default()            # or Arm.from_file("my-arm.toml"), Arm.from_urdf(path)
    M = arm.mass_matrix([0.1, 0.5, -0.3, 0.2])
    tau = arm.rnea(Q, V, A)                 # Q, V, A of shape (n, 4): n states at once

The studies in memory, on a setup's objects (MuJoCo's habit: the model and the data are
objects)::

    setup = chessarm.Setup.default()         # or Setup.from_file(…), Setup.from_urdf(…)
    plan = chessarm.plan(setup, moves="e4 e5")           # plan.t, plan.q (n, 4), plan.tool (n, 3)
    sim = chessarm.simulate(setup, controller="pd")      # sim.q, sim.tau, sim.max_tip_error
    game = chessarm.play(setup, moves="e4 e5 Nf3")       # game.plies[0].placement_error
    stepper = chessarm.Simulator(setup, dt=1e-3)         # stepper.step_torque(tau), stepper.state

    sweep = chessarm.tune(setup, kp="100..900:10", kd="10..60:10")   # sweep.max_tip_error, sweep.best()
    trials = chessarm.robustness(setup, trials=20, sensors="hobby")  # trials.place_error, .statistics

Without a setup, ``plan``, ``simulate``, ``play``, ``tune`` and ``robustness`` run the CLI's
commands (as ``chessarm.cli``)::

    game = chessarm.play(moves="e4 e5 Nf3")  # the CLI's files, loaded as NumPy arrays
    rows = chessarm.tune(kp="100..900:10", kd="10..60:10")
"""

from ._chessarm import (  # noqa: F401
    Arm,
    Campaign,
    ChessarmWarning,
    CommandError,
    DynamicsError,
    Error,
    Game,
    GameError,
    ModelError,
    Plan,
    PlanError,
    PlannedMove,
    Ply,
    Run,
    Setup,
    Simulation,
    SimulationError,
    Simulator,
    Tuning,
    UnreachableError,
    __version__,
)
from . import cli  # noqa: F401
from ._commands import Result, Sweep, Table, run
from ._studies import play, plan, robustness, simulate, tune

__all__ = [
    "Arm",
    "Setup",
    "Simulator",
    "Error",
    "ModelError",
    "UnreachableError",
    "DynamicsError",
    "CommandError",
    "PlanError",
    "SimulationError",
    "GameError",
    "ChessarmWarning",
    "plan",
    "simulate",
    "play",
    "Plan",
    "PlannedMove",
    "Simulation",
    "Run",
    "Game",
    "Ply",
    "Tuning",
    "Campaign",
    "cli",
    "run",
    "tune",
    "robustness",
    "Result",
    "Sweep",
    "Table",
    "__version__",
]
