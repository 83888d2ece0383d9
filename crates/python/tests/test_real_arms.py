"""The makers' own URDFs, as published (crates/cli/tests/fixtures/real-arms), against Pinocchio.

Pinocchio (PyPI's `pin`) reads each file itself, holds every joint chessarm holds at the same
values with its own `buildReducedModel` (which merges the held sub-trees' inertias), and gives
the tool frame's position, M(q), g(q) and C(q, v) v at seeded states across the joints' limits;
chessarm's Python package gives them from the same file with its composite bodies and DH model.
Angles are the file's on both sides (the SO-101's base yaw turns about −z: chessarm keeps the
file's sense at every edge).
"""

import os
from pathlib import Path

import numpy as np
import pytest

import chessarm

if os.environ.get("CI") == "true":
    import pinocchio as pin  # CI installs it: a missing Pinocchio fails there
else:
    pin = pytest.importorskip("pinocchio", reason="needs Pinocchio (pip install pin); CI installs it")

ROOT = Path(__file__).resolve().parents[3]
FIXTURES = ROOT / "crates" / "cli" / "tests" / "fixtures" / "real-arms"

# Per file: chessarm's --lock, the tool link it finds, and every held joint's value as the
# import documents it (a gripper joint at 0 when its limits allow, else its limit nearest 0; a
# <mimic> follower at multiplier·leader + offset), written out here independently.
ARMS = {
    "open_manipulator_x": ({}, "end_effector_link", {"gripper_left_joint": 0.0, "gripper_right_joint": 0.0}),
    "px100": ({}, "px100/ee_gripper_link", {"gripper": 0.0, "left_finger": 0.015, "right_finger": -0.015}),
    "so101_new_calib": ({"wrist_roll": 0.0}, "gripper_frame_link", {"wrist_roll": 0.0, "gripper": 0.0}),
}

def exact_angles(text):
    """The SO-101's CAD export writes π as 3.14159 and π/2 as 1.5708: the angles it means. And
    chessarm leaves out bodies below MARKER_MASS (1e-6 kg) held to a moving link (frame markers:
    the SO-101's 1e-9 kg gripper_frame_link, 4e-9 N·m of gravity); Pinocchio, which merges it,
    is given the same rule by making it massless."""
    text = text.replace('<mass value="1e-9"/>', '<mass value="0"/>')
    return text.replace("3.14159\"", "3.141592653589793\"").replace("3.14159 ", "3.141592653589793 ").replace(
        "1.5708\"", "1.5707963267948966\"").replace("1.5708 ", "1.5707963267948966 ")


def reduced(path, held):
    model = pin.buildModelFromUrdf(str(path))
    q = pin.neutral(model)
    ids = []
    for name, value in held.items():
        joint = model.getJointId(name)
        ids.append(joint)
        if model.joints[joint].nq == 1:
            q[model.joints[joint].idx_q] = value
        else:  # a continuous joint: (cos, sin)
            q[model.joints[joint].idx_q: model.joints[joint].idx_q + 2] = [np.cos(value), np.sin(value)]
    arm = pin.buildReducedModel(model, ids, q)
    arm.gravity.linear[:] = [0.0, 0.0, -9.8]  # chessarm's gravity for a URDF (it has none)
    return arm


def worst_differences(arm, path, tool, held, count=40):
    """Largest differences over seeded states: tool point (m), and M, g, C v relative to
    their largest entry."""
    model = reduced(path, held)
    data = model.createData()
    joints = [model.getJointId(name) for name in arm.joint_names]
    assert all(model.joints[j].nq == 1 for j in joints), "the four arm joints are one-angle joints"
    order = [model.joints[j].idx_v for j in joints]
    frame = model.getFrameId(tool)
    rng = np.random.default_rng(20261206)
    worst = np.zeros(4)
    for _ in range(count):
        q = rng.uniform(model.lowerPositionLimit, model.upperPositionLimit)
        v = rng.uniform(-2.0, 2.0, model.nv)
        pin.framesForwardKinematics(model, data, q)
        mass = pin.crba(model, data, q)
        mass = np.triu(mass) + np.triu(mass, 1).T
        gravity = pin.computeGeneralizedGravity(model, data, q)
        coriolis = pin.rnea(model, data, q, v, np.zeros(model.nv)) - gravity
        qa, va = q[order], v[order]
        ours = arm.gravity(qa)
        pairs = [
            (arm.tool_point(qa)[:3], data.oMf[frame].translation, 1.0),
            (arm.mass_matrix(qa), mass[np.ix_(order, order)], np.abs(mass).max()),
            (ours, gravity[order], np.abs(gravity).max()),
            (arm.rnea(qa, va, np.zeros(4)) - ours, coriolis[order], np.abs(coriolis).max()),
        ]
        for k, (a, b, scale) in enumerate(pairs):
            worst[k] = max(worst[k], np.abs(a - b).max() / scale)
    return worst


