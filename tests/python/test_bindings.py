"""chasles._core against the C++ library bit for bit, and against the independent references.

chasles_python_oracle (tests/python/oracle.cpp) prints what the C++ library computes on every
reference case of tests/data; each bound quantity, from one call per case and from one batch of
every case, must equal it exactly. The same results are then held to Pinocchio's values in
tests/data within the tolerances the C++ tests use (kinematics 1e-10 absolute, dynamics 1e-9
relative to max(1, |expected|)), and IK, the observer and calibration to references known by
construction.
"""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

import chasles

DATA = Path(os.environ["CHASLES_TEST_DATA"])
BUILD = Path(os.environ["CHASLES_BUILD"])
ROBOTS = ["ur5", "panda", "tiago", "talos_left_arm", "finger_edu", "iiwa14"]
OBSERVER_GAIN, OBSERVER_STEP = 50.0, 1e-3  # as oracle.cpp's

# Every Model method the oracle prints, with the case fields it takes.
METHODS = {
    "fk": ("q",),
    "link_poses": ("q",),
    "space_jacobian": ("q",),
    "body_jacobian": ("q",),
    "rnea": ("q", "qd", "qdd"),
    "gravity": ("q",),
    "coriolis": ("q", "qd"),
    "mass_matrix": ("q",),
    "forward_dynamics": ("q", "qd", "tau_in"),
    "kinetic_energy": ("q", "qd"),
    "potential_energy": ("q",),
}


@pytest.fixture(scope="module")
def oracle() -> dict:
    """The C++ library's results on every reference case (oracle.cpp)."""
    out = subprocess.run([str(BUILD / "tests" / "python" / "chasles_python_oracle")],
                         check=True, capture_output=True, text=True).stdout
    return json.loads(out)


def model_of(robot: str) -> chasles.Model:
    reference = json.loads((DATA / f"{robot}.json").read_text())
    return chasles.Model.from_urdf(str(DATA / f"{robot}.urdf"), tip=reference["tip_link"])


@pytest.mark.parametrize("robot", ROBOTS)
def test_single_calls_equal_the_cpp_library_bit_for_bit(oracle: dict, robot: str) -> None:
    model = model_of(robot)
    for k, case in enumerate(oracle[robot]["cases"]):
        for method, fields in METHODS.items():
            got = getattr(model, method)(*(np.array(case[f]) for f in fields))
            assert np.array_equal(got, np.array(case[method])), f"{robot} case {k} {method}"
        wrench = chasles.tip_wrench_from_torque(model.body_jacobian(np.array(case["q"])), np.array(case["tau_in"]))
        assert np.array_equal(wrench, np.array(case["tip_wrench"])), f"{robot} case {k} tip_wrench"


@pytest.mark.parametrize("robot", ROBOTS)
def test_batches_equal_the_cpp_library_bit_for_bit(oracle: dict, robot: str) -> None:
    model = model_of(robot)
    cases = oracle[robot]["cases"]
    stacked = {f: np.array([c[f] for c in cases]) for f in ("q", "qd", "qdd", "tau_in")}
    for method, fields in METHODS.items():
        got = getattr(model, method)(*(stacked[f] for f in fields))
        expected = np.array([c[method] for c in cases])
        assert got.shape == expected.shape, method
        assert np.array_equal(got, expected), f"{robot} {method}"


@pytest.mark.parametrize("robot", ROBOTS)
def test_the_observer_equals_the_cpp_library_bit_for_bit(oracle: dict, robot: str) -> None:
    model = model_of(robot)
    cases = oracle[robot]["cases"]
    observer = chasles.MomentumObserver(model, np.full(model.nq, OBSERVER_GAIN))
    observer.reset(np.array(cases[0]["q"]), np.array(cases[0]["qd"]))
    assert np.array_equal(observer.external_torque, np.array(cases[0]["observer"]))
    for k, case in enumerate(cases[1:], start=1):
        r = observer.update(np.array(case["q"]), np.array(case["qd"]), np.array(case["tau_in"]), OBSERVER_STEP)
        assert np.array_equal(r, np.array(case["observer"])), f"{robot} case {k}"


def near_relative(actual: np.ndarray, expected: np.ndarray, tolerance: float) -> bool:
    """|a − e| ≤ tolerance · max(1, max |e|), as tests/support/reference.hpp's matrices_near_relative."""
    return bool(np.all(np.abs(actual - expected) <= tolerance * max(1.0, float(np.max(np.abs(expected))))))


