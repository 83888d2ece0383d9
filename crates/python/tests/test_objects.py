"""The in-memory objects: chessarm.Setup, plan/simulate/play on a setup, and the Simulator.

Their numbers are the CLI's (compared with the CHESSARM_BIN binary's files, to the bit where
the CSV's round-trip floats allow it), and they hold the physics' identities: FK of the planned
joints is the planned tool path, the Simulator stepped along a plan is simulate's run, gravity
torques hold the arm still, inverse dynamics' torque gives its acceleration.
"""

import csv
import json
import os
import subprocess
import threading
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

import chessarm

BIN = os.environ.get("CHESSARM_BIN")
needs_cli = pytest.mark.skipif(BIN is None, reason="CHESSARM_BIN is not set: SKIPPED the comparison with the CLI")
ROOT = Path(__file__).resolve().parents[3]
URDF = ROOT / "examples" / "offset-arm.urdf"
URDF_BOARD = ROOT / "examples" / "offset-arm-board.toml"


def cli(tmp, *args):
    out = subprocess.run([BIN, *args, "--out", str(tmp), "--json"], check=True, capture_output=True, text=True)
    return json.loads(out.stdout)


def columns(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    return {name: np.array([float(row[i]) for row in body]) for i, name in enumerate(header)}


def stacked(table, stem, count=4):
    return np.column_stack([table[f"{stem}{j + 1}"] for j in range(count)])


@pytest.fixture(scope="module")
def setup():
    return chessarm.Setup.default()


@pytest.fixture(scope="module")
def urdf_setup():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", chessarm.ChessarmWarning)
        return chessarm.Setup.from_urdf(URDF, arm=URDF_BOARD)


@pytest.fixture(scope="module")
def scenario_run(setup):
    return chessarm.simulate(setup, controller="pd")


# --- Setup -------------------------------------------------------------------------------------


def test_setup_properties_and_its_arm(setup):
    assert setup.joint_names == ["joint1", "joint2", "joint3", "joint4"]
    assert setup.actuator_names == ["torque"] * 4 and not setup.servos
    assert setup.square_size == pytest.approx(0.06)
    assert setup.board["square_size"] == setup.square_size
    assert set(setup.pieces) == {"pawn", "knight", "bishop", "rook", "queen", "king"}
    # The profile in metres: the default set is the cylinders of the bases, no head block.
    for piece in setup.pieces.values():
        radius = piece["base_diameter"] / 2
        assert piece["outline"] == [[0.0, pytest.approx(radius)], [pytest.approx(piece["height"]), pytest.approx(radius)]]
        assert piece["head_block"] is None
    assert setup.torque_limits.shape == (4,) and np.all(setup.torque_limits > 0)
    assert setup.joint_limits.shape == (4, 2) and np.all(setup.joint_limits[:, 0] < setup.joint_limits[:, 1])
    assert "queens-gambit" in setup.scenarios and "hobby" in setup.sensor_profiles
    e4 = setup.square_center("e4")
    assert e4.shape == (3,) and abs(e4[0] - 0.03) < 1e-12  # e is the first file right of the centre
    q = np.array([0.1, 0.5, -0.3, 0.2])
    np.testing.assert_array_equal(setup.arm.mass_matrix(q), chessarm.Arm.default().mass_matrix(q))
    assert "[[links]]" in setup.to_toml()
    with pytest.raises(ValueError):
        setup.torque_limits[0] = 1.0  # read-only


def test_setup_from_urdf_is_the_arms_and_the_clis(urdf_setup):
    arm = chessarm.Arm.from_urdf(URDF)
    assert urdf_setup.joint_names == arm.joint_names == ["waist", "shoulder", "elbow", "wrist"]
    q = np.array([0.2, 0.4, -0.6, 0.1])
    np.testing.assert_array_equal(urdf_setup.arm.rnea(q, q, q), arm.rnea(q, q, q))
    assert urdf_setup.urdf_path is not None and urdf_setup.base_link


def test_setup_errors_name_the_argument(tmp_path):
    with pytest.raises(chessarm.ModelError):
        chessarm.Setup.from_file(tmp_path / "missing.toml")
    with pytest.raises(ValueError, match="urdf"):
        chessarm.Setup(lock={"wrist": 0.0})
    with pytest.raises(ValueError, match="tool_offset"):
        chessarm.Setup.from_urdf(URDF, tool_offset=[0.0, 1.0])
    with pytest.raises(ValueError, match="servo_command"):
        chessarm.Setup.default(servo_command="gentle")
    with pytest.raises(chessarm.ModelError, match="nosuch"):
        chessarm.Setup.default(actuator="nosuch")
    bad = tmp_path / "bad.toml"
    bad.write_text("[board]\nsquare_size = -1\n")
    with pytest.raises(chessarm.ModelError, match="square_size"):
        chessarm.Setup.from_file(bad)


def test_a_setup_with_servos_has_their_stall_torques():
    servos = chessarm.Setup.default(actuator="sts3215")
    assert servos.servos and servos.actuator_names == ["sts3215"] * 4
    assert np.all(servos.torque_limits != chessarm.Setup.default().torque_limits)


# --- plan ----------------------------------------------------------------------------------------


def test_plan_of_the_scenario_fk_of_its_joints_is_its_tool_path(setup):
    plan = chessarm.plan(setup)
    n = len(plan)
    assert plan.kind == "scenario" and plan.name == "queens-gambit" and plan.dt == 0.001
    assert plan.t.shape == (n,) and plan.q.shape == plan.qd.shape == plan.qdd.shape == (n, 4)
    assert plan.tool.shape == plan.tool_velocity.shape == plan.tool_acceleration.shape == (n, 3)
    assert abs(plan.t[-1] - 13.0) < 1e-9 and abs(plan.duration - 13.0) < 1e-12
    np.testing.assert_allclose(np.diff(plan.t), 0.001, rtol=0, atol=1e-12)
    assert [e[1] for e in plan.events] == ["grip", "release"]
    tips = setup.arm.fk(plan.q)[:, :3, 3]
    np.testing.assert_allclose(tips, plan.tool, rtol=0, atol=1e-9)
    # The tool's velocity is the Jacobian's image of the joint rates.
    J = setup.arm.jacobian(plan.q[::500])
    np.testing.assert_allclose(np.einsum("nij,nj->ni", J[:, :3], plan.qd[::500]), plan.tool_velocity[::500], atol=1e-7)
    assert not plan.q.flags.writeable


def test_plan_of_moves_has_its_plies_and_follows_the_tool(urdf_setup):
    plan = chessarm.plan(urdf_setup, moves="e4 e5 Nf3", dt=0.002)
    assert plan.kind == "moves" and plan.name == "e4 e5 Nf3"
    assert [(p.ply, p.san, p.uci) for p in plan.plies] == [(1, "e4", "e2e4"), (2, "e5", "e7e5"), (3, "Nf3", "g1f3")]
    starts = [p.start for p in plan.plies]
    assert starts[0] == 0 and all(b == pytest.approx(a.start + a.duration) for a, b in zip(plan.plies, starts[1:]))
    assert plan.duration == pytest.approx(sum(p.duration for p in plan.plies))
    assert len(plan.events) == 6 and all(0 <= t <= plan.duration for t, _ in plan.events)
    assert plan.tool.shape == (len(plan), 3)
    np.testing.assert_allclose(urdf_setup.arm.fk(plan.q)[:, :3, 3], plan.tool, rtol=0, atol=1e-9)


@needs_cli
def test_plan_equals_the_clis_joint_csv(tmp_path, setup):
    cli(tmp_path / "moves", "plan", "--moves", "e4 e5", "--dt", "0.001")
    plan = chessarm.plan(setup, moves="e4 e5", dt=0.001)
    joint = columns(tmp_path / "moves" / "joint.csv")
    np.testing.assert_array_equal(plan.t, joint["t"])
    np.testing.assert_array_equal(plan.q, stacked(joint, "q_des"))
    np.testing.assert_array_equal(plan.qdd, stacked(joint, "qdd_des"))
    cartesian = columns(tmp_path / "moves" / "cartesian.csv")
    np.testing.assert_array_equal(plan.tool, np.column_stack([cartesian[a] for a in "xyz"]))
    np.testing.assert_array_equal(plan.tool_velocity, np.column_stack([cartesian["v" + a] for a in "xyz"]))
    cli(tmp_path / "scenario", "plan", "--dt", "0.005")
    joint = columns(tmp_path / "scenario" / "joint.csv")
    np.testing.assert_array_equal(chessarm.plan(setup, dt=0.005).qd, stacked(joint, "qd_des"))


def test_plan_errors(setup):
    with pytest.raises(ValueError, match="scenario"):
        chessarm.plan(setup, "kings-indian")
    with pytest.raises(ValueError, match="moves"):
        chessarm.plan(setup, moves="e4 e4")
    with pytest.raises(ValueError, match="dt"):
        chessarm.plan(setup, dt=0.0)
    with pytest.raises(ValueError, match="fen"):
        chessarm.plan(setup, moves="e4", fen="not a fen")
    with pytest.raises(ValueError, match="tool_speeed"):
        chessarm.plan(setup, moves="e4", motion={"tool_speeed": 1.0})
    with pytest.raises(ValueError, match="both"):
        chessarm.plan(setup, "queens-gambit", moves="e4")
    slower = chessarm.plan(setup, moves="e4", motion={"tool_speed": 0.3})
    assert slower.duration > chessarm.plan(setup, moves="e4").duration


# --- simulate ------------------------------------------------------------------------------------


def test_simulate_gives_every_step_and_the_metrics(scenario_run, setup):
    sim = scenario_run
    assert sim.controllers == ["pd"] and list(sim.runs) == ["pd"]
    run = sim.runs["pd"]
    n = len(run)
    assert run.t.shape == (n,) and n == 13001
    for name in ["q", "qd", "q_des", "qd_des", "qdd_des", "tau", "q_estimate"]:
        assert getattr(run, name).shape == (n, 4), name
    assert run.tip.shape == run.tip_desired.shape == (n, 3)
    # One controller: the simulation's attributes are its run's.
    assert sim.q is run.q and sim.max_tip_error == run.max_tip_error
    errors = np.linalg.norm(run.tip - run.tip_desired, axis=1)
    assert run.max_tip_error == errors.max()
    assert run.rms_tip_error == pytest.approx(np.sqrt(np.mean(errors**2)), rel=1e-12)
    np.testing.assert_array_equal(run.peak_torque, np.abs(run.tau).max(axis=0))
    np.testing.assert_array_equal(run.q_estimate, run.q)  # ideal sensors
    assert run.placement_error is not None and run.placement_error < 1e-3
    assert run.summary["max_tip_error_mm"] == run.max_tip_error * 1e3
    assert [e[1] for e in run.tip_error_at_events] == ["grip", "release"]
    np.testing.assert_allclose(setup.arm.fk(run.q[::1000])[:, :3, 3], run.tip[::1000], rtol=0, atol=1e-12)
    # The plan it followed is the scenario's at the control period.
    np.testing.assert_array_equal(sim.plan.q, run.q_des)


@needs_cli
@pytest.mark.parametrize(
    "flags, kwargs",
    [
        (["--controller", "pd,pid"], dict(controller=["pd", "pid"])),
        (
            ["--controller", "pd", "--sensors", "hobby", "--seed", "3", "--payload-mass", "0.1", "--kp", "500"],
            dict(controller="pd", sensors="hobby", seed=3, payload_mass=0.1, kp=500),
        ),
        (["--controller", "pid", "--dt", "0.0005", "--control-rate", "1000"], dict(controller="pid", dt=0.0005, control_rate=1000)),
    ],
)
def test_simulate_equals_the_clis_files(tmp_path, setup, flags, kwargs):
    result = cli(tmp_path, "simulate", *flags)
    sim = chessarm.simulate(setup, **kwargs)
    for entry in result["summary"]["controllers"]:
        name = entry["controller"]
        run = sim.runs[name]
        table = columns(tmp_path / f"{name}.csv")
        np.testing.assert_array_equal(run.t, table["t"])
        for ours, theirs in [("q", "q"), ("qd", "qd"), ("q_des", "q_des"), ("tau", "tau")]:
            np.testing.assert_array_equal(getattr(run, ours), stacked(table, theirs), err_msg=ours)
        np.testing.assert_array_equal(run.tip, np.column_stack([table[a] for a in "xyz"]))
        np.testing.assert_array_equal(run.tip_desired, np.column_stack([table[a + "_des"] for a in "xyz"]))
        for key in ["rms_tip_error_mm", "max_tip_error_mm", "placement_error_mm", "peak_torque_nm", "saturation_count"]:
            assert run.summary[key] == entry[key], key


def test_simulate_takes_a_plan_and_refuses_a_wrong_one(setup, scenario_run):
    plan = chessarm.plan(setup)
    sim = chessarm.simulate(setup, plan)
    np.testing.assert_array_equal(sim.q, scenario_run.q)
    assert sim.plan is plan
    with pytest.raises(ValueError, match="control_rate"):
        chessarm.simulate(setup, chessarm.plan(setup, dt=0.005), control_rate=1000)
    slow = chessarm.simulate(setup, chessarm.plan(setup, dt=0.002), dt=0.001)  # control_rate 500 Hz
    assert slow.control_rate == pytest.approx(500.0)
    with pytest.raises(ValueError, match="play"):
        chessarm.simulate(setup, chessarm.plan(setup, moves="e4"))


def test_simulate_errors_name_the_argument(setup):
    for kwargs, name in [
        (dict(controller="pdd"), "controller"),
        (dict(dt=-1.0), "dt"),
        (dict(kp=[1.0, 2.0]), "kp"),
        (dict(kp=-5), "kp"),
        (dict(dt=0.001, control_rate=300), "control_rate"),
        (dict(sensors="nosuch"), "sensors"),
        (dict(estimator="magic"), "estimator"),
        (dict(ki=10.0), "ki"),
        (dict(payload_mass=1e9), "payload_mass"),
        (dict(tracking_from=20.0), "tracking_from"),
        (dict(integrator="verlet"), "integrator"),
        (dict(q0=[0.0, 1.0]), "q0"),
    ]:
        with pytest.raises(ValueError, match=name):
            chessarm.simulate(setup, **kwargs)
    with pytest.warns(chessarm.ChessarmWarning, match="q0 joint 2") as warned:
        chessarm.Simulator(setup, q0=[0.0, 45.0, 0.0, 0.0])
        chessarm.simulate(setup, q0=[0.0, 2.7, 0.0, 0.0], tracking_from=1.0)
    assert [w.filename for w in warned] == [__file__, __file__]  # the user's line, not the package's
    sim = chessarm.simulate(setup, controller=["pd", "pid"])
    with pytest.raises(AttributeError, match="runs"):
        sim.q  # noqa: B018 - two controllers: which one's?


def test_simulate_with_sensors_keeps_the_estimate_and_notes(setup):
    sim = chessarm.simulate(setup, sensors="hobby", estimator="kalman", seed=1)
    assert sim.conditions["sensors"]["profile"] == "hobby"
    assert any("hobby" in note for note in sim.notes)
    assert 0 < np.abs(sim.q_estimate - sim.q).max() < 0.01


def test_simulate_releases_the_gil(setup):
    counts = []
    done = threading.Event()

    def count():
        while not done.is_set():
            counts.append(1)
            time.sleep(0.001)

    worker = threading.Thread(target=count)
    worker.start()
    started = time.perf_counter()
    chessarm.simulate(setup, controller=["pd", "pid", "adaptive"])
    elapsed = time.perf_counter() - started
    done.set()
    worker.join()
    # The counting thread ran all along (about one count per millisecond when it can).
    assert len(counts) > 0.2 * elapsed / 0.001


# --- Simulator -----------------------------------------------------------------------------------


@pytest.mark.parametrize("name, kwargs", [("ideal", {}), ("hobby sensors", dict(sensors="hobby", seed=2))])
def test_the_simulator_along_a_plan_is_simulates_run(setup, name, kwargs):
    sim = chessarm.simulate(setup, controller="pd", **kwargs)
    plan = sim.plan
    stepper = chessarm.Simulator(setup, dt=1e-3, controller="pd", **kwargs)
    stepper.reset(q=plan.q[0])
    n = 3000
    q = np.empty((n, 4))
    tau = np.empty((n, 4))
    for k in range(n):
        q[k] = stepper.q
        tau[k] = stepper.step(plan.q[k], plan.qd[k], plan.qdd[k])
    # The same operations in the same order: the same bits.
    np.testing.assert_array_equal(q, sim.q[:n])
    np.testing.assert_array_equal(tau, sim.tau[:n])
    assert stepper.t == pytest.approx(n * 1e-3)


def test_the_simulator_grips_lags_and_samples_slower_as_simulate(setup):
    # The whole scenario with the pawn gripped and released at the plan's events, a motor lag
    # and the controller at 500 Hz (its command held over two steps): simulate's run, bit for bit.
    options = dict(controller="adaptive", torque_lag=0.002, control_rate=500)
    sim = chessarm.simulate(setup, payload_mass=0.2, **options)
    plan = sim.plan
    events = {round(t / 1e-3): event for t, event in plan.events}
    stepper = chessarm.Simulator(setup, **options)
    stepper.reset(q=plan.q[0])
    q = np.empty((len(sim.t), 4))
    for k in range(len(sim.t) - 1):
        if k in events:
            stepper.grip(0.2) if events[k] == "grip" else stepper.release()
        q[k] = stepper.q
        sample = k // 2  # the plan is sampled at the control period, 2 ms
        stepper.step(plan.q[sample], plan.qd[sample], plan.qdd[sample])
    q[-1] = stepper.q
    np.testing.assert_array_equal(q, sim.q)


def test_gravity_torques_hold_the_arm_and_rnea_gives_its_acceleration(setup):
    arm = setup.arm
    q = np.array([0.3, 0.7, -0.9, 0.2])
    stepper = chessarm.Simulator(setup, controller=None, q0=q)
    for _ in range(200):
        stepper.step_torque(arm.gravity(q))
    np.testing.assert_allclose(stepper.q, q, atol=1e-12)
    np.testing.assert_allclose(stepper.qd, 0.0, atol=1e-12)
    # One short step of τ = rnea(q, v, a): the rates change by a·dt (to first order).
    v = np.array([0.2, -0.1, 0.3, 0.05])
    a = np.array([1.0, -2.0, 0.5, 3.0])
    dt = 1e-6
    stepper = chessarm.Simulator(setup, dt=dt, controller=None)
    stepper.reset(q=q, qd=v)
    stepper.step_torque(arm.rnea(q, v, a), clip=False)
    accel = (stepper.qd - v) / dt
    np.testing.assert_allclose(accel, arm.forward_dynamics(q, v, arm.rnea(q, v, a)), rtol=1e-4, atol=1e-4)


def test_a_free_falling_arm_without_friction_keeps_its_energy():
    # The report's arm has no friction: with no torque, kinetic + potential energy is kept.
    setup = chessarm.Setup.default()
    arm = setup.arm
    stepper = chessarm.Simulator(setup, dt=1e-4, controller=None, q0=[0.0, 1.2, -0.5, 0.3])

    def energy():
        q, qd = stepper.state
        kinetic = 0.5 * qd @ arm.mass_matrix(q) @ qd
        return kinetic, q, qd

    # The potential's change is minus the work of gravity: ∫ g(q)·q̇ dt (trapezoid).
    kinetic0, q, qd = energy()
    work = 0.0
    previous = arm.gravity(q) @ qd
    for _ in range(3000):
        stepper.step_torque(np.zeros(4))
        kinetic, q, qd = energy()
        power = arm.gravity(q) @ qd
        work += 0.5 * (previous + power) * 1e-4
        previous = power
    assert kinetic > 0.05  # it fell
    assert abs(kinetic - kinetic0 + work) < 1e-5 * kinetic


def test_simulator_errors(setup):
    with pytest.raises(ValueError, match="servo"):
        chessarm.Simulator(chessarm.Setup.default(actuator="sts3215"))
    stepper = chessarm.Simulator(setup, controller=None)
    with pytest.raises(ValueError, match="step_torque"):
        stepper.step([0.0] * 4)
    with pytest.raises(ValueError, match="tau"):
        stepper.step_torque([1.0, 2.0])
    with pytest.raises(ValueError, match="control_rate"):
        chessarm.Simulator(setup, dt=1e-3, control_rate=300)
    with pytest.raises(chessarm.SimulationError, match="diverged"):
        stepper.step_torque([1e9, 0, 0, 0], clip=False)
        for _ in range(10):
            stepper.step_torque([1e9, 0, 0, 0], clip=False)


def test_the_simulator_carries_a_piece(setup):
    q = np.array([0.3, 0.7, -0.9, 0.2])
    held = chessarm.Simulator(setup, controller="pd", q0=q)
    held.grip(0.2, controller_knows=True)
    for _ in range(500):
        held.step(q)
    np.testing.assert_allclose(held.q, q, atol=1e-9)
    unknown = chessarm.Simulator(setup, controller="pd", q0=q)
    unknown.grip(0.2)
    for _ in range(500):
        unknown.step(q)
    assert np.abs(unknown.q - q).max() > 1e-6  # it sags under a piece its model does not know
    unknown.release()


# --- play ----------------------------------------------------------------------------------------


def test_play_moves_in_memory(setup):
    game = chessarm.play(setup, moves="e4 e5 Nf3")
    assert [p.san for p in game.plies] == ["e4", "e5", "Nf3"] and len(game) == 3
    assert game.misplaced == [] and game.result == "*"
    assert game.final_fen_physical.startswith("rnbqkbnr/pppp1ppp/8/4p3/4P3/5N2/PPPP1PPP/RNBQKB1R")
    assert game.final_fen_physical == game.final_fen_rules
    ply = game.plies[0]
    assert ply.by == "robot" and ply.placement_error < 0.005 and ply.clearance > 0 and not ply.contact
    assert ply.q.shape == (len(ply.t), 4) and ply.tip.shape == (len(ply.t), 3)
    assert game.placement_errors.shape == (3,)
    assert game.robot_time == pytest.approx(sum(p.duration for p in game.plies))
    # The report's arm keeps clear at its pace: no move slowed, as with keep_pace.
    kept = chessarm.play(setup, moves="e4 e5 Nf3", keep_pace=True)
    assert [p.pace for p in game.plies] == [p.pace for p in kept.plies] == [1.0, 1.0, 1.0]
    assert [p.duration for p in game.plies] == [p.duration for p in kept.plies]


@needs_cli
def test_play_equals_the_clis_game(tmp_path, setup):
    cli(tmp_path, "play", "--moves", "e4 d5 exd5", "--robot", "white")
    game = chessarm.play(setup, moves="e4 d5 exd5", robot="white")
    record = json.loads((tmp_path / "game.json").read_text())
    assert [p.by for p in game.plies] == [m["by"] for m in record["moves"]] == ["robot", "hand", "robot"]
    for ply, move in zip(game.plies, record["moves"]):
        assert [e * 1e3 for e in ply.place_errors] == move["place_errors_mm"]
        assert (ply.max_tip_error * 1e3 if ply.max_tip_error is not None else None) == move["max_tip_error_mm"]
        assert ply.duration == move["duration_s"]
        assert ply.pace == move["pace"]
        assert [d * 1e3 for d in ply.too_near_tries] == move["too_near_tries_mm"]
        if move["clearance"]:
            assert ply.clearance * 1e3 == move["clearance"]["smallest_mm"]
    assert game.final_fen_physical == record["final_fen_physical"]
    assert game.result == record["result"] and game.result_reason == record["result_reason"]
    table = columns(tmp_path / "moves" / "003-e4d5.csv")
    np.testing.assert_array_equal(game.plies[2].t, table["t"])
    np.testing.assert_array_equal(game.plies[2].q, stacked(table, "q"))
    np.testing.assert_array_equal(game.plies[2].tip, np.column_stack([table[a] for a in "xyz"]))


@needs_cli
def test_a_noisy_game_and_servos_equal_the_clis(tmp_path, setup):
    cli(tmp_path / "play", "play", "--moves", "e4 e5", "--sensors", "hobby", "--seed", "1")
    game = chessarm.play(setup, moves="e4 e5", sensors="hobby", seed=1)
    record = json.loads((tmp_path / "play" / "game.json").read_text())
    assert [[e * 1e3 for e in p.place_errors] for p in game.plies] == [m["place_errors_mm"] for m in record["moves"]]
    assert game.final_fen_physical == record["final_fen_physical"]
    assert any("hobby" in note for note in game.notes)
    subprocess.run(
        [BIN, "--actuator", "sts3215", "simulate", "--out", str(tmp_path / "sim"), "--json"], check=True, capture_output=True
    )
    sim = chessarm.simulate(chessarm.Setup.default(actuator="sts3215"))
    assert sim.controllers == ["plain"] and "servos" in sim.notes[0]
    table = columns(tmp_path / "sim" / "plain.csv")
    np.testing.assert_array_equal(sim.q, stacked(table, "q"))
    np.testing.assert_array_equal(sim.servo_goal, stacked(table, "goal"))
    np.testing.assert_array_equal(sim.servo_target, stacked(table, "target"))


def test_play_pgn_text_and_files_and_engines(tmp_path, setup):
    game = chessarm.play(setup, pgn="1. f3 e5 2. g4 Qh4# 0-1\n", robot="black")
    assert game.result == "0-1" and [p.by for p in game.plies] == ["hand", "robot", "hand", "robot"]
    path = tmp_path / "game.pgn"
    path.write_text('[Event "x"]\n[Result "*"]\n\n1. d4 *\n')
    assert [p.san for p in chessarm.play(setup, pgn=path).plies] == ["d4"]
    assert [p.san for p in chessarm.play(setup, pgn=str(path)).plies] == ["d4"]
    engine_game = chessarm.play(setup, engine="builtin", plies=2, depth=1, robot="white")
    assert len(engine_game.plies) == 2 and "plies=2" in engine_game.result_reason


def test_play_errors(setup, tmp_path):
    with pytest.raises(ValueError, match="moves"):
        chessarm.play(setup, moves="e4 e4")
    with pytest.raises(FileNotFoundError):
        chessarm.play(setup, pgn=tmp_path / "missing.pgn")
    with pytest.raises(ValueError, match="robot"):
        chessarm.play(setup, moves="e4", robot="left")
    with pytest.raises(ValueError, match="not both"):
        chessarm.play(setup, moves="e4", pgn="1. e4 *")
    with pytest.raises(ValueError, match="controller"):
        chessarm.play(setup, moves="e4", controller=["pd", "pid"])
    with pytest.raises(ValueError, match="tolerance"):
        chessarm.play(setup, moves="e4", tolerance=0)


def test_ctrl_c_stops_a_game_between_plies(setup):
    import signal

    threading.Timer(0.3, lambda: os.kill(os.getpid(), signal.SIGINT)).start()
    started = time.perf_counter()
    with pytest.raises(KeyboardInterrupt):
        chessarm.play(setup, engine="builtin", plies=60, depth=1)
    assert time.perf_counter() - started < 10.0
    assert len(chessarm.play(setup, moves="e4").plies) == 1  # and the next call works


# --- the names ------------------------------------------------------------------------------------


def test_without_a_setup_the_functions_are_the_clis(tmp_path):
    planned = chessarm.plan("e4")
    assert isinstance(planned, chessarm.cli.Plan) and planned.joint.q_des.shape[1] == 4
    assert chessarm.cli.simulate is chessarm._commands.simulate
    for error in [chessarm.PlanError, chessarm.SimulationError, chessarm.GameError, chessarm.ModelError]:
        assert issubclass(error, chessarm.Error)
    assert issubclass(chessarm.ChessarmWarning, UserWarning)
