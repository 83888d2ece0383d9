"""chessarm.tune and chessarm.robustness on a Setup, in memory: their rows equal the chessarm
binary's tune.csv and robustness.csv for the same options, to the bit (errors in m here, mm in
the files); their errors name the argument; and the studies in memory write nothing, in a
folder that is not writable with no temporary folder to fall back on."""

import csv
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import chessarm

BIN = os.environ.get("CHESSARM_BIN")
UNCERTAINTY = Path(__file__).resolve().parents[3] / "examples" / "uncertainty.toml"
needs_cli = pytest.mark.skipif(BIN is None, reason="CHESSARM_BIN is not set: SKIPPED the comparison with the CLI")


def table(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], rows[1:]


def column(header, rows, name, kind=float):
    i = header.index(name)
    return [kind(row[i]) for row in rows]


@pytest.fixture(scope="module")
def setup():
    return chessarm.Setup.default()


@needs_cli
def test_tune_equals_the_clis_sweep(tmp_path, setup):
    flags = ["--kp", "100..900:4", "--kd", "10..60:3", "--sensors", "hobby", "--q0", "0.1,0.2,0.3,0.4"]
    summary = json.loads(
        subprocess.run([BIN, "tune", *flags, "--out", str(tmp_path), "--json"], check=True, capture_output=True, text=True).stdout
    )
    sweep = chessarm.tune(setup, kp="100..900:4", kd=(10, 60, 3), sensors="hobby", q0=[0.1, 0.2, 0.3, 0.4])
    header, rows = table(tmp_path / "tune.csv")
    assert len(sweep) == len(rows) == sweep.sweep_size == 12
    np.testing.assert_array_equal(sweep.kp, column(header, rows, "kp"))
    np.testing.assert_array_equal(sweep.kd, column(header, rows, "kd"))
    for name in ["max_tip_error", "rms_tip_error", "place_error"]:
        np.testing.assert_array_equal(sweep.__getattribute__(name), np.array(column(header, rows, name + "_mm")) / 1e3)
    np.testing.assert_array_equal(sweep.rms_joint_error, column(header, rows, "rms_joint_error_rad"))
    np.testing.assert_array_equal(sweep.peak_torque, column(header, rows, "peak_torque_nm"))
    assert sweep.saturated_samples == column(header, rows, "saturated_samples", int)
    assert sweep.status == column(header, rows, "status", str)
    # The same ranking as the command's, and the tracking metrics' start after q0's transient.
    assert [int(sweep.index[i]) for i in sweep.best(top=5)] == [b["index"] for b in summary["best"]]
    assert sweep.tracking_from == summary["tracking_metrics_from_s"] > 0


@needs_cli
def test_a_servo_sweep_equals_the_clis(tmp_path):
    subprocess.run(
        [BIN, "--actuator", "sts3215", "tune", "--p-gain", "8..64:3", "--out", str(tmp_path), "--json"],
        check=True,
        capture_output=True,
    )
    sweep = chessarm.tune(chessarm.Setup.default(actuator="sts3215"), p_gain="8..64:3")
    header, rows = table(tmp_path / "tune.csv")
    assert sweep.servos and sweep.servo_command == column(header, rows, "servo_command", str)
    np.testing.assert_array_equal(sweep.p_gain, column(header, rows, "p_gain"))
    np.testing.assert_array_equal(sweep.max_tip_error, np.array(column(header, rows, "max_tip_error_mm")) / 1e3)


