"""chessarm: from a chess move to the joint torques of a 4-DOF arm, verified in simulation.

The arm's kinematics and dynamics on NumPy arrays (SI units: m, rad, rad/s, rad/s², N·m), the
same numbers as the ``chessarm`` command::

    import chessarm
    arm = chessarm.Arm.default()            # or Arm.from_file("my-arm.toml"), Arm.from_urdf(path)
    M = arm.mass_matrix([0.1, 0.5, -0.3, 0.2])
    tau = arm.rnea(Q, V, A)                 # Q, V, A of shape (n, 4): n states at once
"""

from ._chessarm import (  # noqa: F401
    Arm,
    DynamicsError,
    Error,
    ModelError,
    UnreachableError,
    __version__,
)

__all__ = ["Arm", "Error", "ModelError", "UnreachableError", "DynamicsError", "__version__"]
