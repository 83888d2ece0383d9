"""Sweeps and Monte-Carlo campaigns on a Dask cluster.

``chessarm.distributed.tune(client, kp=…, kd=…)`` splits a ``tune`` sweep into shards (the
CLI's ``--shard K/N``: contiguous ranges of candidates), runs each shard in Rust on a worker
(``chessarm._chessarm.run_cli``, the GIL released), streams the shards' CSVs back as they finish
and joins them in shard order into the same ``tune.csv`` the single-machine command writes, byte
for byte (only the first shard writes the header; every candidate's row depends on the candidate alone).
``robustness`` likewise joins ``robustness.csv``. A shard whose worker is lost is run again
(Dask reschedules it; ``retries`` more times for a shard that raises). Progress: one line per
finished shard on standard error (or ``progress=False``).

Needs ``dask[distributed]`` (``pip install "./crates/python[distributed]"``) on the client and
the workers, and the chessarm package on every worker. Files named in the flags (``arm=``,
``urdf=``, a ``pgn=`` path) are opened by the workers: on a remote cluster they must exist there
at the same path; a game given as PGN text travels with the tasks.
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
import uuid
from typing import Any, Dict, Optional, Tuple

import numpy as np

from . import _commands
from ._chessarm import run_cli


def _shard(command: str, csv_name: str, index: int, count: int, kwargs: Dict[str, Any]) -> Tuple[int, str]:
    """Runs shard ``index`` of ``count`` on this worker; its CSV's text."""
    with tempfile.TemporaryDirectory(prefix="chessarm-shard-") as folder:
        kwargs = dict(kwargs)
        game = _commands._game(kwargs)
        positional = [] if game is None else [_commands.pgn_file(game, folder)]
        args = [command, *positional, *_commands.flags(shard=f"{index + 1}/{count}", out=folder, **kwargs)]
        run_cli(args)
        with open(os.path.join(folder, csv_name), newline="") as f:
            return index, f.read()


def _count(name: str, value: Any) -> int:
    """A whole number ≥ 1 (NumPy's too; not a bool)."""
    import operator

    if isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name}={value!r}: needs a whole number ≥ 1")
    try:
        count = operator.index(value)
    except TypeError:
        raise ValueError(f"{name}={value!r}: needs a whole number ≥ 1") from None
    if count < 1:
        raise ValueError(f"{name}={value!r}: needs at least one")
    return count


def _client(client, scheduler: Optional[str], workers: int):
    """The client to use, and the client and cluster this call made (and must close)."""
    if client is not None:
        return client, None, None
    from dask.distributed import Client, LocalCluster

    if scheduler is not None:
        made = Client(scheduler, set_as_default=False)
        return made, made, None
    workers = _count("workers", workers)
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0")
    made = Client(cluster, set_as_default=False)
    return made, made, cluster


def _campaign(
    command: str,
    csv_name: str,
    client,
    scheduler: Optional[str],
    workers: int,
    shards: Optional[int],
    out: Optional[os.PathLike],
    retries: int,
    progress: bool,
    kwargs: Dict[str, Any],
) -> str:
    from dask.distributed import as_completed

    if kwargs.get("shard") is not None:
        raise ValueError("shard: chessarm.distributed chooses the shards; give shards=N instead")
    if shards is not None:
        shards = _count("shards", shards)
    client, made, cluster = _client(client, scheduler, workers)
    try:
        count = shards if shards is not None else max(2, 2 * len(client.scheduler_info().get("workers", {})))
        # A shard runs on one core of its worker unless told otherwise: the cores are the
        # workers'. The rows do not depend on it.
        kwargs = {"threads": 1, **kwargs}
        started = time.perf_counter()
        # Keys of this call's own (Dask would otherwise hand back an earlier call's results).
        token = uuid.uuid4().hex[:12]
        futures = [
            client.submit(
                _shard, command, csv_name, k, count, kwargs, key=f"chessarm-{command}-{token}-{k + 1}-of-{count}", retries=retries
            )
            for k in range(count)
        ]
        texts: Dict[int, str] = {}
        for done, future in enumerate(as_completed(futures), start=1):
            index, text = future.result()
            texts[index] = text
            if progress:
                rows = text.count("\n") - (1 if index == 0 else 0)
                sys.stderr.write(
                    f"chessarm {command}: shard {index + 1}/{count} done ({rows} rows), {done}/{count} shards "
                    f"in {time.perf_counter() - started:.1f} s\n"
                )
        merged = "".join(texts[k] for k in range(count))
    finally:
        if made is not None:
            made.close()
        if cluster is not None:
            cluster.close()
    if out is not None:
        folder = os.fspath(out)
        os.makedirs(folder, exist_ok=True)
        target = os.path.join(folder, csv_name)
        partial = target + ".part"
        with open(partial, "w", newline="") as f:
            f.write(merged)
        os.replace(partial, target)
    return merged, count


def _table(text: str, csv_name: str) -> _commands.Table:
    with tempfile.TemporaryDirectory(prefix="chessarm-merged-") as folder:
        path = os.path.join(folder, csv_name)
        with open(path, "w", newline="") as f:
            f.write(text)
        return _commands.Table(path)


def tune(
    client=None,
    *,
    scheduler: Optional[str] = None,
    workers: int = 2,
    shards: Optional[int] = None,
    out: Optional[os.PathLike] = None,
    retries: int = 2,
    progress: bool = True,
    **kwargs: Any,
) -> _commands.Sweep:
    """A ``tune`` sweep on Dask: ``client`` (a ``dask.distributed.Client``), or ``scheduler``
    (its address), or neither (a ``LocalCluster`` of ``workers`` processes, closed after). The
    rows, as :func:`chessarm.tune` returns them; with ``out=`` the merged ``tune.csv`` is
    written there. ``text`` holds the merged CSV."""
    text, count = _campaign("tune", "tune.csv", client, scheduler, workers, shards, out, retries, progress, kwargs)
    table = _table(text, "tune.csv")
    sweep = _commands.Sweep(table.rows())
    sweep.table = table
    sweep.summary = {"candidates": len(sweep), "shards": count}
    sweep.text = text
    return sweep


def robustness(
    client=None,
    *,
    scheduler: Optional[str] = None,
    workers: int = 2,
    shards: Optional[int] = None,
    out: Optional[os.PathLike] = None,
    retries: int = 2,
    progress: bool = True,
    **kwargs: Any,
) -> _commands.Table:
    """A ``robustness`` campaign on Dask (as :func:`tune`): the merged ``robustness.csv``."""
    text, _ = _campaign("robustness", "robustness.csv", client, scheduler, workers, shards, out, retries, progress, kwargs)
    table = _table(text, "robustness.csv")
    table.text = text
    return table
