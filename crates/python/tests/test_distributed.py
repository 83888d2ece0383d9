"""chessarm.distributed: a sweep and a campaign on a Dask LocalCluster of two worker processes,
merged into the single-machine CSV byte for byte."""

import json
import os
import subprocess

import pytest

import chessarm

distributed = pytest.importorskip("dask.distributed", reason="dask[distributed] is not installed: SKIPPED")
import chessarm.distributed  # noqa: E402

BIN = os.environ.get("CHESSARM_BIN")


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0")
    with distributed.Client(cluster) as client:
        yield client
    cluster.close()


def single_machine(tmp, *args):
    """The CLI's (or, without CHESSARM_BIN, the in-process command's) CSV of the whole run."""
    if BIN is not None:
        subprocess.run([BIN, *args, "--out", str(tmp), "--json"], check=True, capture_output=True)
    else:
        chessarm.run(*args, out=str(tmp))
    return tmp


def test_a_sweep_on_two_workers_merges_to_the_single_machine_csv(client, tmp_path, capfd):
    sweep = chessarm.distributed.tune(client, shards=5, kp="100..900:6", kd="10..60:5", out=tmp_path / "dask")
    whole = single_machine(tmp_path / "one", "tune", "--kp", "100..900:6", "--kd", "10..60:5")
    assert (tmp_path / "dask" / "tune.csv").read_bytes() == (whole / "tune.csv").read_bytes()
    assert len(sweep) == 30 and sweep[0]["index"] == 0.0
    # Progress: a line per shard on stderr.
    progress = capfd.readouterr().err
    assert progress.count("chessarm tune: shard ") == 5 and "5/5 shards" in progress, progress
    # Any number of shards gives the same file.
    again = chessarm.distributed.tune(client, shards=2, kp="100..900:6", kd="10..60:5", progress=False)
    assert again.text == sweep.text


def test_a_campaign_on_two_workers_merges_to_the_single_machine_csv(client, tmp_path):
    table = chessarm.distributed.robustness(client, shards=3, trials=6, seed=7, out=tmp_path / "dask")
    whole = single_machine(tmp_path / "one", "robustness", "--trials", "6", "--seed", "7")
    assert (tmp_path / "dask" / "robustness.csv").read_bytes() == (whole / "robustness.csv").read_bytes()
    assert len(table) > 0


def test_a_local_cluster_of_its_own_with_one_call(tmp_path):
    sweep = chessarm.distributed.tune(workers=2, shards=2, kp="100..200:2", kd="10..20:2", progress=False)
    assert [row["kp"] for row in sweep] == [100.0, 100.0, 200.0, 200.0]
    with pytest.raises(ValueError, match="shard"):
        chessarm.distributed.tune(workers=1, shard="0/2", kp="100..200:2", kd="10..20:2")


def test_a_lost_workers_shards_run_again_and_the_file_is_the_same(client, tmp_path):
    import threading
    import time

    before = set(client.scheduler_info()["workers"])
    victim = sorted(before)[0]
    killed = threading.Event()

    def kill_one_worker_midway():
        # Once the first shards are done, the victim's process dies (its nanny starts another).
        time.sleep(1.2)
        try:
            client.run(os._exit, 1, workers=[victim])
        except Exception:  # noqa: BLE001 - the worker dies before it answers
            pass
        finally:
            killed.set()

    flags = dict(kp="100..900:40", kd="10..60:10")
    killer = threading.Thread(target=kill_one_worker_midway)
    killer.start()
    sweep = chessarm.distributed.tune(client, shards=10, out=tmp_path / "dask", progress=False, **flags)
    killer.join()
    assert killed.is_set()
    whole = single_machine(tmp_path / "one", "tune", "--kp", flags["kp"], "--kd", flags["kd"])
    assert (tmp_path / "dask" / "tune.csv").read_bytes() == (whole / "tune.csv").read_bytes()
    assert len(sweep) == 400
    # The worker was lost while the sweep ran (a new one took its place).
    client.wait_for_workers(2, timeout=60)
    assert victim not in set(client.scheduler_info()["workers"])


def test_calls_do_not_share_results_and_bad_arguments_fail_fast(client):
    first = chessarm.distributed.tune(client, shards=2, kp="500..600:2", kd="10..20:2", progress=False)
    second = chessarm.distributed.tune(client, shards=2, kp="700..800:2", kd="10..20:2", progress=False)
    assert {row["kp"] for row in first} == {500.0, 600.0} and {row["kp"] for row in second} == {700.0, 800.0}
    with pytest.raises(ValueError, match="--kp"):
        chessarm.distributed.tune(client, shards=2, kp="nonsense", progress=False)
    assert len(chessarm.distributed.tune(client, shards=2, kp="100..200:2", kd="10..20:2", progress=False)) == 4
    for bad in [dict(shards=0), dict(workers=0, client=None)]:
        arguments = {"client": client, **bad}
        with pytest.raises(ValueError):
            chessarm.distributed.tune(arguments.pop("client"), kp="100..200:2", kd="10..20:2", **arguments)


def test_a_scheduler_address_gets_a_client_that_is_closed_after(client):
    address = client.scheduler.address
    before = len(client.run_on_scheduler(lambda dask_scheduler: list(dask_scheduler.clients)))
    for _ in range(2):
        chessarm.distributed.tune(scheduler=address, shards=2, kp="100..200:2", kd="10..20:2", progress=False)
    import time

    time.sleep(0.5)
    after = len(client.run_on_scheduler(lambda dask_scheduler: list(dask_scheduler.clients)))
    assert after == before
    assert distributed.default_client() is client


def test_counts_may_be_numpy_integers_but_not_bools(client):
    import numpy as np

    rows = chessarm.distributed.tune(client, shards=np.int64(2), kp="100..200:2", kd="10..20:2", progress=False)
    assert len(rows) == 4 and rows.summary["shards"] == 2
    with pytest.raises(ValueError, match="whole number"):
        chessarm.distributed.tune(client, shards=True, kp="100..200:2", kd="10..20:2")