@needs_cli
def test_robustness_equals_the_clis_campaign(tmp_path, setup):
    flags = ["--trials", "4", "--controller", "pd,dob", "--sensors", "hobby", "--seed", "3", "--uncertainty", str(UNCERTAINTY)]
    out = subprocess.run([BIN, "robustness", *flags, "--out", str(tmp_path), "--json"], check=True, capture_output=True, text=True)
    summary = json.loads(out.stdout)["summary"]
    trials = chessarm.robustness(
        setup, trials=4, controller=["pd", "dob"], sensors="hobby", seed=3, uncertainty=UNCERTAINTY
    )
    header, rows = table(tmp_path / "robustness.csv")
    assert len(trials) == len(rows) == 8
    assert trials.trial == column(header, rows, "trial", int)
    assert trials.trial_seed == column(header, rows, "trial_seed", int)
    assert trials.controller == column(header, rows, "controller", str)
    assert trials.success == [v == "true" for v in column(header, rows, "success", str)]
    np.testing.assert_array_equal(trials.place_error, np.array(column(header, rows, "place_error_mm")) / 1e3)
    np.testing.assert_array_equal(trials.robot_time, column(header, rows, "robot_time_s"))
    drawn = header[header.index("clearance_mm") + 1 :]
    assert drawn and sorted(trials.drawn) == sorted(drawn)
    for name in drawn:
        np.testing.assert_array_equal(trials.drawn[name], column(header, rows, name))
    for mine, theirs in zip(trials.statistics, summary["controllers"]):
        theirs = dict(theirs)
        theirs.pop("replay_worst_trial")
        assert mine == theirs


def test_sweep_errors_name_the_argument(setup):
    with pytest.raises(ValueError, match=r"kp='100\.\.x:3'"):
        chessarm.tune(setup, kp="100..x:3", kd="10..60:3")
    with pytest.raises(ValueError, match="kd"):
        chessarm.tune(setup, kp="100..900:3")
    with pytest.raises(ValueError, match="p_gain"):
        chessarm.tune(setup, p_gain="8..64:3")
    with pytest.raises(ValueError, match="controller='pid-plain'"):
        chessarm.tune(setup, kp="100..900:3", kd="10..60:3", controller="pid-plain")
    with pytest.raises(ValueError, match="trials=0"):
        chessarm.robustness(setup, trials=0)
    with pytest.raises(ValueError, match="shard=\\(3, 2\\)"):
        chessarm.robustness(setup, trials=4, shard=(3, 2))


def test_the_studies_in_memory_write_nothing(tmp_path):
    """A plan, a simulation, a 3-move game, a sweep, a campaign and 13 000 Simulator steps in a
    folder without write permission (an empty one that must stay empty: the tests may run as
    root, whom permissions do not stop) with TMPDIR naming a folder that does not exist."""
    folder = tmp_path / "read-only"
    folder.mkdir()
    script = textwrap.dedent(
        """
        import numpy as np, chessarm, time
        setup = chessarm.Setup.default()
        plan = chessarm.plan(setup)
        sim = chessarm.simulate(setup, plan)
        game = chessarm.play(setup, moves="e4 e5 Nf3")
        sweep = chessarm.tune(setup, kp="300..500:2", kd="20..30:2")
        trials = chessarm.robustness(setup, trials=2, controller="pd", sensors="hobby")
        stepper = chessarm.Simulator(setup, dt=1e-3)
        tau = setup.arm.gravity(np.zeros(4))
        started = time.perf_counter()
        for _ in range(13000):
            stepper.step_torque(tau)
        seconds = time.perf_counter() - started
        assert plan.q.shape[1] == 4 and sim.q.shape == (len(sim.t), 4) and len(game.plies) == 3
        assert len(sweep) == 4 and len(trials) == 2 and stepper.steps == 13000
        print(seconds)
        """
    )
    os.chmod(folder, 0o555)
    try:
        environment = dict(os.environ, TMPDIR=str(tmp_path / "no-such-folder"), TEMP="", TMP="")
        done = subprocess.run([sys.executable, "-c", script], cwd=folder, env=environment, capture_output=True, text=True)
        assert done.returncode == 0, done.stderr
        assert list(folder.iterdir()) == []
        assert not (tmp_path / "no-such-folder").exists()
        assert float(done.stdout.strip()) > 0
    finally:
        os.chmod(folder, 0o755)
