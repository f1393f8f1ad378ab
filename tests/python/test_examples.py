"""The model examples of python/examples, run as a user runs them; their outputs checked
against references computed here without chasles."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import xml.etree.ElementTree as ElementTree
from pathlib import Path

import numpy as np

import chasles

DATA = Path(os.environ["CHASLES_TEST_DATA"])
EXAMPLES = Path(__file__).resolve().parents[2] / "python" / "examples"


def run_example(name: str, *args: str) -> dict:
    run = subprocess.run([sys.executable, str(EXAMPLES / name), *args], capture_output=True, text=True, check=True)
    return json.loads(run.stdout)


def reach_bound(urdf: Path, tip: str) -> float:
    """Σ |p_i| over the joint origins from the root to `tip`, read from the XML: no tip position can be
    farther from the base origin (each joint motion is a rotation about, or a translation along, an
    axis through its own origin, and rotations keep lengths)."""
    joints = {j.find("child").get("link"): j for j in ElementTree.parse(urdf).getroot().iter("joint")}
    bound, link = 0.0, tip
    while link in joints:
        joint = joints[link]
        assert joint.get("type") in ("revolute", "continuous", "fixed")
        origin = joint.find("origin")
        bound += float(np.linalg.norm([float(v) for v in origin.get("xyz", "0 0 0").split()]))
        link = joint.find("parent").get("link")
    return bound


def test_workspace_plots_the_tip_positions_and_reaches_the_arms_bound(tmp_path: Path) -> None:
    """lbr7's joint origins are all on one line at q = 0, so its reach is the bound itself, and
    20000 samples come within 0.5 % of it without passing it."""
    png = tmp_path / "workspace.png"
    summary = run_example("workspace.py", str(DATA / "lbr7.urdf"), str(png), "--samples", "20000")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10000
    bound = reach_bound(DATA / "lbr7.urdf", "flange")
    assert abs(bound - 1.332) < 1e-12  # 0.1575 + 0.2025 + 0.2045 + 0.2155 + 0.1845 + 0.2155 + 0.081 + 0.071
    assert 0.995 * bound <= summary["max_reach"] <= bound
    assert summary["samples"] == 20000


def test_ik_grid_solves_every_reachable_pose(tmp_path: Path) -> None:
    out = tmp_path / "ik.json"
    summary = run_example("ik_grid.py", str(DATA / "ur5.urdf"), str(out), "--tip", "tool0", "--grid", "4")
    assert summary["targets"] == 64 and summary["success_rate"] == 1.0
    model = chasles.Model.from_urdf(str(DATA / "ur5.urdf"), tip="tool0")
    results = json.loads(out.read_text())["targets"]
    assert len(results) == 64
    for r in results:
        assert r["converged"]
        T, T_made, T_sol = np.array(r["T"]), model.fk(np.array(r["q_made"])), model.fk(np.array(r["q"]))
        assert np.array_equal(T, T_made)
        assert np.linalg.norm(T_sol[:3, 3] - T[:3, 3]) <= 1e-6
        rotation = np.clip((np.trace(T[:3, :3].T @ T_sol[:3, :3]) - 1) / 2, -1.0, 1.0)
        assert np.arccos(rotation) <= 1e-5  # arccos near 1 loses half the digits of a 1e-6 rad tolerance
