"""The API reference builds from the docstrings with every Sphinx warning an error."""
from __future__ import annotations

import ast
import html
import importlib
import inspect
import pkgutil
import re
import subprocess
import sys
from pathlib import Path

import morpi_filters

ROOT = Path(__file__).resolve().parents[1]


def _comments_above_assignments(path: Path) -> dict:
    """name -> text of the ``#:`` lines right above its top-level assignment in a source file."""
    text = path.read_text()
    lines = text.splitlines()
    found = {}
    for node in ast.parse(text).body:
        if not isinstance(node, (ast.Assign, ast.AnnAssign)):
            continue
        above = []
        row = node.lineno - 2
        while row >= 0 and lines[row].lstrip().startswith("#:"):
            above.insert(0, lines[row].lstrip()[2:].strip())
            row -= 1
        targets = node.targets if isinstance(node, ast.Assign) else [node.target]
        # ``A, B = 1, 2`` under one comment documents both names with it
        for target in targets:
            for name in (target.elts if isinstance(target, (ast.Tuple, ast.List)) else [target]):
                if above and isinstance(name, ast.Name):
                    found[name.id] = " ".join(above)
    return found


def reexported_constant_comments() -> dict:
    """``package.NAME`` -> ``#:`` text of every constant a package re-exports (its ``__all__``) from the
    submodule where the comment stands."""
    expected = {}
    packages = [morpi_filters] + [importlib.import_module(i.name) for i in
                                  pkgutil.walk_packages(morpi_filters.__path__, "morpi_filters.") if i.ispkg]
    for package in packages:
        submodules = [importlib.import_module(i.name) for i in
                      pkgutil.walk_packages(package.__path__, package.__name__ + ".")]
        comments = [(module, _comments_above_assignments(Path(module.__file__))) for module in submodules]
        for name in getattr(package, "__all__", ()):
            value = getattr(package, name)
            if inspect.ismodule(value) or inspect.isclass(value) or inspect.isroutine(value):
                continue
            for module, texts in comments:
                if name in texts and getattr(module, name, None) is value:
                    expected[f"{package.__name__}.{name}"] = texts[name]
    return expected


def _words(text: str) -> list:
    """The words a reader sees: a role shows its title or its target (the last part after ``~``)."""
    def shown(m):
        target = m.group(1)
        if "<" in target:
            return target.split("<")[0]
        return target.rsplit(".", 1)[-1] if target.startswith("~") else target
    return re.findall(r"\w+", re.sub(r"(?::\w+)+:`([^`]+)`", shown, text))


def _contains(words: list, part: list) -> bool:
    return any(words[i:i + len(part)] == part for i in range(len(words) - len(part) + 1))


def _missing_constants(page: str, expected: dict) -> list:
    """The constants of ``expected`` (name -> comment) the built API page lacks, or shows without their comment."""
    missing = []
    for full, text in sorted(expected.items()):
        m = re.search(r'<dt [^>]*id="%s">.*?</dt>\s*<dd>(.*?)</dd>' % re.escape(full), page, re.S)
        shown = _words(html.unescape(re.sub(r"<[^>]+>", " ", m.group(1)))) if m else []
        if not _contains(shown, _words(text)):
            missing.append(full if m else f"{full} (no entry)")
    return missing


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
    # a package documents, under its own name, every constant it re-exports with the #: comment of its submodule
    expected = reexported_constant_comments()
    assert "morpi_filters.steps.GRID_HZ" in expected
    missing = _missing_constants(page, expected)
    assert not missing, f"{len(missing)} re-exported constants undocumented: {missing}"
