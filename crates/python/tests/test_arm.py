"""The Python package against the chessarm command's numbers and the physics identities.

CHESSARM_BIN names the chessarm binary to compare with (the Rust test that runs this file sets
it to the one cargo built); without it the comparisons with the CLI are skipped, visibly.
"""

import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

import chessarm

ROOT = Path(__file__).resolve().parents[3]
EXAMPLE_URDF = ROOT / "examples" / "offset-arm.urdf"
BIN = os.environ.get("CHESSARM_BIN")
needs_cli = pytest.mark.skipif(BIN is None, reason="CHESSARM_BIN is not set: SKIPPED the comparison with the CLI")

RNG = np.random.default_rng(20261202)
STATES = RNG.uniform(-2.5, 2.5, (12, 4))
RATES = RNG.uniform(-2.0, 2.0, (12, 4))
ACCELERATIONS = RNG.uniform(-3.0, 3.0, (12, 4))


def cli(*args):
    out = subprocess.run([BIN, *args, "--json"], check=True, capture_output=True, text=True).stdout
    return json.loads(out)


def listed(values):
    return ",".join(repr(float(v)) for v in values)


@pytest.fixture(params=["default", "urdf"])
def arm_and_flags(request):
    if request.param == "default":
        return chessarm.Arm.default(), []
    return chessarm.Arm.from_urdf(EXAMPLE_URDF), ["--urdf", str(EXAMPLE_URDF)]


@needs_cli
def test_dynamics_and_fk_equal_the_clis(arm_and_flags):
    arm, flags = arm_and_flags
    for q, v in zip(STATES[:6], RATES[:6]):
        terms = cli(*flags, "dynamics", "--q", listed(q), "--qd", listed(v))
        # The same Rust functions on the same numbers, printed with round-trip precision.
        np.testing.assert_array_equal(arm.mass_matrix(q), np.array(terms["M"]))
        np.testing.assert_array_equal(arm.gravity(q), np.array(terms["g"]))
        np.testing.assert_allclose(arm.coriolis(q, v) @ v, np.array(terms["c"]), rtol=0, atol=1e-12)
        fk = cli(*flags, "fk", "--q", listed(q))
        np.testing.assert_allclose(arm.fk(q)[:3, 3], fk["tip"], rtol=0, atol=1e-15)
        np.testing.assert_allclose(arm.tool_point(q)[3], fk["pitch"], rtol=0, atol=1e-15)


@needs_cli
def test_ik_equals_the_clis_and_fk_inverts_it(arm_and_flags):
    arm, flags = arm_and_flags
    for square in ["a1", "d4", "h8", "e2"]:
        expected = cli(*flags, "ik", "--square", square)["q"]
        tip = cli(*flags, "fk", "--q", listed(expected))["tip"]
        q = arm.ik(tip)
        np.testing.assert_allclose(q, expected, rtol=0, atol=1e-12)
        np.testing.assert_allclose(arm.tool_point(q), [*tip, -np.pi / 2], rtol=0, atol=1e-12)


def test_physics_identities(arm_and_flags):
    arm, _ = arm_and_flags
    for q, v, a in zip(STATES, RATES, ACCELERATIONS):
        m = arm.mass_matrix(q)
        np.testing.assert_array_equal(m, m.T)
        assert np.linalg.eigvalsh(m).min() > 0
        tau = arm.rnea(q, v, a)
        # RNEA's terms: M a + (C v + g), g alone at rest, C v from the Coriolis matrix.
        np.testing.assert_allclose(arm.rnea(q, v, np.zeros(4)) + m @ a, tau, rtol=0, atol=1e-12)
        np.testing.assert_allclose(arm.rnea(q, np.zeros(4), np.zeros(4)), arm.gravity(q), rtol=0, atol=1e-12)
        np.testing.assert_allclose(arm.rnea(q, v, np.zeros(4)) - arm.gravity(q), arm.coriolis(q, v) @ v, atol=1e-12)


def test_aba_inverts_rnea_on_a_frictionless_arm():
    arm = chessarm.Arm.default()
    for q, v, a in zip(STATES, RATES, ACCELERATIONS):
        np.testing.assert_allclose(arm.aba(q, v, arm.rnea(q, v, a)), a, rtol=0, atol=1e-10)


def test_many_states_in_one_call_equal_one_call_per_state():
    arm = chessarm.Arm.default()
    batched = {
        "rnea": arm.rnea(STATES, RATES, ACCELERATIONS),
        "mass_matrix": arm.mass_matrix(STATES),
        "fk": arm.fk(STATES),
        "jacobian": arm.jacobian(STATES),
        "coriolis": arm.coriolis(STATES, RATES),
    }
    assert batched["rnea"].shape == (12, 4) and batched["mass_matrix"].shape == (12, 4, 4)
    assert batched["fk"].shape == (12, 4, 4) and batched["jacobian"].shape == (12, 6, 4)
    for i in range(len(STATES)):
        np.testing.assert_array_equal(batched["rnea"][i], arm.rnea(STATES[i], RATES[i], ACCELERATIONS[i]))
        np.testing.assert_array_equal(batched["mass_matrix"][i], arm.mass_matrix(STATES[i]))
        np.testing.assert_array_equal(batched["fk"][i], arm.fk(STATES[i]))
        np.testing.assert_array_equal(batched["jacobian"][i], arm.jacobian(STATES[i]))
        np.testing.assert_array_equal(batched["coriolis"][i], arm.coriolis(STATES[i], RATES[i]))
    # Lists work as arrays do.
    np.testing.assert_array_equal(arm.gravity(STATES.tolist()), arm.gravity(STATES))


