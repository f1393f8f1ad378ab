"""Call overhead of chasles's Python bindings beside Pinocchio's (pip `pin`), in one process.

    build-bench/venv/bin/python tests/bench/python_bench.py [--build BUILD]

Run it with the interpreter of the venv tools/pinocchio.sh makes (it holds pin==4.1.0; Debian's
CPython 3.11, as build/venv) and PYTHONPATH=BUILD/python (a tree configured with
-DCHASLES_PYTHON=ON, with chasles_python_oracle built). Not a test: it prints a table.

Per call (timeit, best of 7 repeats, each a pass over a table of 256 random configurations within
the limits, seed 1; the pass's loop is the same for both libraries): fk, J_b, rnea and M of the
ur5 (tip tool0) and the panda (tip panda_hand, fingers locked at 0) in chasles and in pin. pin's
model is built by pin.buildModelFromUrdf from the same URDF; the panda's finger joints are locked
at 0 by pin.buildReducedModel, which is what chasles's loader does with joints off the chain (and
what tests/bench/pinocchio_bench.cpp compares in C++). The pin calls are those of a pin user:
  fk   pin.forwardKinematics(model, data, q) + pin.updateFramePlacement(model, data, tip)
  J_b  pin.computeFrameJacobian(model, data, q, tip, pin.LOCAL)   (tip frame; FK pass included)
  rnea pin.rnea(model, data, q, v, a)
  M    pin.crba(model, data, q)   (upper triangle only; chasles gives the full matrix)
chasles's fk returns a new 4×4 numpy array; pin's updateFramePlacement returns an SE3 object.

Batch: chasles's fk and rnea of 1000 configurations in one call against the same 1000 in a C++
loop, timed by `chasles_python_oracle --time ROBOT` (its own 1000 configurations, same
distribution, results written into one preallocated array as the batch writes its numpy array),
both the best of 50 runs.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import timeit
from pathlib import Path

import numpy as np
import pinocchio as pin

import chasles

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "tests" / "data"
ROBOTS = {"ur5": ("tool0", []), "panda": ("panda_hand", ["panda_finger_joint1", "panda_finger_joint2"])}
REPEATS = 7


def best_per_call(run, calls: int) -> float:
    """ns per call of the best of REPEATS passes."""
    passes = max(1, 20000 // calls)
    return min(timeit.repeat(run, number=passes, repeat=REPEATS)) / (passes * calls) * 1e9


def pin_model(robot: str, tip: str, locked: list[str]) -> tuple[pin.Model, int]:
    model = pin.buildModelFromUrdf(str(DATA / f"{robot}.urdf"))
    if locked:
        model = pin.buildReducedModel(model, [model.getJointId(name) for name in locked], pin.neutral(model))
    return model, model.getFrameId(tip)


def per_call(robot: str) -> list[tuple[str, float, float]]:
    tip, locked = ROBOTS[robot]
    model = chasles.Model.from_urdf(str(DATA / f"{robot}.urdf"), tip=tip)
    pmodel, frame = pin_model(robot, tip, locked)
    pdata = pmodel.createData()
    assert pmodel.nq == model.nq and list(pmodel.names)[1:] == model.joint_names
    rng = np.random.default_rng(1)
    table = [rng.uniform(model.lower, model.upper) for _ in range(256)]
    # The same quantities, checked once before timing (Pinocchio's twists are (v, ω): rows permuted).
    q = table[0]
    pin.forwardKinematics(pmodel, pdata, q)
    assert np.allclose(pin.updateFramePlacement(pmodel, pdata, frame).homogeneous, model.fk(q), atol=1e-9)
    J = pin.computeFrameJacobian(pmodel, pdata, q, frame, pin.LOCAL)
    assert np.allclose(np.vstack([J[3:], J[:3]]), model.body_jacobian(q), atol=1e-9)
    assert np.allclose(pin.rnea(pmodel, pdata, q, q, q), model.rnea(q, q, q), rtol=1e-9, atol=1e-9)
    assert np.allclose(np.triu(pin.crba(pmodel, pdata, q)), np.triu(model.mass_matrix(q)), rtol=1e-9, atol=1e-9)

    def fk_pin() -> None:
        for q in table:
            pin.forwardKinematics(pmodel, pdata, q)
            pin.updateFramePlacement(pmodel, pdata, frame)

    pairs = {
        "fk": (lambda: [model.fk(q) for q in table], fk_pin),
        "J_b": (lambda: [model.body_jacobian(q) for q in table],
                lambda: [pin.computeFrameJacobian(pmodel, pdata, q, frame, pin.LOCAL) for q in table]),
        "rnea": (lambda: [model.rnea(q, q, q) for q in table], lambda: [pin.rnea(pmodel, pdata, q, q, q) for q in table]),
        "M": (lambda: [model.mass_matrix(q) for q in table], lambda: [pin.crba(pmodel, pdata, q) for q in table]),
    }
    return [(name, best_per_call(ours, len(table)), best_per_call(theirs, len(table)))
            for name, (ours, theirs) in pairs.items()]


def batch(robot: str, oracle: Path) -> list[tuple[str, float, float]]:
    tip, _ = ROBOTS[robot]
    model = chasles.Model.from_urdf(str(DATA / f"{robot}.urdf"), tip=tip)
    Q = np.random.default_rng(1).uniform(model.lower, model.upper, size=(1000, model.nq))
    cpp = json.loads(subprocess.run([str(oracle), "--time", robot], check=True, capture_output=True, text=True).stdout)
    # Best of 50 single calls, as the oracle takes the best of 50 loops.
    fk = min(timeit.repeat(lambda: model.fk(Q), number=1, repeat=50)) * 1e6
    rnea = min(timeit.repeat(lambda: model.rnea(Q, Q, Q), number=1, repeat=50)) * 1e6
    return [("fk ×1000", fk, cpp["fk_us"]), ("rnea ×1000", rnea, cpp["rnea_us"])]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--build", default=os.environ.get("CHASLES_BUILD", str(ROOT / "build")),
                        help="the build tree with chasles_python_oracle (default: $CHASLES_BUILD or build/)")
    args = parser.parse_args()
    oracle = Path(args.build) / "tests" / "python" / "chasles_python_oracle"
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}, pin {pin.__version__}")
    print(f"{'robot':6} {'call':10} {'chasles ns':>11} {'pin ns':>8} {'ratio':>6}")
    for robot in ROBOTS:
        for name, ours, theirs in per_call(robot):
            print(f"{robot:6} {name:10} {ours:11.0f} {theirs:8.0f} {ours / theirs:6.2f}")
    print(f"\n{'robot':6} {'batch':10} {'python µs':>11} {'C++ µs':>8} {'ratio':>6}")
    for robot in ROBOTS:
        for name, ours, cpp in batch(robot, oracle):
            print(f"{robot:6} {name:10} {ours:11.1f} {cpp:8.1f} {ours / cpp:6.2f}")


if __name__ == "__main__":
    main()
