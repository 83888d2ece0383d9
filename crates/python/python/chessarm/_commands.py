"""The chessarm commands from Python: plan, simulate, play, tune, robustness.

Each runs the CLI's own command in this process (``chessarm._chessarm.run_cli``, the GIL
released), so its numbers are the CLI's, and loads what it wrote into NumPy arrays. Keyword
arguments are the command's flags: ``payload_mass=0.2`` is ``--payload-mass 0.2``, ``True`` a
bare flag, a list a comma-separated value; ``arm=`` and ``urdf=`` name a setup file or URDF.
Without ``out=`` the files go to a temporary folder that is removed once read.
"""

from __future__ import annotations

import csv
import json
import os
import tempfile
from pathlib import Path
from typing import Any, Dict, List, Optional

import numpy as np

from ._chessarm import run_cli


def _value(value: Any) -> str:
    """A flag's value as the CLI reads it: floats in full (also NumPy's), arrays and lists
    comma-separated, paths as paths."""
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value.item()
    if isinstance(value, np.ndarray):
        return ",".join(_value(v) for v in value.ravel().tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, (list, tuple)):
        return ",".join(_value(v) for v in value)
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    return str(value)


def flags(**kwargs: Any) -> List[str]:
    """Command-line flags from keyword arguments (``None`` and ``False`` are left out)."""
    words: List[str] = []
    for key, value in kwargs.items():
        if isinstance(value, np.ndarray) and value.ndim == 0:
            value = value.item()
        if isinstance(value, np.bool_):
            value = bool(value)
        if value is None or value is False:
            continue
        flag = "--" + key.replace("_", "-")
        if value is True:
            words.append(flag)
        else:
            words += [flag, _value(value)]
    return words


def run(command: str, *args: Any, **kwargs: Any) -> Any:
    """Runs ``chessarm COMMAND ARGS… FLAGS… --json``: its JSON result as a dict, or, for the
    commands that print a file (``arm``: TOML, ``urdf``: XML), that text."""
    stdout, _ = run_cli([command, *[_value(a) for a in args], *flags(**kwargs)])
    try:
        return json.loads(stdout)
    except json.JSONDecodeError:
        return stdout


class Table(dict):
    """A CSV's columns by name (NumPy arrays: float where every value is a number, else str),
    with the numbered columns ``q1..q4`` also stacked as ``table["q"]`` of shape (n, 4) and
    ``x, y, z`` as ``table["tip"]`` (``x_des, …`` as ``tip_des``)."""

    def __init__(self, path: Path):
        super().__init__()
        with open(path, newline="") as f:
            rows = list(csv.reader(f))
        header, body = rows[0], rows[1:]
        for i, name in enumerate(header):
            column = [row[i] for row in body]
            try:
                self[name] = np.array([float(v) for v in column])
            except ValueError:
                self[name] = np.array(column)
        groups: Dict[str, List[str]] = {}
        for name in header:
            stem = name.rstrip("0123456789")
            if stem != name and stem not in self:
                groups.setdefault(stem, []).append(name)
        for stem, names in groups.items():
            self[stem] = np.column_stack([self[n] for n in names])
        for suffix in ["", "_des"]:
            axes = [f"{a}{suffix}" for a in "xyz"]
            if all(a in self for a in axes):
                self["tip" + suffix] = np.column_stack([self[a] for a in axes])
        self.path = str(path)
        self._header, self._body = header, body

    def __getattr__(self, name: str) -> np.ndarray:
        try:
            return self[name]
        except KeyError:
            raise AttributeError(name) from None

    def __len__(self) -> int:  # rows, not columns
        first = next(iter(self.values()), np.array([]))
        return len(first)

    def rows(self) -> List[Dict[str, Any]]:
        """The table as one dict per row (numbers as float)."""

        def number(v: str) -> Any:
            try:
                return float(v)
            except ValueError:
                return v

        return [{k: number(v) for k, v in zip(self._header, row)} for row in self._body]


