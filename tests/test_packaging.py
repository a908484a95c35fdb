"""Packaging conventions: one version, ``py.typed``, the citation file, mypy on the package,
and a wheel and an sdist that build and install into a fresh environment.

The fresh environment is a new venv into which only the wheel is installed (``--no-deps
--no-index``: nothing is downloaded). Its dependencies (numpy, scipy, heyoka, xarray, ...)
are those of the environment running the tests, made visible by a ``.pth`` line naming
that environment's site-packages, so that heyoka is not downloaded and compiled again.
A ``.pth`` line only adds a folder to ``sys.path``; the ``.pth`` files *inside* that folder
(an editable install of this checkout) are not read, and the new venv's own site-packages
comes first: the package imported there is the wheel's copy, which the test asserts.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import sysconfig
import tarfile
import textwrap
import tomllib
import venv
import zipfile
from pathlib import Path

import pytest

import impactosc

ROOT = Path(__file__).resolve().parent.parent
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())


def test_version_is_written_once():
    project = PYPROJECT["project"]
    assert "version" not in project and "version" in project["dynamic"]
    assert PYPROJECT["tool"]["hatch"]["version"]["path"] == "impactosc/_version.py"
    assert re.fullmatch(r"\d+\.\d+\.\d+([.-]?(a|b|rc|dev|post)\d*)*", impactosc.__version__)
    assert "version:" not in (ROOT / "CITATION.cff").read_text().replace("cff-version:", "")
    changelog = (ROOT / "CHANGELOG.md").read_text()
    assert f"## [{impactosc.__version__}]" in changelog, "the version has no section in CHANGELOG.md"


def test_citation_cites_the_software_and_the_paper():
    yaml = pytest.importorskip("yaml")
    cff = yaml.safe_load((ROOT / "CITATION.cff").read_text())
    assert cff["cff-version"] == "1.2.0" and cff["type"] == "software"
    assert cff["message"] and cff["authors"] and "impactosc" in cff["title"]
    assert cff["license"] == PYPROJECT["project"]["license"]["text"]
    (paper,) = [ref for ref in cff["references"] if ref.get("doi") == "10.1115/1.2748775"]
    assert paper["title"] == "Characterization of Tape Edge Contact Force With Acoustic Emission"
    assert paper["type"] == "article" and paper["authors"] and paper["publisher"]["name"] == "ASME"


def test_license_file_is_the_declared_mit_license():
    text = (ROOT / "LICENSE").read_text()
    assert PYPROJECT["project"]["license"]["text"] == "MIT"
    assert text.startswith("MIT License\n") and "Copyright (c) 2026 the impactosc developers" in text


def test_package_is_marked_typed():
    assert (ROOT / "impactosc" / "py.typed").is_file()


def test_mypy_passes_on_the_package():
    pytest.importorskip("mypy")
    # The configuration ([tool.mypy] in pyproject.toml) names the files: impactosc/.
    proc = subprocess.run([sys.executable, "-m", "mypy"], cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "Success" in proc.stdout


def _package_files() -> set[str]:
    files = {p.relative_to(ROOT).as_posix() for p in (ROOT / "impactosc").rglob("*.py")}
    return files | {"impactosc/py.typed"}


@pytest.fixture(scope="module")
def dist(tmp_path_factory) -> Path:
    """The sdist, and the wheel built from it (``python -m build`` builds the wheel from the sdist)."""
    pytest.importorskip("build")
    pytest.importorskip("hatchling")
    out = tmp_path_factory.mktemp("dist")
    proc = subprocess.run([sys.executable, "-m", "build", "--no-isolation", "--outdir", str(out), str(ROOT)],
                          cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return out


def test_sdist_and_wheel_hold_the_whole_package(dist):
    (sdist,) = dist.glob("impactosc-*.tar.gz")
    (wheel,) = dist.glob("impactosc-*.whl")
    assert sdist.name == f"impactosc-{impactosc.__version__}.tar.gz"
    with tarfile.open(sdist) as tar:
        in_sdist = {name.split("/", 1)[1] for name in tar.getnames() if "/" in name}
    assert _package_files() | {"pyproject.toml", "README.md", "CHANGELOG.md", "CITATION.cff", "LICENSE"} <= in_sdist
    with zipfile.ZipFile(wheel) as zf:
        in_wheel = set(zf.namelist())
        metadata = zf.read(f"impactosc-{impactosc.__version__}.dist-info/METADATA").decode()
    assert _package_files() <= in_wheel, f"missing from the wheel: {sorted(_package_files() - in_wheel)}"
    assert f"impactosc-{impactosc.__version__}.dist-info/licenses/LICENSE" in in_wheel
    assert not any("__pycache__" in name or name.startswith(("tests/", "docs/")) for name in in_wheel)
    assert f"Version: {impactosc.__version__}" in metadata


INSTALLED_CHECK = textwrap.dedent("""
    import importlib, importlib.metadata as md, pathlib, pkgutil, re, sys
    import impactosc as io

    here = pathlib.Path(io.__file__).resolve()
    assert here.is_relative_to(pathlib.Path(sys.prefix).resolve()), f"not the installed copy: {here}"
    assert md.version("impactosc") == io.__version__
    assert (here.parent / "py.typed").is_file()
    for info in pkgutil.walk_packages(io.__path__, "impactosc."):
        importlib.import_module(info.name)
    for req in md.requires("impactosc"):
        if "extra ==" not in req:
            md.version(re.split(r"[<>=!~ ;\\[]", req, maxsplit=1)[0])  # each dependency is there
    sol = io.simulate(io.Oscillator(F=0.5, Omega=1.1, beta=0.01, K=1e4), 100.0)
    assert sol.status == 0 and sol.counts["contact_start"] > 0, sol
    print("installed impactosc", io.__version__, "ran:", sol.summary())
""")


def test_wheel_installs_and_runs_in_a_fresh_venv(dist, tmp_path):
    (wheel,) = dist.glob("impactosc-*.whl")
    env_dir = tmp_path / "venv"
    venv.EnvBuilder(with_pip=False).create(env_dir)
    python = env_dir / ("Scripts/python.exe" if os.name == "nt" else "bin/python")
    site = subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                          capture_output=True, text=True, check=True).stdout.strip()
    Path(site, "test-environment-dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV")}
    install = subprocess.run([sys.executable, "-m", "pip", "--python", str(python), "install", "--no-deps",
                              "--no-index", "--quiet", str(wheel)], capture_output=True, text=True, env=env,
                             timeout=300)
    assert install.returncode == 0, install.stdout + install.stderr

    run = subprocess.run([str(python), "-c", INSTALLED_CHECK], cwd=tmp_path, capture_output=True, text=True,
                         env=env, timeout=300)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "installed impactosc" in run.stdout

    cli = env_dir / ("Scripts/impactosc.exe" if os.name == "nt" else "bin/impactosc")
    help_text = subprocess.run([str(cli), "--help"], cwd=tmp_path, capture_output=True, text=True, env=env,
                               timeout=120)
    assert help_text.returncode == 0 and "simulate" in help_text.stdout, help_text.stderr
