"""`pip install .` into a fresh venv, as a user installs the package, gives a chasles whose every
module imports away from the source tree: the extension with its stubs and py.typed, the message
classes chasles.lcmtypes, and chasles.client and chasles.logs with the dependencies pip installed
from pyproject.toml alone (the venv starts with scikit-build-core and nothing else: no numpy, no
lcm). test_pip_client.py then drives the simulated arm with the venv this test leaves in
$CHASLES_BUILD/pip-venv (the ctest fixture chasles_pip_venv).

By default the build packages the build tree's own extension (CHASLES_PYTHON_PREBUILT, given here
as $CHASLES_PIP_PREBUILT), so the test takes seconds rather than the minutes the C++ library takes
to compile again; configured with -DCHASLES_PYTHON_PIP_FROM_SOURCE=ON, it compiles everything as a
user's install does.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DATA = Path(os.environ["CHASLES_TEST_DATA"])
VENV = Path(os.environ["CHASLES_BUILD"]) / "pip-venv"
REQUIREMENTS = ROOT / "python" / "requirements.txt"


def pinned(*names: str) -> list[str]:
    """The requirement lines of python/requirements.txt for these packages."""
    lines = REQUIREMENTS.read_text().splitlines()
    return [line for line in lines if line.split("==")[0] in names]


def test_pip_install_gives_a_package_whose_every_module_works(tmp_path: Path) -> None:
    shutil.rmtree(VENV, ignore_errors=True)
    subprocess.run(["/usr/bin/python3", "-m", "venv", str(VENV)], check=True)
    python = VENV / "bin" / "python"
    pip = [str(python), "-m", "pip", "install", "--disable-pip-version-check", "--no-input", "--quiet"]
    prebuilt = os.environ.get("CHASLES_PIP_PREBUILT")
    # --no-build-isolation: the build runs in this venv with the pinned build requirements rather
    # than in a throwaway one pip would fill from PyPI on every run (nanobind and numpy are only
    # needed to compile the extension).
    build_requirements = ("scikit-build-core",) if prebuilt else ("scikit-build-core", "nanobind", "numpy")
    subprocess.run(pip + ["--only-binary=:all:", *pinned(*build_requirements)], check=True)
    before = subprocess.run([str(python), "-m", "pip", "list", "--format=freeze"], check=True, capture_output=True,
                            text=True).stdout
    # What the client needs at run time is pip's to install from the package's declared dependencies.
    assert "lcm==" not in before and (not prebuilt or "numpy==" not in before), before
    # -c: the runtime dependencies pyproject.toml declares, at the versions the suite tests.
    options = ["--no-build-isolation", "-c", str(REQUIREMENTS), "--config-settings", f"build-dir={tmp_path / 'build'}"]
    if prebuilt:
        options += ["--config-settings", f"cmake.define.CHASLES_PYTHON_PREBUILT={prebuilt}"]
    subprocess.run(pip + options + [str(ROOT)], check=True, cwd=tmp_path)

    script = (
        "import pathlib, numpy as np, chasles, chasles.client, chasles.logs\n"
        "from chasles.lcmtypes import robot_state_t\n"
        f"m = chasles.Model.from_urdf({str(DATA / 'ur5.urdf')!r}, tip='tool0')\n"
        "T = m.fk(np.zeros(6))\n"
        "assert abs(T[0, 3] - 0.81725) < 1e-9, T\n"  # upper arm and forearm along x at q = 0: 0.425 + 0.39225 m
        "assert robot_state_t.decode(robot_state_t().encode()).num_joints == 0\n"
        "package = pathlib.Path(chasles.__file__).parent\n"
        "print(package, (package / '_core.pyi').is_file(), (package / 'py.typed').is_file(),\n"
        "      pathlib.Path(chasles.client.lcm.__file__).is_relative_to(package.parent))\n"
    )
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    run = subprocess.run([str(python), "-c", script], check=True, capture_output=True, text=True, cwd=tmp_path, env=env)
    package, stubs, typed, lcm_in_venv = run.stdout.split()
    assert Path(package).is_relative_to(VENV)
    assert (stubs, typed, lcm_in_venv) == ("True", "True", "True")
