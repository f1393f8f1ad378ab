"""Bad input from Python raises the chasles.Error subclass the C++ library throws, with its message,
and never crashes the interpreter (each case also runs in a child interpreter, whose exit code
says it survived)."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import chasles

DATA = Path(os.environ["CHASLES_TEST_DATA"])


@pytest.fixture(scope="module")
def ur5() -> chasles.Model:
    return chasles.Model.from_urdf(str(DATA / "ur5.urdf"), tip="tool0")


def test_the_hierarchy_mirrors_the_cpp_one() -> None:
    for cls in (chasles.ModelError, chasles.ArgumentError, chasles.DynamicsError, chasles.ObserverError,
                chasles.CalibrationError):
        assert issubclass(cls, chasles.Error)
    assert issubclass(chasles.TipNotChosenError, chasles.ModelError)
    assert issubclass(chasles.ArgumentError, ValueError)


@pytest.mark.parametrize("q, message", [
    (np.zeros(5), "q has 5 entries, the model has 6 joints"),
    (np.zeros((2, 5)), "q has shape (2, 5), expected (6,) for one configuration or (N, 6)"),
    (np.zeros((2, 3, 6)), "q has shape (2, 3, 6)"),
    (np.float64(1.0), "q has shape ()"),
])
def test_a_wrong_shape_is_an_argument_error(ur5: chasles.Model, q: np.ndarray, message: str) -> None:
    with pytest.raises(chasles.ArgumentError, match=message.replace("(", r"\(").replace(")", r"\)")):
        ur5.fk(q)


def test_batches_of_different_lengths_or_mixed_with_single_vectors_are_refused(ur5: chasles.Model) -> None:
    with pytest.raises(chasles.ArgumentError, match="qd has 3 rows, q has 2"):
        ur5.coriolis(np.zeros((2, 6)), np.zeros((3, 6)))
    with pytest.raises(chasles.ArgumentError, match="give every argument for one configuration or all for a batch"):
        ur5.rnea(np.zeros(6), np.zeros((2, 6)), np.zeros(6))


@pytest.mark.parametrize("q, reason", [
    (np.array(["a"] * 6), r"Cannot cast array data from dtype\('<U1'\) to dtype\('float64'\)"),
    (np.zeros(6, dtype=complex), r"Cannot cast array data from dtype\('complex128'\)"),
    (["x", 0, 0, 0, 0, 0], "could not convert string to float"),
    ([object()] * 6, "float"),
])
def test_a_dtype_that_cannot_be_read_as_float64_is_refused(ur5: chasles.Model, q: object, reason: str) -> None:
    with pytest.raises(chasles.ArgumentError, match="q cannot be read as float64 numbers: .*" + reason):
        ur5.mass_matrix(q)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_a_non_finite_entry_is_named(ur5: chasles.Model, bad: float) -> None:
    q = np.zeros(6)
    q[3] = bad
    with pytest.raises(chasles.ArgumentError, match=r"q\[3\] is .*; every entry must be finite"):
        ur5.body_jacobian(q)
    Q = np.zeros((4, 6))
    Q[2, 1] = bad
    with pytest.raises(chasles.ArgumentError, match=r"qd\[2, 1\] is .*; every entry must be finite"):
        ur5.kinetic_energy(np.zeros((4, 6)), Q)


def test_a_missing_urdf_file_is_a_model_error_naming_it(tmp_path: Path) -> None:
    path = tmp_path / "absent.urdf"
    with pytest.raises(chasles.ModelError, match=f"{path}: cannot open URDF file: No such file or directory"):
        chasles.Model.from_urdf(str(path))


def test_a_malformed_urdf_string_is_a_model_error() -> None:
    with pytest.raises(chasles.ModelError, match="<urdf string>: malformed XML at line 1"):
        chasles.Model.from_urdf_string("<robot name='r'><link name='a'>")


def test_a_tree_with_several_leaves_needs_a_tip() -> None:
    with pytest.raises(chasles.TipNotChosenError, match="the tree has 3 leaves .*name the tip link"):
        chasles.Model.from_urdf(str(DATA / "panda.urdf"))


def test_an_unreachable_pose_is_not_converged_rather_than_an_error(ur5: chasles.Model) -> None:
    options = chasles.IkOptions()
    options.time_budget = 0.002
    options.max_restarts = 3
    T = np.eye(4)
    T[:3, 3] = [5.0, 0.0, 0.0]  # the ur5 reaches under 1 m
    result = chasles.IkSolver(ur5, options).solve(T, np.zeros(6))
    assert not result.converged
    assert result.pos_err > 3.9
    assert result.restarts <= 3


@pytest.mark.parametrize("T, message", [
    (np.diag([2.0, 1.0, 1.0, 1.0]), "IK target: the rotation is not orthonormal"),
    (np.diag([1.0, 1.0, 1.0, 2.0]), "IK target"),
    (np.full((4, 4), np.nan), r"IK target: entry \(0, 0\) is not finite"),
    (np.eye(3), r"target has shape \(3, 3\), expected \(4, 4\)"),
])
def test_a_malformed_ik_target_is_an_argument_error(ur5: chasles.Model, T: np.ndarray, message: str) -> None:
    with pytest.raises(chasles.ArgumentError, match=message):
        chasles.IkSolver(ur5).solve(T, np.zeros(6))


def test_ik_options_out_of_range_are_refused(ur5: chasles.Model) -> None:
    options = chasles.IkOptions()
    options.weights = np.array([1.0, 1.0, 1.0, 0.0, 1.0, 1.0])
    with pytest.raises(chasles.ArgumentError, match="IK weights must be positive and finite"):
        chasles.IkSolver(ur5, options)
    with pytest.raises(chasles.ArgumentError, match="time_budget must be a positive number of seconds"):
        options.time_budget = -1.0


def test_a_singular_mass_matrix_is_a_dynamics_error() -> None:
    model = chasles.Model.from_urdf(str(DATA / "arm_massless_tip.urdf"), tip="tip")
    with pytest.raises(chasles.DynamicsError, match="j3"):
        model.forward_dynamics(np.zeros(3), np.zeros(3), np.zeros(3))


def test_observer_gains_must_be_positive(ur5: chasles.Model) -> None:
    with pytest.raises(chasles.ObserverError):
        chasles.MomentumObserver(ur5, np.full(6, -1.0))
    with pytest.raises(chasles.ArgumentError, match=r"gain has shape \(5,\), expected \(6,\)"):
        chasles.MomentumObserver(ur5, np.ones(5))


@pytest.mark.parametrize("dt, shown", [(np.inf, "inf"), (np.nan, "nan"), (0.0, "0"), (-1e-3, "-0.001")])
def test_an_observer_step_that_is_not_positive_and_finite_is_an_argument_error(
        ur5: chasles.Model, dt: float, shown: str) -> None:
    observer = chasles.MomentumObserver(ur5, np.full(6, 10.0))
    q, qd, tau = np.full(6, 0.3), np.full(6, 0.1), np.ones(6)
    observer.reset(q, qd)
    expected = rf"^the observer's step dt = {shown} s; it must be positive and finite$"
    with pytest.raises(chasles.ArgumentError, match=expected):
        observer.update(q, qd, tau, dt)
    assert np.all(np.isfinite(observer.update(q, qd, tau, 1e-3)))


def test_a_dataset_with_an_unknown_column_names_its_line(ur5: chasles.Model) -> None:
    with pytest.raises(chasles.CalibrationError, match="data.csv:1: .*nope"):
        chasles.parse_dataset("nope,x,y,z\n1,2,3,4\n", ur5, "data.csv")


def test_too_few_rows_to_calibrate_is_a_calibration_error(ur5: chasles.Model) -> None:
    few = chasles.Dataset.from_arrays(ur5, np.zeros((2, 6)), np.zeros((2, 3)))
    with pytest.raises(chasles.CalibrationError):
        chasles.calibrate(ur5, few)


def test_no_bad_input_crashes_the_interpreter() -> None:
    """Every case above at once in a fresh interpreter: it must exit normally, not by a signal."""
    script = textwrap.dedent(f"""
        import numpy as np, chasles
        m = chasles.Model.from_urdf({str(DATA / 'ur5.urdf')!r}, tip='tool0')
        bad = [np.zeros(5), np.zeros((2, 3, 6)), np.array(['a'] * 6), np.full(6, np.nan), [None] * 6,
               np.zeros(0), np.zeros((0, 6)), np.zeros((0, 5))]
        caught = 0
        for q in bad:
            for method in ('fk', 'link_poses', 'space_jacobian', 'body_jacobian', 'gravity', 'mass_matrix',
                           'potential_energy'):
                try:
                    getattr(m, method)(q)
                except chasles.Error:
                    caught += 1
        try:
            chasles.IkSolver(m).solve(np.full((4, 4), np.inf), np.zeros(6))
        except chasles.ArgumentError:
            caught += 1
        print(caught)
    """)
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    # Every bad input but the empty batch (0, 6), which is a valid batch of no configurations.
    assert int(run.stdout) == 7 * 7 + 1