class Result:
    """A command's result: ``summary`` (its JSON, as ``--json`` prints it), ``files`` (paths
    as the command named them), ``tables`` (each CSV it wrote, by file name), ``documents``
    (each JSON file it wrote), ``messages`` (its notes and warnings) and ``out`` (the folder,
    or ``None`` when it was temporary)."""

    def __init__(self, summary: Dict[str, Any], files: List[str], messages: str, kept: Optional[str], folder: str):
        self.summary = summary
        self.files = files
        self.messages = messages
        self.out = kept
        self.tables: Dict[str, Table] = {}
        self.documents: Dict[str, Any] = {}
        for listed in files:
            path = Path(listed)
            paths = sorted(path.iterdir()) if path.is_dir() else [path]
            for file in paths:
                # Named by their path in the output folder: "tune.csv", "moves/001-e2e4.csv".
                key = os.path.relpath(file, folder)
                if file.suffix == ".csv":
                    self.tables[key] = Table(file)
                elif file.suffix == ".json":
                    with open(file) as f:
                        self.documents[key] = json.load(f)

    def __repr__(self) -> str:
        return f"{type(self).__name__}(tables={sorted(self.tables)}, out={self.out!r})"


def _looks_like_a_path(text: str) -> bool:
    """One line naming a file (``games/x.pgn``, ``x.PGN``), not movetext (``1. e4 e5 *``)."""
    line = text.strip()
    if "\n" in line or not line:
        return False
    return line.lower().endswith(".pgn") or os.sep in line or (" " not in line and not line[:1].isdigit())


def pgn_file(pgn: Any, holder: str) -> str:
    """A PGN game given as a path (which must exist) or as PGN text (written into `holder`).
    With Dask the path must exist on every worker; PGN text travels with the task."""
    if not isinstance(pgn, (str, os.PathLike)):
        raise TypeError(f"pgn: a path or PGN text, not {type(pgn).__name__}")
    if isinstance(pgn, os.PathLike) or os.path.exists(pgn) or _looks_like_a_path(pgn):
        if not os.path.exists(os.fspath(pgn)):
            raise FileNotFoundError(f"no PGN file {os.fspath(pgn)!r}")
        return os.fspath(pgn)
    if not pgn.strip():
        raise ValueError("pgn: empty PGN text")
    path = os.path.join(holder, "game.pgn")
    with open(path, "w") as f:
        f.write(pgn)
    return path


def _game(kwargs: Dict[str, Any]) -> Any:
    """`pgn=` (or its CLI name `game_file=`) taken out of `kwargs`; both is an error."""
    pgn, game_file = kwargs.pop("pgn", None), kwargs.pop("game_file", None)
    if pgn is not None and game_file is not None:
        raise ValueError("pgn and game_file name the same game: give one")
    return pgn if pgn is not None else game_file


def _in_folder(command: str, positional: List[str], out: Optional[os.PathLike], kwargs: Dict[str, Any], kind):
    with tempfile.TemporaryDirectory(prefix="chessarm-") as temporary:
        # A game for play/tune/robustness comes as the command's positional PGN file.
        game = _game(kwargs)
        if game is not None:
            positional = [pgn_file(game, temporary), *positional]
        folder = os.fspath(out) if out is not None else os.path.join(temporary, command)
        stdout, stderr = run_cli([command, *positional, *flags(out=folder, **kwargs)])
        summary = json.loads(stdout)
        return kind(summary, summary.get("files", []), stderr, folder if out is not None else None, folder)


class Simulation(Result):
    """``simulate``'s result; ``runs`` maps each controller to its time series (a
    :class:`Table`: ``t`` s, ``q``, ``qd``, ``q_des``, ``qd_des``, ``e`` rad and rad/s of shape
    (n, 4), ``tau`` N·m, ``tip`` and ``tip_des`` m of shape (n, 3))."""

    @property
    def runs(self) -> Dict[str, Table]:
        return {name[: -len(".csv")]: table for name, table in self.tables.items()}


def simulate(*, out: Optional[os.PathLike] = None, **kwargs: Any) -> Simulation:
    """``chessarm simulate``: the seed scenario (or ``scenario=``) under each controller."""
    return _in_folder("simulate", [], out, kwargs, Simulation)


