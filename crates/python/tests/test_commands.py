"""chessarm.plan/simulate/play/tune/robustness: the CLI's own commands run in-process, so
their files equal the CLI's byte for byte, loaded as NumPy arrays."""

import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

import chessarm

BIN = os.environ.get("CHESSARM_BIN")
needs_cli = pytest.mark.skipif(BIN is None, reason="CHESSARM_BIN is not set: SKIPPED the comparison with the CLI")
ROOT = Path(__file__).resolve().parents[3]


def cli(tmp, *args):
    out = subprocess.run([BIN, *args, "--out", str(tmp), "--json"], check=True, capture_output=True, text=True)
    return json.loads(out.stdout)


def same_files(a: Path, b: Path, names):
    for name in names:
        assert (a / name).read_bytes() == (b / name).read_bytes(), name


@needs_cli
def test_simulate_writes_the_clis_files_and_loads_them(tmp_path):
    result = chessarm.simulate(controller=["pd", "pid"], out=tmp_path / "py")
    cli(tmp_path / "cli", "simulate", "--controller", "pd,pid")
    same_files(tmp_path / "py", tmp_path / "cli", ["pd.csv", "pid.csv"])
    run = result.runs["pd"]
    assert run.q.shape == (len(run.t), 4) and run.tau.shape == (len(run.t), 4) and run.tip.shape == (len(run.t), 3)
    assert abs(run.t[-1] - 13.0) < 1e-9
    # The summary is the CLI's (but for the folder it names).
    assert [c["controller"] for c in result.summary["summary"]["controllers"]] == ["pd", "pid"]


@needs_cli
def test_play_equals_the_cli_and_gives_the_game_and_its_trajectories(tmp_path):
    game = chessarm.play(moves="e4 e5 Nf3", out=tmp_path / "py")
    cli(tmp_path / "cli", "play", "--moves", "e4 e5 Nf3")
    same_files(tmp_path / "py", tmp_path / "cli", ["moves/001-e2e4.csv", "moves/003-g1f3.csv", "hardware/001-e2e4.json"])
    assert game.summary["misplaced"] == 0
    assert game.game["final_fen_physical"].startswith("rnbqkbnr/pppp1ppp/8/4p3/4P3/5N2/PPPP1PPP/RNBQKB1R")
    assert sorted(game.moves) == ["moves/001-e2e4.csv", "moves/002-e7e5.csv", "moves/003-g1f3.csv"]
    trajectory = game.hardware["hardware/001-e2e4.json"]["trajectory"]
    assert trajectory["joint_names"] == ["joint1", "joint2", "joint3", "joint4"]
    assert game.hardware["hardware/001-e2e4.csv"]["gripper"][0] == "open"
    # Every robot move's clearance, as game.json has it, and the game's smallest.
    clearance = game.clearance
    assert [m["ply"] for m in clearance["moves"]] == [1, 2, 3]
    smallest = min(m["smallest_mm"] for m in clearance["moves"])
    assert clearance["summary"]["smallest_mm"] == smallest
    assert clearance["summary"]["contacts"] == 0
    assert all(m["part"] and m["obstacle"] and m["executed"]["contact"] is False for m in clearance["moves"])


def test_play_takes_pgn_text_and_a_temporary_folder_goes_away():
    game = chessarm.play("1. f3 e5 2. g4 Qh4# 0-1\n")
    assert game.summary["result"] == "0-1" and game.out is None
    assert len(game.game["moves"]) == 4


@needs_cli
def test_tune_rows_equal_the_clis_csv(tmp_path):
    rows = chessarm.tune(kp="100..400:3", kd="10..40:3", out=tmp_path / "py")
    cli(tmp_path / "cli", "tune", "--kp", "100..400:3", "--kd", "10..40:3")
    same_files(tmp_path / "py", tmp_path / "cli", ["tune.csv"])
    assert len(rows) == 9 and rows[0]["kp"] == 100.0 and rows[0]["status"] == "ok"
    # The summary is the CLI's: the best candidates, best first.
    best = rows.summary["best"][0]
    assert best["metric"] == min(row["max_tip_error_mm"] for row in rows)
    assert rows[int(best["index"])]["kp"] == best["kp"]
    np.testing.assert_array_equal(rows.table.kd[:3], [10.0, 25.0, 40.0])


def test_plan_with_moves_and_the_urdf_arm():
    planned = chessarm.plan(
        "e4", urdf=ROOT / "examples" / "offset-arm.urdf", arm=ROOT / "examples" / "offset-arm-board.toml"
    )
    assert planned.joint.q_des.shape[1] == 4
    assert planned.hardware["hardware/001-e2e4.json"]["trajectory"]["joint_names"] == ["waist", "shoulder", "elbow", "wrist"]


