"""`pip install .` into a fresh venv builds the package from this CMake project and installs a
working chasles: the extension, its stubs and py.typed, importable away from the source tree.

Slow (it builds the C++ library again): registered as python.test_pip_install with the ctest label
`pip`, disabled unless the tree is configured with -DCHASLES_PYTHON_PIP_TEST=ON.
"""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DATA = Path(os.environ["CHASLES_TEST_DATA"])


def pinned(*names: str) -> list[str]:
    """The requirement lines of python/requirements.txt for these packages."""
    lines = (ROOT / "python" / "requirements.txt").read_text().splitlines()
    return [line for line in lines if line.split("==")[0] in names]


def test_pip_install_builds_and_installs_a_working_package(tmp_path: Path) -> None:
    venv = tmp_path / "venv"
    subprocess.run(["/usr/bin/python3", "-m", "venv", str(venv)], check=True)
    python = venv / "bin" / "python"
    pip = [str(python), "-m", "pip", "install", "--disable-pip-version-check", "--no-input", "--quiet"]
    subprocess.run(pip + ["--only-binary=:all:", *pinned("scikit-build-core", "nanobind", "numpy")], check=True)
    subprocess.run(pip + ["--no-build-isolation", str(ROOT)], check=True, cwd=tmp_path)

    script = (
        "import pathlib, numpy as np, chasles\n"
        f"m = chasles.Model.from_urdf({str(DATA / 'ur5.urdf')!r}, tip='tool0')\n"
        "T = m.fk(np.zeros(6))\n"
        "assert abs(T[0, 3] - 0.81725) < 1e-9, T\n"  # upper arm and forearm along x at q = 0: 0.425 + 0.39225 m
        "package = pathlib.Path(chasles.__file__).parent\n"
        "print(package, (package / '_core.pyi').is_file(), (package / 'py.typed').is_file())\n"
    )
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    run = subprocess.run([str(python), "-c", script], check=True, capture_output=True, text=True, cwd=tmp_path, env=env)
    package, stubs, typed = run.stdout.split()
    assert Path(package).is_relative_to(venv)
    assert (stubs, typed) == ("True", "True")
