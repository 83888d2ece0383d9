"""Servos from Python: the commands take the CLI's --actuator, --servo-command and --p-gain as
keyword arguments, and the goals the host sent come back as arrays."""

import numpy as np

import chessarm

# An XM430 on 48 V with a 20 N·m current limit: strong enough for the report's arm.
BIG = '[actuators.big]\nbase = "xm430"\nsupply_voltage = 48.0\nmax_torque = 20.0\n'


def test_simulate_compares_the_hosts_goal_strategies(tmp_path):
    setup = tmp_path / "big.toml"
    setup.write_text(BIG)
    result = chessarm.simulate(arm=setup, actuator="big", servo_command=["plain", "feedforward"])
    plain, feedforward = result.runs["plain"], result.runs["feedforward"]
    # The goals, the servos' internal targets and duties per joint, as the CSV has them.
    assert plain.goal.shape == (len(plain.t), 4) and plain.duty.shape == (len(plain.t), 4)
    assert np.all(np.abs(plain.duty) <= 1.0)
    rms = lambda run: np.sqrt(np.mean(np.sum((run.tip - run.tip_des) ** 2, axis=1)))
    assert rms(feedforward) < rms(plain)


def test_play_returns_the_goals_sent_in_ticks(tmp_path):
    setup = tmp_path / "big.toml"
    setup.write_text(BIG + "[servo_bus]\nids = [1, 2, 3, 4]\ndirections = [1, 1, -1, 1]\n")
    game = chessarm.play(moves="e4", arm=setup, actuator="big", servo_command="sag")
    goals = game.servo_goals["001-e2e4"]
    count = 2 * np.pi / 4096
    # Whole counts, in ticks about the middle of the register, joint 3 turned.
    assert np.allclose(goals.goal / count, np.round(goals.goal / count), atol=1e-6)
    assert np.array_equal(goals.goal3_ticks, 2048 - np.round(goals.goal[:, 2] / count))
    assert np.all(np.diff(goals.t) > 0)
    bus = game.hardware["hardware/servo_bus.json"]
    assert [j["id"] for j in bus["joints"]] == [1, 2, 3, 4]
    assert game.game["misplaced"] == []


def test_plain_goals_are_the_plan_in_whole_counts_every_bus_period(tmp_path):
    # Not the record read twice: the plan's angles (the move's q_des, every 10th 1 ms step,
    # the 100 Hz bus's) quantised to the servo's counts are what the plain host sent.
    setup = tmp_path / "big.toml"
    setup.write_text(BIG)
    game = chessarm.play(moves="e4", arm=setup, actuator="big", servo_command="plain")
    goals = game.servo_goals["001-e2e4"]
    planned = game.moves["moves/001-e2e4.csv"]
    count = 2 * np.pi / 4096
    assert len(goals.t) == len(planned.t) > 100
    assert np.array_equal(goals.goal, np.round(planned.q_des / count) * count)


def test_tune_sweeps_the_p_register(tmp_path):
    setup = tmp_path / "big.toml"
    setup.write_text(BIG)
    sweep = chessarm.tune(arm=setup, actuator="big", servo_command="plain", p_gain="400..1600:2", metric="max-tip-error")
    assert [row["p_gain"] for row in sweep] == [400.0, 1600.0]
    # A stiffer loop follows closer.
    assert sweep[1]["max_tip_error_mm"] < sweep[0]["max_tip_error_mm"]
