"""``chessarm.plan``, ``simulate``, ``play``, ``tune`` and ``robustness``: in memory when the first argument is a
:class:`chessarm.Setup`, else the command-line form of earlier versions.

In memory (``plan(setup, …)``, ``simulate(setup, …)``, ``play(setup, …)``) the studies run as
library calls on the setup's objects and return :class:`chessarm.Plan`,
:class:`chessarm.Simulation` and :class:`chessarm.Game` with NumPy arrays: no argument list, no
files, the GIL released while they compute. Without a setup the call runs the ``chessarm``
command in this process and loads the files it wrote (``chessarm.cli.plan`` etc., unchanged:
keyword arguments are its flags, ``out=`` keeps its folder).
"""

from __future__ import annotations

from typing import Any, Optional, Union, overload

from . import _chessarm, _commands
from ._chessarm import Campaign, Game, Plan, Setup, Simulation, Tuning


def _in_memory(args: tuple, kwargs: dict) -> bool:
    first = args[0] if args else kwargs.get("setup")
    return isinstance(first, Setup)


@overload
def plan(setup: Setup, scenario: Optional[str] = None, **kwargs: Any) -> Plan: ...
@overload
def plan(moves: Optional[str] = None, **kwargs: Any) -> _commands.Plan: ...
def plan(*args: Any, **kwargs: Any) -> Union[Plan, _commands.Plan]:
    """``plan(setup, scenario="queens-gambit", dt=1e-3)`` or ``plan(setup, moves="e4 e5",
    fen=None, dt=1e-3, timing=None, motion=None)``: a :class:`chessarm.Plan` in memory.

    Without a setup (``plan("e4 e5", out=…, **flags)``): ``chessarm plan`` run in this process,
    its files loaded (:func:`chessarm.cli.plan`)."""
    if _in_memory(args, kwargs):
        return _chessarm.plan(*args, **kwargs)
    return _commands.plan(*args, **kwargs)


@overload
def simulate(setup: Setup, plan: Optional[Plan] = None, **kwargs: Any) -> Simulation: ...
@overload
def simulate(**kwargs: Any) -> _commands.Simulation: ...
def simulate(*args: Any, **kwargs: Any) -> Union[Simulation, _commands.Simulation]:
    """``simulate(setup, plan=None, scenario=…, controller="pd" | ["pd", "pid"], kp=…, kd=…,
    ki=…, sensors=…, estimator=…, seed=0, dt=1e-3, control_rate=…, payload_mass=0, …)``: a
    :class:`chessarm.Simulation` in memory, the numbers of ``chessarm simulate`` with the same
    options.

    Without a setup (``simulate(controller=[…], out=…, **flags)``): ``chessarm simulate`` run in
    this process, its files loaded (:func:`chessarm.cli.simulate`)."""
    if _in_memory(args, kwargs):
        return _chessarm.simulate(*args, **kwargs)
    if args:
        raise TypeError("simulate() without a Setup takes keyword arguments only (the command's flags)")
    return _commands.simulate(**kwargs)


@overload
def play(setup: Setup, moves: Optional[str] = None, **kwargs: Any) -> Game: ...
@overload
def play(pgn: Optional[str] = None, **kwargs: Any) -> _commands.Game: ...
def play(*args: Any, **kwargs: Any) -> Union[Game, _commands.Game]:
    """``play(setup, moves="e4 e5")``, ``play(setup, pgn=path_or_text)`` or ``play(setup,
    engine="builtin", plies=20)``: a :class:`chessarm.Game` in memory.

    Without a setup (``play("game.pgn")``, ``play(moves=…, out=…, **flags)``): ``chessarm play``
    run in this process, its files loaded (:func:`chessarm.cli.play`)."""
    if _in_memory(args, kwargs):
        return _chessarm.play(*args, **kwargs)
    return _commands.play(*args, **kwargs)


def tune(*args: Any, **kwargs: Any) -> Union[Tuning, _commands.Sweep]:
    """``tune(setup, kp="100..900:40", kd="10..60:40", …)`` (or ``p_gain=`` with servos): a
    :class:`chessarm.Tuning` in memory, the numbers of ``chessarm tune`` with the same options.

    Without a setup (``tune(kp=…, kd=…, out=…, **flags)``): ``chessarm tune`` run in this
    process, its CSV loaded (:func:`chessarm.cli.tune`)."""
    if _in_memory(args, kwargs):
        return _chessarm.tune(*args, **kwargs)
    return _commands.tune(*args, **kwargs)


def robustness(*args: Any, **kwargs: Any) -> Union[Campaign, _commands.Result]:
    """``robustness(setup, trials=100, controller=["pd", "pid"], …)``: a
    :class:`chessarm.Campaign` in memory, the rows of ``chessarm robustness`` with the same
    options.

    Without a setup (``robustness(trials=…, out=…, **flags)``): ``chessarm robustness`` run in
    this process, its files loaded (:func:`chessarm.cli.robustness`)."""
    if _in_memory(args, kwargs):
        return _chessarm.robustness(*args, **kwargs)
    return _commands.robustness(*args, **kwargs)
