"""The workspace of an arm: sample its joint space, plot where the tip goes.

    python workspace.py ARM.urdf OUT.png [--tip LINK] [--samples N] [--seed S]

Draws N configurations uniformly within the joint limits, computes every tip position in one
batched forward-kinematics call, plots them (side and top views, metres, base frame) to OUT.png
with matplotlib's Agg backend, and prints a JSON summary on stdout: the number of samples, the
largest distance of the tip from the base origin (``max_reach``, m) and the axis-aligned bounds of
the tip positions (m).
"""

from __future__ import annotations

import argparse
import json
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (after the backend is chosen)
import numpy as np  # noqa: E402

import chasles  # noqa: E402


def sample_tip_positions(model: chasles.Model, samples: int, seed: int) -> np.ndarray:
    """Tip positions (samples, 3), m, base frame, of configurations uniform within the limits."""
    rng = np.random.default_rng(seed)
    q = rng.uniform(model.lower, model.upper, size=(samples, model.nq))
    return model.fk(q)[:, :3, 3]


def plot(points: np.ndarray, title: str, path: str) -> None:
    """Side (x–z) and top (x–y) scatter of the tip positions, written to `path`."""
    figure, (side, top) = plt.subplots(1, 2, figsize=(10, 5))
    for axes, (i, j), labels in ((side, (0, 2), ("x [m]", "z [m]")), (top, (0, 1), ("x [m]", "y [m]"))):
        axes.scatter(points[:, i], points[:, j], s=1, alpha=0.3)
        axes.set_xlabel(labels[0])
        axes.set_ylabel(labels[1])
        axes.set_aspect("equal")
    figure.suptitle(title)
    partial = path + ".partial.png"  # written whole, then renamed: no half-written plot at `path`
    figure.savefig(partial, dpi=80)
    plt.close(figure)
    os.replace(partial, path)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("urdf")
    parser.add_argument("png")
    parser.add_argument("--tip", default=None, help="tip link (default: the tree's single leaf)")
    parser.add_argument("--samples", type=int, default=20000)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    model = chasles.Model.from_urdf(args.urdf, tip=args.tip)
    points = sample_tip_positions(model, args.samples, args.seed)
    plot(points, f"{model.name}: {args.samples} tip positions of {model.tip}", args.png)
    print(json.dumps({
        "samples": args.samples,
        "max_reach": float(np.max(np.linalg.norm(points, axis=1))),
        "lower": points.min(axis=0).tolist(),
        "upper": points.max(axis=0).tolist(),
    }))


if __name__ == "__main__":
    main()
