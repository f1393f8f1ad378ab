"""Inverse kinematics over a grid of reachable poses.

    python ik_grid.py ARM.urdf OUT.json [--tip LINK] [--grid K] [--seed S] [--budget SECONDS]

The targets are the tip poses of a K×K×K grid over the arm's first three joints (each from
lower + 10 % to upper − 10 % of its range), the other joints at random values within their limits:
every target is reachable by construction. Each is solved from one seed configuration (the middle
of every range). Prints a JSON summary on stdout: the number of targets, the success rate and the
median and largest solve time (µs, wall clock). OUT.json holds every target (4×4), the
configuration it was made from, the solution and the solver's report.
"""

from __future__ import annotations

import argparse
import itertools
import json
import os

import numpy as np

import chasles


def grid_configurations(model: chasles.Model, k: int, seed: int) -> np.ndarray:
    """(k³, n) configurations: a grid over joints 1-3 at 10 %…90 % of their ranges, the rest random."""
    rng = np.random.default_rng(seed)
    lower, upper = model.lower, model.upper
    axes = [np.linspace(lower[i] + 0.1 * (upper[i] - lower[i]), upper[i] - 0.1 * (upper[i] - lower[i]), k)
            for i in range(3)]
    rows = []
    for values in itertools.product(*axes):
        q = rng.uniform(lower + 0.1 * (upper - lower), upper - 0.1 * (upper - lower))
        q[:3] = values
        rows.append(q)
    return np.array(rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("urdf")
    parser.add_argument("out")
    parser.add_argument("--tip", default=None, help="tip link (default: the tree's single leaf)")
    parser.add_argument("--grid", type=int, default=4, help="grid points per joint (K)")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--budget", type=float, default=0.05, help="time budget per solve, s (CPU time)")
    args = parser.parse_args()

    model = chasles.Model.from_urdf(args.urdf, tip=args.tip)
    options = chasles.IkOptions()
    options.time_budget = args.budget
    solver = chasles.IkSolver(model, options)
    q_made = grid_configurations(model, args.grid, args.seed)
    targets = model.fk(q_made)
    q_seed = 0.5 * (model.lower + model.upper)
    results = [solver.solve(T, q_seed) for T in targets]

    times = np.array([r.time_us for r in results])
    partial = args.out + ".partial"  # written whole, then renamed: no half-written report at OUT.json
    with open(partial, "w") as out:
        json.dump({
            "tip": model.tip,
            "targets": [{
                "T": T.tolist(), "q_made": q.tolist(), "q": r.q.tolist(), "converged": r.converged,
                "pos_err": r.pos_err, "rot_err": r.rot_err, "restarts": r.restarts, "time_us": r.time_us,
            } for T, q, r in zip(targets, q_made, results)],
        }, out)
    os.replace(partial, args.out)
    print(json.dumps({
        "targets": len(results),
        "success_rate": sum(r.converged for r in results) / len(results),
        "median_time_us": float(np.median(times)),
        "max_time_us": float(np.max(times)),
    }))


if __name__ == "__main__":
    main()
