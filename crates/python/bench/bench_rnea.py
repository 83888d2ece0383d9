"""arm.rnea on 10^5 states: one vectorised call vs a Python loop of single calls, and
Pinocchio's Python binding (`pip install pin`) on the same arm where it is installed.

Run: python crates/python/bench/bench_rnea.py [N]. Prints the figures as JSON; nothing is
asserted (the tests check the numbers; this measures their speed).
"""

import json
import sys
import tempfile
import time

import numpy as np

import chessarm


def best_of(runs, f):
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        f()
        times.append(time.perf_counter() - start)
    return min(times)


def main():
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 100_000
    arm = chessarm.Arm.default()
    rng = np.random.default_rng(1)
    q, v, a = (rng.uniform(-2, 2, (n, 4)) for _ in range(3))
    figures = {"states": n}
    figures["vectorised_s"] = best_of(5, lambda: arm.rnea(q, v, a))
    loop_n = min(n, 20_000)
    loop = best_of(3, lambda: [arm.rnea(q[i], v[i], a[i]) for i in range(loop_n)])
    figures["python_loop_s"] = loop * n / loop_n
    figures["python_loop_measured_states"] = loop_n
    try:
        import pinocchio as pin

        with tempfile.NamedTemporaryFile("w", suffix=".urdf", delete=False) as f:
            f.write(arm.to_urdf())
        model = pin.buildModelFromUrdf(f.name)
        data = model.createData()
        model.gravity.linear = np.array([0.0, 0.0, -9.8])
        tau = pin.rnea(model, data, q[0], v[0], a[0])
        assert np.allclose(tau, arm.rnea(q[0], v[0], a[0]), atol=1e-8), (tau, arm.rnea(q[0], v[0], a[0]))
        pin_loop = best_of(3, lambda: [pin.rnea(model, data, q[i], v[i], a[i]) for i in range(loop_n)])
        figures["pinocchio_python_loop_s"] = pin_loop * n / loop_n
        figures["pinocchio_version"] = pin.__version__
    except ImportError:
        figures["pinocchio_python_loop_s"] = None
    for key in ["vectorised_s", "python_loop_s", "pinocchio_python_loop_s"]:
        if figures.get(key):
            figures[key.replace("_s", "_ns_per_state")] = figures[key] / n * 1e9
    print(json.dumps(figures, indent=1))


if __name__ == "__main__":
    main()
