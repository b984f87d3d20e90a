"""Renamed names keep working for one release: old keywords and attributes warn, old JSON keys ride along."""
from __future__ import annotations

import warnings

import pytest

from morpi_filters.deprecation import renamed_attribute, renamed_keywords, with_aliases
from morpi_filters.errors import ParameterError


def _old_keyword(func, old, new, *args, **kwargs):
    """func(*args, old=value) and func(*args, new=value): (old result, new result, the warnings of the old call)."""
    value = kwargs.pop("value")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        got_old = func(*args, **kwargs, **{old: value})
    got_new = func(*args, **kwargs, **{new: value})
    deprecations = [w for w in caught if issubclass(w.category, DeprecationWarning)]
    return got_old, got_new, deprecations


def test_an_old_keyword_is_passed_on_under_its_new_name_with_a_warning():
    @renamed_keywords(speed="speed_mps")
    def travel(seconds, *, speed_mps=1.0):
        return seconds * speed_mps

    old, new, caught = _old_keyword(travel, "speed", "speed_mps", 2.0, value=3.0)
    assert old == new == 6.0
    assert len(caught) == 1 and "speed_mps=" in str(caught[0].message) and "travel" in str(caught[0].message)
    assert caught[0].filename == __file__            # the warning points at the caller
    with pytest.raises(ParameterError, match="both speed= and speed_mps="):
        travel(1.0, speed=1.0, speed_mps=2.0)


def test_an_old_attribute_reads_the_new_one_with_a_warning():
    class Walk:
        speed_mps = 1.5
        speed = renamed_attribute("Walk", "speed", "speed_mps")

    with pytest.warns(DeprecationWarning, match="Walk.speed_mps"):
        assert Walk().speed == 1.5


def test_an_old_json_key_follows_its_new_key_with_the_same_value():
    out = with_aliases({"a": 1, "speed_mps": [0.5], "b": 2}, {"speed_m_s": "speed_mps", "gone": "absent"})
    assert list(out) == ["a", "speed_mps", "speed_m_s", "b"]
    assert out["speed_m_s"] is out["speed_mps"]
