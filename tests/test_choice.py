"""Tests of morpi_filters.choice: the tie-tolerant choice by a least score, and the choices made with it."""
from __future__ import annotations

import itertools

import numpy as np
import pytest

from morpi_filters import field as fd
from morpi_filters.field import rules as fdr, thresholds as fdt
from morpi_filters.choice import TIE_REL, choose, tie_margin


def test_within_the_tolerance_the_earlier_wins_beyond_it_the_better():
    for least in (3.7, 1e-6, 2e5, -4.0):
        band = tie_margin(least)
        assert band == TIE_REL * abs(least) + tie_margin(0.0)
        inside = least + 0.5 * band
        outside = least - 2.0 * band                      # better than the first by twice the band
        assert choose([inside, least, 9.0 * abs(least) + 1]) == 0
        assert choose([least + 9 * band, inside, least]) == 1
        assert choose([inside, outside]) == 1
        assert choose([least, least]) == 0
    assert choose([2.0, 1.0, 1.0], tol_rel=0.0) == 1 == int(np.argmin([2.0, 1.0, 1.0]))
    assert choose([1.0 + 1e-12, 1.0], tol_rel=0.0, tol_abs=0.0) == 1
    assert choose([1.0 + 1e-12, 1.0]) == 0


def test_nan_is_never_chosen_and_infinite_scores_only_without_a_finite_one():
    assert choose([np.nan, 2.0, 1.0]) == 2
    assert choose([np.inf, np.inf, 4.0]) == 2
    assert choose([np.inf, np.inf]) == 0
    assert choose([np.nan, np.nan]) == 0
    assert choose([3.0, -np.inf, -np.inf]) == 1
    for bad in ([], [[1.0, 2.0]]):
        with pytest.raises(ValueError, match="one-dimensional"):
            choose(bad)
    with pytest.raises(ValueError, match="tolerances"):
        choose([1.0], tol_rel=-1.0)


def test_a_choice_does_not_flip_under_rounding_noise_of_its_scores():
    # two candidates equal in exact arithmetic, each score perturbed by 1e-12 relative (far above the
    # rounding of a sum, far below the tie tolerance): the earlier is kept in every draw; an argmin would
    # follow the noise
    rng = np.random.default_rng(7)
    base = np.array([5.2, 3.1, 4.0, 3.1, 6.0])
    picks = set()
    for _ in range(200):
        noisy = base * (1.0 + 1e-12 * rng.standard_normal(base.size))
        picks.add(choose(noisy))
    assert picks == {1}


def test_the_rule_search_keeps_the_earlier_of_two_rules_tied_within_rounding(monkeypatch):
    # the search's own scores replaced by a table in which two reading combinations tie in exact arithmetic;
    # 1e-12 relative noise on every score must not move the chosen rule
    rng = np.random.default_rng(11)
    start = fdt.SEARCH_START.with_(heading_source="gyro")
    keys = list(fd.READING_GRID)
    combos = [start.with_(**dict(zip(keys, c))) for c in itertools.product(*(fd.READING_GRID[k] for k in keys))]
    assert len(combos) >= 4
    tied = (combos[1], combos[3])                              # the earlier of the two is combos[1]

    def exact(cfg):
        reading = cfg.with_(**{k: getattr(start, k) for k in fd.TUNABLE_GRID})
        if reading in tied:
            return 2.5 + 0.1 * (cfg != reading)             # a tunable off the start scores worse
        return 4.0 + 1e-3 * len(repr(cfg))                # the others worse, not tied

    chosen = set()
    for _ in range(60):
        noise = {}

        def score(data, method, cfg, mode="GC", exclude=frozenset(), held_out="recording"):
            if cfg not in noise:
                noise[cfg] = 1.0 + 1e-12 * rng.standard_normal()
            return exact(cfg) * noise[cfg], 10

        monkeypatch.setattr(fdr, "held_out_score", score)
        best, best_score, n, trials = fdr._search(None, ("MoRPI-A",), frozenset(), start)
        assert n == 10 and abs(best_score - 2.5) < 1e-9
        chosen.add(best)
    assert chosen == {tied[0]}