@pytest.mark.parametrize("robot", ROBOTS)
def test_results_match_pinocchio_within_the_cpp_tests_tolerances(robot: str) -> None:
    reference = json.loads((DATA / f"{robot}.json").read_text())
    model = model_of(robot)
    assert model.joint_names == reference["joint_names"]
    assert model.base == reference["base_link"] and model.tip == reference["tip_link"]
    assert np.array_equal(model.lower, np.array(reference["limits"]["lower"]))
    assert np.array_equal(model.upper, np.array(reference["limits"]["upper"]))
    assert np.allclose(model.home, np.array(reference["home"]["T"]), rtol=0, atol=1e-10)
    assert np.allclose(model.space_axes, np.array(reference["home"]["S"]).T, rtol=0, atol=1e-10)
    # The iiwa's URDF carries rotor inertias, which the reference gives apart (tests/data/README.md).
    with_armature = "armature" in reference
    if with_armature:
        assert np.allclose(model.armature, np.array(reference["armature"]["values"]), rtol=1e-12, atol=0)
    for k, case in enumerate(reference["cases"]):
        q, qd, qdd = (np.array(case[f]) for f in ("q", "qd", "qdd"))
        assert np.allclose(model.fk(q), np.array(case["T"]), rtol=0, atol=1e-10), k
        assert np.allclose(model.space_jacobian(q), np.array(case["J_s"]), rtol=0, atol=1e-10), k
        assert np.allclose(model.body_jacobian(q), np.array(case["J_b"]), rtol=0, atol=1e-10), k
        poses = dict(zip(model.link_names, model.link_poses(q)))
        for name, T in case["link_T"].items():
            assert np.allclose(poses[name], np.array(T), rtol=0, atol=1e-10), (k, name)
        tau, M = (("tau_with_armature", "M_with_armature") if with_armature else ("tau", "M"))
        assert near_relative(model.rnea(q, qd, qdd), np.array(case[tau]), 1e-9), k
        assert near_relative(model.mass_matrix(q), np.array(case[M]), 1e-9), k
        assert near_relative(model.gravity(q), np.array(case["g"]), 1e-9), k
        assert near_relative(model.coriolis(q, qd), np.array(case["c"]), 1e-9), k
        if with_armature:
            assert near_relative(model.forward_dynamics(q, qd, np.array(case["tau"])),
                                 np.array(case["qdd_of_tau_with_armature"]), 1e-9), k
        else:
            assert near_relative(model.forward_dynamics(q, qd, np.array(case["tau"])), qdd, 1e-9), k


def test_energies_satisfy_their_definitions_on_the_reference_mass_matrix() -> None:
    """½ q̇ᵀ M q̇ with Pinocchio's M; the potential energy's change is −(work of gravity) = g(q)·δq."""
    reference = json.loads((DATA / "ur5.json").read_text())
    model = model_of("ur5")
    for case in reference["cases"][:10]:
        q, qd = np.array(case["q"]), np.array(case["qd"])
        assert model.kinetic_energy(q, qd) == pytest.approx(0.5 * qd @ np.array(case["M"]) @ qd, rel=1e-12)
        h, dq = 1e-6, np.linspace(-1.0, 1.0, model.nq)
        dV = (model.potential_energy(q + h * dq) - model.potential_energy(q - h * dq)) / (2 * h)
        assert dV == pytest.approx(np.array(case["g"]) @ dq, rel=1e-6, abs=1e-6)


def test_inputs_of_other_layouts_are_converted_to_the_same_result() -> None:
    """Lists, integers, float32 and strided views give what the float64 contiguous array gives."""
    model = model_of("ur5")
    q = np.array([0.0, 1.0, -1.0, 2.0, 0.0, 1.0])
    expected = model.mass_matrix(q)
    assert np.array_equal(model.mass_matrix(q.tolist()), expected)
    assert np.array_equal(model.mass_matrix(q.astype(np.int64)), expected)
    assert np.array_equal(model.mass_matrix(q.astype(np.float32)), expected)  # these values are exact in float32
    assert np.array_equal(model.mass_matrix(np.repeat(q, 2)[::2]), expected)
    Q = np.asfortranarray(np.stack([q, -q]))
    assert np.array_equal(model.mass_matrix(Q), np.stack([expected, model.mass_matrix(-q)]))


