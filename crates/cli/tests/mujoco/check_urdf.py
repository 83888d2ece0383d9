"""Loads chessarm's URDF in MuJoCo (its own importer) and compares it with chessarm.

    python check_urdf.py CHESSARM_BINARY

Prints one JSON object with what was measured; the Rust test (crates/cli/tests/cli_plan.rs)
makes the assertions. Angles are drawn from a seeded generator within the joint limits.
"""
import json
import subprocess
import sys

import mujoco
import numpy as np

binary = sys.argv[1]


def chessarm(*args):
    return subprocess.run([binary, *args], check=True, capture_output=True, text=True).stdout


urdf = chessarm("urdf")
model = mujoco.MjModel.from_xml_string(urdf)
data = mujoco.MjData(model)
bodies = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, i) for i in range(model.nbody)]
geoms_per_body = {name: int(np.sum(model.geom_bodyid == i)) for i, name in enumerate(bodies)}
tool = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "tool")
lower, upper = model.jnt_range[:, 0], model.jnt_range[:, 1]
rng = np.random.default_rng(20261202)
worst = {"tool_m": 0.0, "mass_matrix": 0.0, "gravity_nm": 0.0}
for _ in range(20):
    q = lower + (upper - lower) * rng.random(model.nq)
    data.qpos[:] = q
    data.qvel[:] = 0.0
    mujoco.mj_forward(model, data)
    flags = ["--q", ",".join(repr(float(v)) for v in q), "--json"]
    fk = json.loads(chessarm("fk", *flags))
    dynamics = json.loads(chessarm("dynamics", *flags))
    mass = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, mass)
    worst["tool_m"] = max(worst["tool_m"], float(np.linalg.norm(data.xpos[tool] - np.array(fk["tip"]))))
    worst["mass_matrix"] = max(worst["mass_matrix"], float(np.abs(mass - np.array(dynamics["M"])).max()))
    # At rest the bias force is gravity alone.
    worst["gravity_nm"] = max(worst["gravity_nm"], float(np.abs(data.qfrc_bias - np.array(dynamics["g"])).max()))
print(json.dumps({
    "mujoco": mujoco.__version__,
    "nbody": model.nbody,
    "ngeom": model.ngeom,
    "njnt": model.njnt,
    "bodies": bodies,
    "geoms_per_body": geoms_per_body,
    "gravity": model.opt.gravity.tolist(),
    "worst": worst,
}))
