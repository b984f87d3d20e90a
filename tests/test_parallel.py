"""Tests of morpi_filters.parallel's progress line: the time left, from the rate of the finished runs."""
from __future__ import annotations

import contextlib
import io
import re

import pytest

from morpi_filters.parallel import Progress, format_duration


class FakeClock:
    """A clock that reads what the test sets."""

    def __init__(self):
        self.now = 100.0

    def __call__(self):
        return self.now


def test_the_time_left_comes_from_the_rate_of_the_finished_runs(capsys):
    clock = FakeClock()
    p = Progress(1000, "study", enabled=True, clock=clock)
    clock.now += 36.0                       # 100 runs in 36 s: 900 more take 324 s
    p.update(100)
    clock.now += 84.0                       # 500 runs in 120 s: 500 more take 120 s
    p.update(400)
    clock.now += 1.5
    p.update(0)                             # no new tenth: no line
    clock.now += 58.5                       # 1000 runs in 180 s
    p.update(500)
    assert capsys.readouterr().err.splitlines() == [
        "study: 100/1000 runs (10 %), about 5 min left",
        "study: 500/1000 runs (50 %), about 2 min left",
        "study: 1000/1000 runs (100 %) in 180.0 s"]


def test_a_slow_start_gives_a_long_estimate_in_hours():
    clock = FakeClock()
    err = io.StringIO()
    p = Progress(10**6, "study", enabled=True, clock=clock)
    clock.now += 3600.0                     # 100000 runs an hour: 900000 more take 9 h
    with contextlib.redirect_stderr(err):
        p.update(10**5)
    assert err.getvalue() == "study: 100000/1000000 runs (10 %), about 9 h left\n"


class Terminal(io.StringIO):
    def isatty(self):
        return True


def test_on_a_terminal_the_line_is_rewritten_and_padded(monkeypatch):
    term = Terminal()
    monkeypatch.setattr("sys.stderr", term)
    clock = FakeClock()
    p = Progress(4, "s", enabled=True, clock=clock)
    for _ in range(4):
        clock.now += 120.0
        p.update(1)
    lines = term.getvalue().split("\r")[1:]
    assert [ln.rstrip() for ln in lines] == ["s: 1/4 runs (25 %), about 6 min left",
                                             "s: 2/4 runs (50 %), about 4 min left",
                                             "s: 3/4 runs (75 %), about 2 min left",
                                             "s: 4/4 runs (100 %) in 480.0 s"]
    # every rewrite covers the longest line before it; only the last one ends the line
    assert all(len(ln.rstrip("\n")) >= len(lines[0]) for ln in lines)
    assert term.getvalue().endswith("\n") and term.getvalue().count("\n") == 1


@pytest.mark.parametrize("seconds, text", [(0.4, "0 s"), (119.0, "119 s"), (120.0, "2 min"), (7199.0, "120 min"),
                                           (7200.0, "2 h"), (36 * 3600.0, "36 h"), (9 * 86400.0, "216 h (9.0 days)")])
def test_durations_read_in_their_unit(seconds, text):
    assert format_duration(seconds) == text


def test_a_small_study_shows_the_time_left_in_its_progress_lines(capsys):
    from morpi_filters.montecarlo import StudyConfig, run_study

    run_study(12, 0, StudyConfig(training_runs=20), chunk=3, progress=True)
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 4
    pattern = re.compile(r"montecarlo gain-error study: (\d+)/12 runs \((\d+) %\)"
                         r"(, about \d+ (s|min|h) left| in \d+\.\d s)")
    for i, line in enumerate(lines):
        m = pattern.fullmatch(line)
        assert m and int(m[1]) == 3 * (i + 1), line
        assert (m[3].startswith(" in") if i == 3 else m[3].endswith("left")), line