def test_ik_reaches_the_reference_targets_and_fk_confirms() -> None:
    """tests/data/ik_ur5.json: targets from Pinocchio's FK of random q; any solution within the limits counts."""
    targets = json.loads((DATA / "ik_ur5.json").read_text())
    model = model_of("ur5")
    options = chasles.IkOptions()
    options.time_budget = 0.05
    solver = chasles.IkSolver(model, options)
    assert solver.options.time_budget == 0.05
    for case in targets["cases"][:20]:
        T = np.array(case["T_target"])
        result = solver.solve(T, np.array(case["q_seed"]))
        assert result.converged
        assert np.all(result.q >= model.lower) and np.all(result.q <= model.upper)
        T_sol = model.fk(result.q)
        assert np.linalg.norm(T_sol[:3, 3] - T[:3, 3]) <= 1e-6 + 1e-12
        assert result.pos_err == pytest.approx(np.linalg.norm(T_sol[:3, 3] - T[:3, 3]), abs=1e-12)


def test_observer_reads_a_constant_external_torque_through_its_lag() -> None:
    """A resting arm held by τ = g(q) − τ_ext: the residual is (1 − exp(−K t)) τ_ext at every sample."""
    model = model_of("ur5")
    q, qd = np.array([0.1, -1.0, 1.2, -0.5, 0.3, 0.0]), np.zeros(6)
    tau_ext = np.array([1.0, -2.0, 0.5, 0.25, -0.1, 0.05])
    gain, dt = 20.0, 1e-3
    observer = chasles.MomentumObserver(model, np.full(6, gain))
    observer.reset(q, qd)
    for k in range(1, 51):
        r = observer.update(q, qd, model.gravity(q) - tau_ext, dt)
        assert np.allclose(r, (1 - np.exp(-gain * k * dt)) * tau_ext, rtol=0, atol=1e-9), k


def test_tip_wrench_recovers_a_wrench_through_the_jacobian_transpose() -> None:
    """τ = J_bᵀ F at a full-rank pose gives back F."""
    model = model_of("ur5")
    J_b = model.body_jacobian(np.array([0.3, -1.1, 1.4, -0.6, 0.8, 0.2]))
    F = np.array([0.5, -0.2, 0.1, 3.0, -4.0, 10.0])
    assert np.allclose(chasles.tip_wrench_from_torque(J_b, J_b.T @ F), F, rtol=0, atol=1e-9)


def test_calibration_recovers_a_known_offset_base_and_tool() -> None:
    """Measurements made by a model whose joint 2 reads 0.01 rad short, seen from a shifted tracker
    with a marker 5 cm out on the tool: calibration finds the offset and predicts the marker."""
    urdf = (DATA / "ur5.urdf").read_text()
    nominal = chasles.Model.from_urdf_string(urdf, tip="tool0")
    rng = np.random.default_rng(3)
    q = rng.uniform(-2.5, 2.5, size=(40, nominal.nq))
    offset = np.array([0.0, 0.01, 0.0, 0.0, 0.0, 0.0])
    T_tracker_base = np.eye(4)
    T_tracker_base[:3, 3] = [1.0, 0.5, 0.2]
    marker = np.array([0.0, 0.0, 0.05, 1.0])
    p = np.array([(T_tracker_base @ nominal.fk(qk + offset) @ marker)[:3] for qk in q])
    dataset = chasles.Dataset.from_arrays(nominal, q, p)
    assert len(dataset) == 40 and not dataset.has_orientation and dataset.R is None
    assert np.array_equal(dataset.q, q) and np.array_equal(dataset.p, p)
    fit, holdout = dataset.split(0.25, seed=1)
    assert (len(fit), len(holdout)) == (30, 10)
    options = chasles.CalibrationOptions()
    options.loss = chasles.Loss.HUBER
    result = chasles.calibrate(nominal, fit, holdout, options)
    assert result.converged
    assert result.fit_after.rms_position < 1e-8 and result.holdout_after.rms_position < 1e-8
    assert result.fit_before.rms_position > 1e-3
    calibrated = chasles.corrected_model(nominal, result.after)
    for qk, pk in zip(holdout.q, holdout.p):
        predicted = result.after.T_tracker_base @ calibrated.fk(qk) @ result.after.T_tip_marker
        assert np.allclose(predicted[:3, 3], pk, rtol=0, atol=1e-8)
    assert len(chasles.parameter_names(nominal)) == result.x.shape[0] == 7 * 6 + 12
    assert "marker" in chasles.corrected_urdf(urdf, nominal, result.after)


def test_datasets_read_from_csv_name_their_lines() -> None:
    model = model_of("ur5")
    header = ",".join(model.joint_names) + ",x,y,z\n"
    text = header + "# a comment\n" + "0,0.1,0.2,0.3,0.4,0.5,1,2,3\n"
    dataset = chasles.parse_dataset(text, model, "memory.csv")
    assert dataset.lines == [3]
    assert np.array_equal(dataset.q, [[0, 0.1, 0.2, 0.3, 0.4, 0.5]]) and np.array_equal(dataset.p, [[1, 2, 3]])
