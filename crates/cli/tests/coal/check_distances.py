"""The clearance check's distances against Coal (the maintained hpp-fcl, PyPI `coal`, installed
with Pinocchio), an independent library.

Reads the JSON that crates/cli/tests/clearance_coal.rs writes: sampled configurations of a real
game, each with the arm's solids (cylinders between two face centres, boxes with their axes and
half sizes) and the standing pieces (upright cylinders), and chessarm's distance for pairs of a
solid and a piece. Builds the same shapes in Coal, asks Coal for each pair's distance, and
prints one JSON line: the number of pairs, the largest difference, the pairs both call
touching, and the first pairs that differ by more than the tolerance.

(FCL itself, PyPI `python-fcl` 0.7, was tried first: its GJK on cylinders is off by up to
16 mm here — two coaxial cylinders 40 mm apart come out 56.6 mm, the rims' diagonal — as its
own tracker reports, flexible-collision-library/fcl#570 and #321; a dense sampling of both
surfaces agrees with chessarm and Coal.)"""

import json
import sys

import coal
import numpy as np


def frame_along(axis):
    """A rotation whose z column is the unit vector `axis` (Coal's cylinders lie along z)."""
    z = axis / np.linalg.norm(axis)
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return np.column_stack([x, y, z])


def cylinder(a, b, radius):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    length = np.linalg.norm(b - a)
    return coal.Cylinder(radius, length), coal.Transform3s(frame_along(b - a), (a + b) / 2.0)


def solid(s):
    if s["kind"] == "cylinder":
        return cylinder(s["a"], s["b"], s["radius"])
    axes = np.asarray(s["axes"], dtype=float).T  # the given columns
    half = np.asarray(s["half"], dtype=float)
    return coal.Box(*(2.0 * half)), coal.Transform3s(axes, np.asarray(s["centre"], dtype=float))


def main(path):
    data = json.load(open(path))
    worst, pairs, both_touch, disagree = 0.0, 0, 0, []
    for sample in data["samples"]:
        solids = [solid(s) for s in sample["solids"]]
        pieces = [cylinder(p["base"], np.asarray(p["base"]) + [0.0, 0.0, p["height"]], p["radius"]) for p in sample["pieces"]]
        for i, k, ours in sample["distances"]:
            (shape1, pose1), (shape2, pose2) = solids[i], pieces[k]
            theirs = max(coal.distance(shape1, pose1, shape2, pose2, coal.DistanceRequest(), coal.DistanceResult()), 0.0)
            pairs += 1
            if ours == 0.0 and theirs == 0.0:
                both_touch += 1
            difference = abs(ours - theirs)
            worst = max(worst, difference)
            if difference > data["tolerance"]:
                disagree.append([i, k, ours, theirs])
    print(json.dumps({"pairs": pairs, "largest_difference": worst, "both_touching": both_touch, "disagree": disagree[:10]}))


if __name__ == "__main__":
    main(sys.argv[1])
