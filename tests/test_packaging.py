"""The installed package holds every subpackage and data file (``pip install .``).

An editable install (what the test suite runs on) imports from the source tree
and hides a package list that forgets a subpackage; a wheel does not.
"""

import pathlib
import shutil
import subprocess
import sys
import zipfile

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_wheel_holds_every_module(tmp_path):
    # a copy: setuptools reuses a build/ directory left in the source tree
    src = tmp_path / "src"
    src.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, src / name)
    shutil.copytree(ROOT / "gaocvx", src / "gaocvx", ignore=shutil.ignore_patterns("__pycache__"))
    build = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "--wheel-dir", str(tmp_path),
         str(src)], capture_output=True, text=True, cwd=tmp_path)
    assert build.returncode == 0, build.stderr
    (wheel,) = tmp_path.glob("gaocvx-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    source = {p.relative_to(ROOT).as_posix() for p in (ROOT / "gaocvx").rglob("*")
              if p.suffix in (".py", ".json") and "__pycache__" not in p.parts}
    assert source, "no sources found"
    assert source <= names, sorted(source - names)