def test_jacobian_against_finite_differences():
    arm = chessarm.Arm.default()
    q = STATES[3]
    step = 1e-6
    numeric = np.column_stack(
        [(arm.fk(q + step * e)[:3, 3] - arm.fk(q - step * e)[:3, 3]) / (2 * step) for e in np.eye(4)]
    )
    # Central differences: truncation ~h²|f'''| ≈ 1e-12, rounding ~1e-16/h = 1e-10.
    np.testing.assert_allclose(arm.jacobian(q)[:3], numeric, rtol=0, atol=1e-8)


def test_errors_are_python_exceptions_with_the_clis_messages(tmp_path):
    arm = chessarm.Arm.default()
    with pytest.raises(chessarm.UnreachableError, match="out of reach"):
        arm.ik([2.0, 0.0, 0.0])
    assert issubclass(chessarm.UnreachableError, chessarm.Error)
    with pytest.raises(ValueError, match=r"q: shape \[3\]"):
        arm.mass_matrix([1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match=r"v: shape \(2, 4\) where q has shape \(3, 4\)"):
        arm.rnea(STATES[:3], STATES[:2], STATES[:3])
    with pytest.raises(ValueError, match="not finite"):
        arm.gravity([0.0, float("nan"), 0.0, 0.0])
    with pytest.raises(ValueError, match=r"q\[1\] = .* rad: an angle is beyond"):
        arm.fk([[0.0, 0.0, 0.0, 0.0], [0.0, 2e6, 0.0, 0.0]])
    # Rates are not angles: large ones are the dynamics' to answer.
    assert np.all(np.isfinite(arm.rnea([0.0, 0.1, 0.2, 0.3], [3e6, 0.0, 0.0, 0.0], [0.0] * 4)))
    bad = tmp_path / "bad.urdf"
    bad.write_text(EXAMPLE_URDF.read_text().replace('name="elbow" type="revolute"', 'name="elbow" type="prismatic"'))
    with pytest.raises(chessarm.ModelError, match=r"line \d+: <joint name=\"elbow\">: a prismatic joint on the way to the tool"):
        chessarm.Arm.from_urdf(bad)
    toml = tmp_path / "arm.toml"
    toml.write_text("[[links]]\na = -1.0\n[[links]]\n[[links]]\n[[links]]\n")
    with pytest.raises(chessarm.ModelError, match="link 1"):
        chessarm.Arm.from_file(toml)
    with pytest.raises(chessarm.ModelError, match="cannot read"):
        chessarm.Arm.from_file(tmp_path / "missing.toml")


def test_setup_files_and_urdf_round_trip(tmp_path):
    toml = tmp_path / "arm.toml"
    toml.write_text("[[links]]\n[[links]]\na = 0.32\n[[links]]\n[[links]]\n")
    arm = chessarm.Arm.from_file(toml)
    assert arm.dh[1, 0] == 0.32
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(arm.to_urdf())
    again = chessarm.Arm.from_urdf(urdf)
    np.testing.assert_allclose(again.mass_matrix(STATES), arm.mass_matrix(STATES), rtol=0, atol=1e-12)
    assert chessarm.Arm.from_urdf(EXAMPLE_URDF).joint_names == ["waist", "shoulder", "elbow", "wrist"]


def test_what_the_cli_refuses_raises_and_never_returns_inf_or_nan():
    # These returned inf or NaN where `chessarm dynamics` says "overflows".
    arm = chessarm.Arm.default()
    zero = [0.0, 0.0, 0.0, 0.0]
    for call, needle in [
        (lambda: arm.rnea(zero, [1e200, 0, 0, 0], zero), "v = [1e200, 0, 0, 0]"),
        (lambda: arm.forward_dynamics(zero, [1e300, 0, 0, 0], zero), "v = [1e300, 0, 0, 0]"),
        (lambda: arm.aba(zero, zero, [1e308, 1e308, 0, 0]), "tau = [1e308, 1e308, 0, 0]"),
    ]:
        with pytest.raises(ValueError, match="overflows") as raised:
            call()
        assert needle in str(raised.value)
    # Many states: the message names the one that overflowed.
    v = np.zeros((3, 4))
    v[2, 0] = 1e200
    with pytest.raises(ValueError, match=r"state 2: .*v = \[1e200"):
        arm.rnea(np.zeros((3, 4)), v, np.zeros((3, 4)))
    # Large finite values that do not overflow still give numbers.
    assert np.isfinite(arm.rnea(zero, [1e50, 0, 0, 0], zero)).all()


def test_a_batch_the_machine_cannot_hold_is_a_memory_error_not_an_abort():
    # 10^10 states (broadcast, so the input itself takes no memory): their copies and results
    # would take 1.6 TB. Rust aborts the interpreter on a failed allocation; the estimate first
    # turns it into MemoryError naming the shape.
    many = np.broadcast_to(np.zeros(4), (10**10, 4))
    arm = chessarm.Arm.default()
    with pytest.raises(MemoryError, match=r"q of shape \(10000000000, 4\)"):
        arm.rnea(many, many, many)
    with pytest.raises(MemoryError):
        arm.mass_matrix(many)
    # A file that never ends is refused after its bound (it was OOM-killed at 24 GB).
    with pytest.raises(chessarm.ModelError, match=r"/dev/zero: longer than 16.0 MB"):
        chessarm.Arm.from_urdf("/dev/zero")
    with pytest.raises(chessarm.ModelError, match=r"/dev/zero: longer than 1.0 MB"):
        chessarm.Arm.from_file("/dev/zero")
