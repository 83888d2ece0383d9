"""The ``chessarm`` commands run in this process, their files loaded as NumPy arrays.

``chessarm.cli.plan``, ``simulate``, ``play``, ``tune`` and ``robustness`` take the command's
flags as keyword arguments (``payload_mass=0.2`` is ``--payload-mass 0.2``; ``arm=``, ``urdf=``
a setup file or URDF; ``out=`` keeps the folder), so their files equal the command's byte for
byte. ``chessarm.plan``, ``simulate`` and ``play`` called without a :class:`chessarm.Setup`
are these.
"""

from ._commands import Game, Plan, Result, Simulation, Sweep, Table, play, plan, robustness, run, simulate, tune

__all__ = ["run", "plan", "simulate", "play", "tune", "robustness", "Result", "Plan", "Simulation", "Game", "Sweep", "Table"]