def test_errors_name_the_flag_or_say_why():
    with pytest.raises(ValueError, match="--kp"):
        chessarm.tune(kp="nonsense")
    with pytest.raises(chessarm.CommandError, match="e4"):
        chessarm.play(moves="e4 e4")
    assert issubclass(chessarm.CommandError, chessarm.Error)


def test_numpy_values_paths_and_games_become_the_clis_flags(tmp_path):
    q = np.array([0.1, 0.2, 0.3, 0.4])
    fk = chessarm.run("fk", q=q)
    np.testing.assert_allclose(fk["tip"], chessarm.Arm.default().fk(q)[:3, 3], rtol=0, atol=1e-15)
    assert chessarm.run("fk", q=list(q)) == fk
    assert "[[links]]" in chessarm.run("arm")  # a command that prints a file gives its text
    dynamics = chessarm.run("dynamics", q=q, payload_mass=np.float64(0.1))
    assert len(dynamics["g"]) == 4
    with pytest.raises(FileNotFoundError, match="gmae.pgn"):
        chessarm.play("gmae.pgn")
    with pytest.raises(FileNotFoundError):
        chessarm.play(tmp_path / "missing.pgn")
    game = tmp_path / "game.pgn"
    game.write_text("1. e4 *\n")
    rows = chessarm.tune(pgn=game, kp="100..200:2", kd="10..20:2")
    assert len(rows) == 4 and all(row["status"] == "ok" for row in rows)


def test_a_folder_removed_between_runs_is_written_again(tmp_path):
    import shutil

    out = tmp_path / "sim"
    chessarm.simulate(controller="pd", out=out)
    shutil.rmtree(out)
    chessarm.simulate(controller="pd", out=out)
    assert (out / ".chessarm-written").exists()
    chessarm.simulate(controller="pd", out=out)  # and again: its own files are replaced


def test_ctrl_c_stops_a_long_sweep_soon_and_the_next_call_works():
    import signal
    import threading
    import time

    threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT)).start()
    started = time.perf_counter()
    with pytest.raises(KeyboardInterrupt):
        chessarm.tune(kp="100..900:40", kd="10..60:40", threads=1)  # ~20 s to the end
    assert time.perf_counter() - started < 5.0
    assert len(chessarm.tune(kp="100..200:2", kd="10..20:2")) == 4


def test_aba_is_rneas_inverse_and_forward_dynamics_adds_friction():
    arm = chessarm.Arm.from_urdf(ROOT / "examples" / "offset-arm.urdf")  # it has friction
    rng = np.random.default_rng(3)
    q, v, a = (rng.uniform(-2, 2, (8, 4)) for _ in range(3))
    tau = arm.rnea(q, v, a)
    np.testing.assert_allclose(arm.aba(q, v, tau), a, rtol=0, atol=1e-9)
    assert np.abs(arm.forward_dynamics(q, v, tau) - a).max() > 1e-3
    plain = chessarm.Arm.default()
    np.testing.assert_array_equal(plain.forward_dynamics(q, v, tau), plain.aba(q, v, tau))


def test_ctrl_c_stops_this_threads_command_not_anothers(tmp_path):
    import signal
    import threading
    import time

    background = {}

    def sweep_in_the_background():
        background["rows"] = chessarm.tune(kp="100..900:12", kd="10..60:12", threads=1)

    worker = threading.Thread(target=sweep_in_the_background)
    worker.start()
    time.sleep(0.3)  # the background sweep holds the process's command slot now
    threading.Timer(0.3, lambda: os.kill(os.getpid(), signal.SIGINT)).start()
    with pytest.raises(KeyboardInterrupt):
        chessarm.tune(kp="100..900:40", kd="10..60:40", threads=1, out=tmp_path / "main")
    worker.join()
    assert len(background["rows"]) == 144  # it ran to its end
    assert not (tmp_path / "main" / "tune.csv").exists()  # this one stopped before writing


def test_games_are_paths_that_exist_or_pgn_text(tmp_path):
    for missing in ["games/x.txt", "missing.PGN"]:
        with pytest.raises(FileNotFoundError):
            chessarm.play(missing)
    with pytest.raises(ValueError, match="empty"):
        chessarm.tune(pgn="", kp="100..200:2", kd="10..20:2")
    with pytest.raises(ValueError, match="give one"):
        chessarm.tune(pgn="1. e4 *", game_file="g.pgn")
    from chessarm._commands import flags

    assert flags(controller_knows_payload=np.array(True), x=np.bool_(False), n=np.int64(3)) == [
        "--controller-knows-payload",
        "--n",
        "3",
    ]
