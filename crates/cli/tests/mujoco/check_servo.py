"""Drives MuJoCo's position actuator with the goals chessarm's servo host sent, and compares.

    python check_servo.py CHESSARM_BINARY FOLDER

chessarm simulates the report's scenario on its own arm with a servo reduced to MuJoCo's ideal
position law: no counts (10^12 per turn), no deadband, backlash, gear friction or armature, the
firmware at every time step, a duty that never saturates (240 V), so its torque is
(kt/R)(kp_duty e V - kt qd) limited to max_torque. MuJoCo loads the same arm from chessarm's URDF
and gets a <position> actuator per joint with kp = kp_duty kt V / R, kv = kt^2 / R and
forcerange = +-max_torque, fed at every step with the goal chessarm's host sent then, from the
state chessarm started in. Prints one JSON object with what was measured; the Rust test
(crates/cli/tests/cli_actuators.rs) makes the assertions.
"""
import csv
import json
import pathlib
import subprocess
import sys

import mujoco
import numpy as np

binary, folder = sys.argv[1], pathlib.Path(sys.argv[2])
DT = 1e-4
# The servo: duty per rad, V, Ω, N·m/A, N·m.
KP_DUTY, VOLTAGE, RESISTANCE, KT, MAX_TORQUE = 1.0, 240.0, 1.0, 3.0, 60.0
setup = folder / "ideal.toml"
setup.write_text(
    'actuator = "ideal"\n[actuators.ideal]\n'
    f"supply_voltage = {VOLTAGE}\nresistance = {RESISTANCE}\ntorque_constant = {KT}\nmax_torque = {MAX_TORQUE}\n"
    "armature = 0.0\ncoulomb_friction = 0.0\nviscous_friction = 0.0\nbacklash = 0.0\n"
    f"counts_per_revolution = 1e12\nperiod = {DT}\nkp = {KP_DUTY}\nki = 0.0\nkd = 0.0\nmax_duty = 1.0\n"
    "deadband = 0.0\nmax_target_speed = 0.0\nmax_target_acceleration = 0.0\n"
)


def chessarm(*args):
    return subprocess.run([binary, "--arm", str(setup), *args], check=True, capture_output=True, text=True).stdout


out = folder / "run"
chessarm("--bus-rate", "1000", "simulate", "--dt", str(DT), "--payload-mass", "0", "--json", "--out", str(out))
with open(out / "plain.csv") as f:
    rows = list(csv.DictReader(f))
q_chessarm = np.array([[float(r[f"q{j}"]) for j in range(1, 5)] for r in rows])
qd_chessarm = np.array([[float(r[f"qd{j}"]) for j in range(1, 5)] for r in rows])
goals = np.array([[float(r[f"goal{j}"]) for j in range(1, 5)] for r in rows])
tau_chessarm = np.array([[float(r[f"tau{j}"]) for j in range(1, 5)] for r in rows])

spec = mujoco.MjSpec.from_string(chessarm("urdf"))
spec.option.timestep = DT
spec.option.integrator = mujoco.mjtIntegrator.mjINT_RK4
# chessarm's plant has no contacts (the links' collision shapes would touch each other near
# the base and jam its yaw in MuJoCo).
spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
kp, kv = KP_DUTY * KT * VOLTAGE / RESISTANCE, KT * KT / RESISTANCE
for joint in spec.joints:
    actuator = spec.add_actuator()
    actuator.name = f"servo_{joint.name}"
    actuator.target = joint.name
    actuator.trntype = mujoco.mjtTrn.mjTRN_JOINT
    actuator.set_to_position(kp=kp, kv=kv)
    actuator.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
    actuator.forcerange = [-MAX_TORQUE, MAX_TORQUE]
    actuator.ctrllimited = mujoco.mjtLimited.mjLIMITED_FALSE
model = spec.compile()
# The servo is the joint's drive: no other damping, friction or rotor inertia.
model.dof_damping[:] = 0.0
model.dof_frictionloss[:] = 0.0
model.dof_armature[:] = 0.0
data = mujoco.MjData(model)
data.qpos[:] = q_chessarm[0]
data.qvel[:] = 0.0
q_mujoco = np.zeros_like(q_chessarm)
q_mujoco[0] = data.qpos
force = np.zeros_like(q_chessarm)
for k in range(len(rows) - 1):
    data.ctrl[:] = goals[k]
    mujoco.mj_forward(model, data)
    force[k] = data.actuator_force
    mujoco.mj_step(model, data)
    q_mujoco[k + 1] = data.qpos
force[-1] = force[-2]
error = np.abs(q_mujoco - q_chessarm)
# The static sag at the start: the goal less the settled angle, against g(q) / kp.
gravity = json.loads(chessarm("dynamics", "--q", ",".join(repr(float(v)) for v in q_chessarm[0]), "--json"))["g"]
print(json.dumps({
    "mujoco": mujoco.__version__,
    "steps": len(rows) - 1,
    "kp_nm_per_rad": kp,
    "kv_nms_per_rad": kv,
    "largest_angle_difference_rad": float(error.max()),
    "rms_angle_difference_rad": float(np.sqrt((error ** 2).mean())),
    "largest_angle_rad": float(np.abs(q_chessarm).max()),
    "largest_speed_rad_per_s": float(np.abs(qd_chessarm).max()),
    "dt_s": DT,
    "largest_torque_difference_nm": float(np.abs(force - tau_chessarm).max()),
    "largest_torque_nm": float(np.abs(tau_chessarm).max()),
    "saturated_steps_mujoco": int((np.abs(force) >= MAX_TORQUE - 1e-9).any(axis=1).sum()),
    "start_sag_rad": (goals[0] - q_chessarm[0]).tolist(),
    "start_sag_closed_form_rad": (np.array(gravity) / kp).tolist(),
}))