@pytest.mark.parametrize("name", sorted(ARMS))
def test_each_official_file_loads_as_published_and_matches_pinocchio(name, tmp_path):
    lock, tool, held = ARMS[name]
    path = FIXTURES / f"{name}.urdf"
    arm = chessarm.Arm.from_urdf(str(path), lock=lock or None)
    if name.startswith("so101"):
        # As published: chessarm makes the arm's axes exact where the file's rounding of π
        # (3.14159, 2.7e-6 rad off) and π/2 (1.5708, 3.7e-6 rad off) tilts them (within
        # AXIS_TOLERANCE, 1e-5 rad); Pinocchio takes them as written. The difference is that
        # rounding times the levers: ≤ 1e-5 rad × 0.5 m for the tool point, and ≤ 1e-4 of the
        # torques and inertias (measured: 1.1e-6 m, 3.2e-5; the 1e-9 kg marker adds 1e-8).
        worst = worst_differences(arm, path, tool, held)
        assert worst[0] < 5e-6, worst
        assert worst[1:].max() < 1e-4, worst
        # With the angles the CAD meant, the two agree to rounding.
        exact = tmp_path / "so101_exact.urdf"
        exact.write_text(exact_angles(path.read_text()))
        arm = chessarm.Arm.from_urdf(str(exact), lock=lock)
        path = exact
    worst = worst_differences(arm, path, tool, held)
    # Two independent sums of the same products: a few hundred ulps of the largest entry.
    assert worst[0] < 1e-12, worst
    assert worst[1:].max() < 1e-11, worst


def test_a_base_yaw_about_minus_z_keeps_the_files_sense():
    """The SO-101's shoulder_pan turns about −z: a positive angle turns the arm clockwise seen
    from above, in chessarm's Python as in the file (and Pinocchio)."""
    arm = chessarm.Arm.from_urdf(str(FIXTURES / "so101_new_calib.urdf"), lock={"wrist_roll": 0.0})
    ahead = arm.tool_point([0.0, 0.0, 0.0, 0.0])[:2]
    turned = arm.tool_point([0.3, 0.0, 0.0, 0.0])[:2]
    # The tool point turns about the base axis, which stands off the root's origin.
    (x0, y0), (x1, y1) = ahead - [0.0388353, 0.0], turned - [0.0388353, 0.0]
    assert x0 * y1 - y0 * x1 < 0.0
    # Torques and rates in the file's sense too: a yaw torque gives a yaw acceleration of its sign.
    a = arm.aba([0.0, 0.5, 0.5, 0.0], [0.0] * 4, [0.1, 0.0, 0.0, 0.0])
    assert a[0] > 0.0


def test_a_fifth_joint_names_the_lock_that_fixes_it():
    with pytest.raises(chessarm.ModelError, match=r"--lock wrist_roll=0"):
        chessarm.Arm.from_urdf(str(FIXTURES / "so101_new_calib.urdf"))


def test_a_board_fitted_to_a_urdf_arm_is_not_an_arm_of_its_own(tmp_path):
    """A setup saved beside a URDF ([urdf] table, no [[links]]) is refused by Arm.from_file, as
    the CLI refuses it without --urdf: it would be the report's arm otherwise."""
    setup = tmp_path / "board.toml"
    setup.write_text('[board]\nsquare_size = 0.05\n\n[urdf]\n')
    with pytest.raises(chessarm.ModelError, match=r"\[urdf\] table is for the arm of a URDF"):
        chessarm.Arm.from_file(str(setup))
