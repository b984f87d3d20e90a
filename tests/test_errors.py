"""The error kinds: every raise names its cause, and each kind exits with the status errors.py documents."""
from __future__ import annotations

import ast
import inspect
import re
from pathlib import Path

import numpy as np
import pytest

from morpi_filters import cli, errors
from morpi_filters.errors import DataError, MissingDataError, MorpiError, OutputError, ParameterError

PKG = Path(__file__).resolve().parents[1] / "morpi_filters"
KINDS = [getattr(errors, name) for name in errors.__all__]


def _plain_morpi_errors(source: str) -> list[int]:
    """Lines that build a plain MorpiError (``raise MorpiError(...)`` or ``MorpiError(...)`` kept to raise later)."""
    return sorted(node.lineno for node in ast.walk(ast.parse(source))
                  if isinstance(node, ast.Call) and isinstance(node.func, (ast.Name, ast.Attribute))
                  and (node.func.id if isinstance(node.func, ast.Name) else node.func.attr) == "MorpiError")


def test_the_scan_sees_a_plain_morpi_error():
    code = "def f(x):\n    if x:\n        raise MorpiError('x')\n    return errors.MorpiError('y')\n"
    assert _plain_morpi_errors(code) == [3, 4]
    assert _plain_morpi_errors("raise ParameterError('x')\n") == []


def test_no_module_raises_a_plain_morpi_error():
    found = [f"{path.relative_to(PKG.parent)}:{line}" for path in sorted(PKG.rglob("*.py"))
             for line in _plain_morpi_errors(path.read_text())]
    assert found == [], "a plain MorpiError names no cause; raise one of its kinds: " + ", ".join(found)


def _documented_codes() -> dict[str, int]:
    """Class name -> exit status as the module docstring of errors.py states it."""
    text = " ".join(errors.__doc__.split())
    listing = text.split("Exit codes of ``morpi``:", 1)[1]
    out = {}
    for code, names in re.findall(r"(\d+) [a-z ]+\(([^)]*)\)", listing):
        for name in re.findall(r":class:`(\w+)`", names):
            out[name] = int(code)
    return out


def test_every_kind_is_listed_with_its_exit_status():
    documented = _documented_codes()
    assert set(documented) == {k.__name__ for k in KINDS if k is not MorpiError}
    for kind in KINDS:
        if kind is MorpiError:
            continue
        assert issubclass(kind, MorpiError)
        assert kind.exit_code == documented[kind.__name__], kind
        said = re.findall(r"exit status (\d)", " ".join(inspect.getdoc(kind).split()))
        assert said and int(said[0]) == kind.exit_code, kind


def test_the_kinds_of_a_bad_parameter_are_parameter_errors():
    for kind in (MissingDataError, OutputError, errors.FetchError):
        assert issubclass(kind, ParameterError) and not issubclass(kind, DataError)


@pytest.mark.parametrize("kind", KINDS, ids=lambda k: k.__name__)
def test_the_command_line_exits_with_each_kinds_status(kind, tmp_path, monkeypatch, capsys):
    def fail(args):
        raise kind("the cause, on one line")

    monkeypatch.setattr(cli, "_dispatch", fail)
    expected = _documented_codes().get(kind.__name__, 2)
    assert cli.main(["check", "--data", str(tmp_path)]) == expected
    assert capsys.readouterr().err == "morpi: error: the cause, on one line\n"


def test_each_cause_raises_its_kind(tmp_path):
    from morpi_filters import steps
    from morpi_filters.dataset import resolve_data_root
    from morpi_filters.outputs import check_output_dir

    with pytest.raises(MissingDataError, match="not a directory"):
        resolve_data_root(tmp_path / "nowhere")
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "thesis.tex").write_text("mine")
    with pytest.raises(OutputError, match="thesis.tex"):
        check_output_dir(tmp_path / "mine")
    assert (tmp_path / "mine" / "thesis.tex").read_text() == "mine"
    with pytest.raises(DataError, match="no periodic motion"):
        steps.require_swing("run.csv", "MoRPI-G", 6.0, 15.0)
    with pytest.raises(ParameterError, match="time") as ei:
        from morpi_filters.strapdown import ins2d
        ins2d(np.array([0.0, 0.0]), np.zeros((2, 3)), np.zeros((2, 3)))
    assert type(ei.value) is ParameterError
