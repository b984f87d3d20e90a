"""Weinberg gains trained on the train runs only: per folder (:func:`trained_gain`) or per train set
(:func:`set_gain`)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import steps as st
from ..errors import MorpiError
from .data import FieldData
from .entries import TrainSet


@dataclass(frozen=True)
class Gain:
    """A trained Weinberg gain.

    Attributes
    ----------
    phone, route, method, calibration : str
    mean, std : float
        Over the training runs [m / unit^(1/4)] (unit: m/s^2 for MoRPI-A, rad/s for MoRPI-G).
    per_run : tuple of float
    files : tuple of str
    skipped : tuple of str
        One line per training file left out (unreadable, or no periodic motion).
    """

    phone: str
    route: str
    method: str
    calibration: str
    mean: float
    std: float
    per_run: tuple
    files: tuple
    skipped: tuple = ()


def trained_gain(data: FieldData, phone, route, calibration, method, config) -> Gain | None:
    """The Weinberg gain of one route, phone, calibration and method, from its train recordings only.

    Parameters
    ----------
    data : FieldData
        The dataset root the train recordings are read from.
    phone, route : str
        Dataset folder names (``"s8"``, ``"short_distance"``).
    calibration : {"RD", "GC", "GAC"}
        Calibration applied to the recordings before step extraction.
    method : {"MoRPI-A", "MoRPI-G"}
        Signal the steps are found on.
    config : steps.StepConfig
        The step rule (for example ``select_config(data).config``).

    Returns
    -------
    Gain or None
        None when the folder has no train recordings or none with periodic motion;
        the recordings left out are named in :attr:`Gain.skipped`.
    """
    if not data.recordings(phone, route, "train"):
        return None
    group = data.entries(phone, route, "train")[0].group
    tset = next((s for s in data.train_sets() if s.name == group), None)
    if tset is None:
        return None
    return set_gain(data, tset, calibration, method, config, phone=phone, route=route,
                    skipped=data.load_errors(phone, route, "train"))


def set_gain(data: FieldData, train_set: TrainSet, calibration, method, config, *, phone: str = "", route: str = "",
             skipped=()) -> Gain | None:
    """The Weinberg gain of a train set's runs (:func:`morpi_filters.steps.train_gain`), each with its distance.

    Parameters
    ----------
    data : FieldData
        The dataset the runs are read from.
    train_set : TrainSet
        The runs and their true distances (:meth:`FieldData.train_sets`).
    calibration, method, config
        As for :func:`trained_gain`.
    phone, route : str
        The labels of the :class:`Gain`.
    skipped : iterable of str
        Lines naming runs left out before (they open :attr:`Gain.skipped`).

    Returns
    -------
    Gain or None
        None when no run has periodic motion under `config`; the runs left
        out are named in :attr:`Gain.skipped`.
    """
    weights, dists, files, skipped = [], [], [], list(skipped)
    for r, d in zip(train_set.runs, train_set.distance_m):
        try:
            weights.append(data.step_sums(r, calibration, method, config)[0])
            dists.append(d)
            files.append(data.relpath(r))
        except MorpiError as exc:
            skipped.append(str(exc))
    if not weights:
        return None
    mean, std, per = st.train_gain(weights, np.array(dists, dtype=float))
    return Gain(phone, route, method, calibration, mean, std, tuple(float(g) for g in per), tuple(files),
                tuple(skipped))