class Plan(Result):
    """``plan``'s result: ``joint`` (``t``, ``q_des``, ``qd_des``, ``qdd_des``), ``cartesian``
    (``t``, ``x``… ``az``) and ``hardware`` (per move: the ROS 2 JointTrajectory JSON and the
    CSV with the gripper column)."""

    @property
    def joint(self) -> Table:
        return self.tables["joint.csv"]

    @property
    def cartesian(self) -> Table:
        return self.tables["cartesian.csv"]

    @property
    def hardware(self) -> Dict[str, Any]:
        return {k: v for k, v in {**self.documents, **self.tables}.items() if k.startswith("hardware")}


def plan(moves: Optional[str] = None, *, out: Optional[os.PathLike] = None, **kwargs: Any) -> Plan:
    """``chessarm plan``: the scenario's path (or the moves', ``moves="e4 e5"``) and joint
    trajectory."""
    return _in_folder("plan", [], out, dict(moves=moves, **kwargs), Plan)


class Game(Result):
    """``play``'s result: ``game`` (game.json: every move, the final table), ``moves`` (each
    robot move's simulated time series, by file name) and ``hardware`` (each robot move's planned
    trajectory for the real arm)."""

    @property
    def game(self) -> Dict[str, Any]:
        return self.documents["game.json"]

    @property
    def moves(self) -> Dict[str, Table]:
        return {k: v for k, v in self.tables.items() if k.startswith("moves")}

    @property
    def hardware(self) -> Dict[str, Any]:
        return {k: v for k, v in {**self.documents, **self.tables}.items() if k.startswith("hardware")}

    @property
    def clearance(self) -> Dict[str, Any]:
        """How near the arm came to the pieces, the table and itself (game.json's, mm): the game's
        ``summary`` (``smallest_mm``, ``contacts``, ``adjusted_moves``, ``by_kind``…), and
        ``moves``, one dict per robot move: ``ply``, ``san``, ``smallest_mm``, ``part``,
        ``obstacle``, ``time_s``, the simulated motion's ``executed`` and the
        ``clearance_adjustments`` the planner made."""
        moves = [
            {"ply": m["ply"], "san": m["san"], **m["clearance"], "clearance_adjustments": m["clearance_adjustments"]}
            for m in self.game["moves"]
            if m.get("clearance")
        ]
        return {"summary": self.game["clearance"], "moves": moves}

    @property
    def servo_goals(self) -> Dict[str, Table]:
        """With servos (``actuator=``): each robot move's goals as the host sent them at the bus
        rate (``t`` s, ``goal`` rad of shape (n, 4), ``goal1_ticks``… in the servos' ticks), by
        move (``"001-e2e4"``); ``hardware["hardware/servo_bus.json"]`` says what the ticks mean."""
        suffix = "-goals.csv"
        return {
            os.path.basename(k)[: -len(suffix)]: v
            for k, v in self.tables.items()
            if k.startswith("hardware") and k.endswith(suffix)
        }


def play(
    pgn: Optional[str] = None,
    *,
    moves: Optional[str] = None,
    engine: Optional[str] = None,
    out: Optional[os.PathLike] = None,
    **kwargs: Any,
) -> Game:
    """``chessarm play``: a PGN game (a path, or the PGN text itself), a move list, or a game
    against an engine (``engine="builtin"`` or a UCI program's path)."""
    return _in_folder("play", [], out, dict(pgn=pgn, moves=moves, engine=engine, **kwargs), Game)


class Sweep(list):
    """``tune``'s rows (one dict per candidate, in the CSV's order) with ``summary`` (the JSON
    result: the best candidate, counts, the metric) and ``table`` (the CSV's columns)."""

    summary: Dict[str, Any]
    table: Table


def tune(*, out: Optional[os.PathLike] = None, **kwargs: Any) -> Sweep:
    """``chessarm tune``: a gain sweep (``kp="100..900:40", kd="10..60:40"``) → rows."""
    result = _in_folder("tune", [], out, kwargs, Result)
    table = result.tables["tune.csv"]
    sweep = Sweep(table.rows())
    sweep.summary = result.summary
    sweep.table = table
    return sweep


def robustness(*, out: Optional[os.PathLike] = None, **kwargs: Any) -> Result:
    """``chessarm robustness``: a Monte-Carlo campaign; ``tables["robustness.csv"]`` has a row
    per trial and controller."""
    return _in_folder("robustness", [], out, kwargs, Result)
