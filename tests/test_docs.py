"""The API reference builds from the docstrings with every Sphinx warning an error."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_api_reference_builds_without_warnings(tmp_path):
    r = subprocess.run([sys.executable, "-m", "sphinx", "-E", "-W", "--keep-going", "-q", "-b", "html",
                        str(ROOT / "docs"), str(tmp_path / "html")], capture_output=True, text=True)
    assert r.returncode == 0, (r.stdout + r.stderr)[-3000:]
    page = (tmp_path / "html" / "api.html").read_text()
    # the reference holds every public module, the aided filter among them
    assert "morpi_filters.aided" in page and "StepDisplacement" in page
    # the foreign-layout tutorial is a page of its own, in the table of contents, and the tables are referenced
    tutorial = (tmp_path / "html" / "tutorial_dataset.html").read_text()
    assert 'href="tutorial_dataset.html"' in (tmp_path / "html" / "index.html").read_text()
    assert 'href="api.html#morpi_filters.dataset_eval.evaluate"' in tutorial and "format_version = 1" in tutorial
    assert "morpi_filters.dataset_eval.DatasetEvaluation.table" in page
