"""The package works when installed from a wheel, away from the source tree.

The wheel is built from a copy of the project, installed without dependencies
into a fresh virtual environment, and its ``morpi`` script runs the analytical
assessment and the field tables on a small synthetic dataset from an empty
working directory. The environment reaches numpy, scipy, ... through the site
folders of the interpreter running the suite (a ``.pth`` file naming them), so
it has what the suite has whether the suite runs in the system Python or in a
virtual environment; ``venv --system-site-packages`` would instead reach the
base interpreter's folders, which a user's virtual environment does not share.
Only files shipped in the wheel (code and ``morpi_filters/data``) are reachable
there, so a parameter file or route catalogue read from outside the package
fails this test.
"""
from __future__ import annotations

import json
import os
import shutil
import site
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

pytestmark = pytest.mark.slow


def _run(argv, cwd, env=None):
    out = subprocess.run(argv, cwd=cwd, env=env, capture_output=True, text=True)
    assert out.returncode == 0, f"{argv} failed ({out.returncode}):\n{out.stdout}\n{out.stderr}"
    return out


def _suite_site_dirs() -> list:
    """The site folders the running interpreter imports its packages from."""
    dirs = list(site.getsitepackages())
    if site.ENABLE_USER_SITE:
        dirs.append(site.getusersitepackages())
    return [d for d in dict.fromkeys(dirs) if Path(d).is_dir()]


def _contains_values(tree, value) -> bool:
    if isinstance(tree, dict):
        return any(_contains_values(v, value) for v in tree.values())
    if isinstance(tree, list):
        return any(_contains_values(v, value) for v in tree)
    return tree == value


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    import wheel  # noqa: F401  (the test extra installs it: building offline needs it)
    base = tmp_path_factory.mktemp("wheel")
    src = base / "src"
    src.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, src / name)
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    shutil.copytree(ROOT / "morpi_filters", src / "morpi_filters", ignore=ignore)
    shutil.copytree(ROOT / "data", src / "data", ignore=ignore)
    dist = base / "dist"
    _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "--no-index",
          "-q", "-w", str(dist), str(src)], cwd=base)
    wheels = list(dist.glob("morpi_filters-*.whl"))
    assert len(wheels) == 1, wheels
    venv = base / "venv"
    _run([sys.executable, "-m", "venv", str(venv)], cwd=base)
    py = venv / "bin" / "python"
    # The suite's own site folders, after the venv's: their .pth files are not
    # run, so an editable install of the source tree there stays out of sight.
    purelib = _run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                   cwd=base).stdout.strip()
    (Path(purelib) / "suite_site.pth").write_text("".join(d + "\n" for d in _suite_site_dirs()))
    _run([str(py), "-m", "pip", "install", "--no-deps", "--no-index", "-q", "--force-reinstall",
          str(wheels[0])], cwd=base)
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "MORPI_DATA")}
    env["MPLBACKEND"] = "Agg"
    work = base / "work"
    work.mkdir()
    return venv, env, work


def test_installed_package_is_the_wheel(installed):
    venv, env, work = installed
    out = _run([str(venv / "bin" / "python"), "-c",
                "import morpi_filters, morpi_filters.resources as r; "
                "print(morpi_filters.__file__); print(r.project_data())"], cwd=work, env=env)
    pkg, data = out.stdout.split()
    # The system site packages may hold an editable install of the source tree:
    # the venv's own copy must win, and its data folder must be inside it.
    assert Path(pkg).resolve().is_relative_to(venv.resolve()), pkg
    assert Path(data).resolve() == Path(pkg).resolve().parent / "data"


def test_assess_and_tables_from_the_wheel(installed):
    venv, env, work = installed
    morpi = str(venv / "bin" / "morpi")
    _run([morpi, "assess", "--out", str(work / "assess"), "--json", str(work / "assess.json")],
         cwd=work, env=env)
    result = json.loads((work / "assess.json").read_text())
    # The parameter file shipped in the wheel was found and read: its values
    # come back in the result (compared with the source tree's copy).
    shipped = json.loads((ROOT / "data" / "assessment_params.json").read_text())
    assert _contains_values(result, shipped["g_mps2"])
    data = work / "synthetic"
    _run([morpi, "simulate", "--out", str(data), "--runs-per-folder", "2"], cwd=work, env=env)
    _run([morpi, "tables", "--data", str(data), "--out", str(work / "tables"),
          "--json", str(work / "tables.json")], cwd=work, env=env)
    tables = json.loads((work / "tables.json").read_text())
    assert tables
    assert any((work / "tables").glob("*.md"))
