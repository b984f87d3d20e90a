"""A manifest's recordings as :class:`~morpi_filters.field.FieldData` lists them: their folders and loaders, a
rest window given in the manifest, a truth track's course, and the train sets they form."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import DataError


#: Horizontal distance over which a truth track's course gives the heading of a start at rest [m]
#: (:func:`track_course`; :data:`morpi_filters.dataset_eval.COURSE_M` aligns the estimates alike).
COURSE_M = 0.3


@dataclass(frozen=True, eq=False)
class TrainSet:
    """One train set of the rule search: runs that share a gain, each with its own truth.

    The train recordings with periodic motion of one group of the dataset's
    manifest (for the MoRPI dataset, a short-route folder such as
    ``s8/short_distance``, whose runs share the route's end point and distance).

    Attributes
    ----------
    name : str
        ``"<phone>/<route>"`` or the group.
    files : tuple of str
        The runs (paths relative to the root, or recording ids), in order.
    runs : tuple of Recording
    end_point_m : ndarray, shape (n, 2)
        Each run's true end point in the navigation frame of the MoRPI
        estimate (origin at the motion's start, x along the heading there) [m].
    distance_m : ndarray, shape (n,)
        Each run's true travelled distance [m].
    phone, route : str
        The group split at its first ``/`` (:class:`FieldData`'s folder).
    """

    name: str
    files: tuple
    runs: tuple
    end_point_m: np.ndarray
    distance_m: np.ndarray
    phone: str = ""
    route: str = ""


@dataclass(frozen=True, eq=False)
class _Entry:
    """A manifest recording as FieldData lists it: its folder ``(phone, route, split)`` (the group split at its
    first ``/``, else the dataset's name and the group; the split None for ``"none"``), its id as its relative
    path, its file, and how to load it (a DatasetRecording)."""

    phone: str
    route: str
    split: str | None
    relpath: str
    path: object
    group: str
    motion: str
    load: object


def folder_of(name: str, group: str, split: str) -> tuple:
    """A recording's folder ``(phone, route, split)`` as FieldData files it.

    Parameters
    ----------
    name : str
        The dataset's name (the phone of a group without ``/``).
    group, split : str
        The recording's manifest group and split.

    Returns
    -------
    tuple of (str, str, str or None)
        The group split at its first ``/`` (else the dataset's name and the group), and the split (None for
        ``"none"``).
    """
    phone, route = group.split("/", 1) if "/" in group else (name, group)
    return phone, route, None if split == "none" else split


def entries_of(dataset) -> list:
    """The entries of a manifest Dataset (in memory) or DatasetIndex (read on demand), in the manifest's order.

    A recording whose file another recording reads too is told apart by its id in its source.

    Parameters
    ----------
    dataset : Dataset or DatasetIndex
        The manifest's recordings (:mod:`morpi_filters.manifest`).

    Returns
    -------
    list
        One entry per recording: its folder, id, file, group, motion and loader.
    """
    from dataclasses import replace

    from ..manifest import Dataset

    items = dataset.recordings
    files = [dr.recording.source if isinstance(dataset, Dataset) else str(dr.file) for dr in items]
    out = []
    for dr, file in zip(items, files):
        if isinstance(dataset, Dataset):
            if files.count(file) > 1:
                dr = replace(dr, recording=replace(dr.recording, source=f"{file}#{dr.id}"))
            load = (lambda dr=dr: dr)
        elif files.count(file) > 1:
            def load(dr=dr, file=file):
                got = dr.load()
                return replace(got, recording=replace(got.recording, source=f"{file}#{dr.id}"))
        else:
            load = dr.load
        out.append(_Entry(*folder_of(dataset.name, dr.group, dr.split), dr.id, Path(file), dr.group, dr.motion, load))
    return out


def given_rest_window(rec, rest):
    """The rest window ``[t0, t1]`` given in seconds from the first sample, as a RestWindow on `rec`."""
    from ..calibration import RestWindow

    t = rec.time - rec.time[0]
    i0 = int(np.searchsorted(t, rest[0]))
    i1 = int(np.searchsorted(t, rest[1], side="right"))
    return RestWindow(float(rec.time[i0]), float(rec.time[i1 - 1]), i0, i1, "given")


def track_course(truth, t: float, *, moving: bool = False, course_m: float = COURSE_M) -> float:
    """The course of a truth track at time `t` [rad], counter-clockwise from the track's x axis.

    ``moving``: the direction of the truth's velocity over one truth interval
    on each side of `t` (after it where the track starts there); otherwise
    the direction from the truth at `t` to its first later position
    `course_m` away horizontally. The same course aligns a method's estimate
    to the track in :mod:`morpi_filters.dataset_eval`.

    Parameters
    ----------
    truth : TruthTrack
        The track (:class:`morpi_filters.manifest.TruthTrack`).
    t : float
        Time on the track's clock [s].
    moving : bool
        The velocity's direction (a start in motion) instead of the first
        `course_m`.
    course_m : float
        Horizontal distance of the course of a start at rest [m].

    Returns
    -------
    float
        The course [rad].

    Examples
    --------
    >>> from morpi_filters.manifest import TruthTrack
    >>> track = TruthTrack(time=np.arange(5.0), position=[[0, 0, 0], [0, 0, 0], [0.1, 0.1, 0], [1, 1, 0], [2, 2, 0]])
    >>> round(float(np.degrees(track_course(track, 1.0))), 6), round(float(np.degrees(track_course(track, 3.0, moving=True))), 6)
    (45.0, 45.0)

    Raises
    ------
    DataError
        The track never moves `course_m` from its position at `t`.
    """
    import math

    if moving:
        h = truth.interval
        a = max(t - h, float(truth.time[0]))
        b = a + 2 * h if a < t - 0.5 * h else t + h
        pa, pb = truth.at([a, b])
        return math.atan2(pb[1] - pa[1], pb[0] - pa[0])
    p0 = truth.at([t])[0, :2]
    later = truth.time > t
    away = np.hypot(*(truth.position[later, :2] - p0).T) >= course_m
    if not away.any():
        raise DataError(f"{truth.source}: the truth track never moves {course_m:g} m from its position at "
                        f"{t:.6g} s")
    q = truth.position[later][int(np.argmax(away)), :2]
    return math.atan2(q[1] - p0[1], q[0] - p0[0])
