"""Ground truth of the MoRPI routes and the dataset's layout, read from the project's ``data/routes.json``."""
from __future__ import annotations

import json
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..errors import ParameterError
from ..resources import project_data

#: Folder of the small files this project owns (ground truth, checksums).
PROJECT_DATA = project_data()


@dataclass(frozen=True)
class Route:
    """Ground truth of one route of the dataset.

    Attributes
    ----------
    name : str
        Route folder name (``"short_distance"``, ``"L_line"``, ...).
    kind : str
        ``"straight"`` or ``"periodic"``.
    environment : str
        ``"indoor"`` or ``"outdoor"``.
    p2p_m : float or None
        Designed peak-to-peak (period) length [m]; None for straight routes.
    amplitude_m : float or None
        Designed lateral amplitude [m].
    distance_m : float
        Travelled distance along the route [m].
    end_point_m : ndarray, shape (2,)
        True end point in the navigation frame [m].
    segments_m : tuple of float
        Lengths of the straight legs [m].
    turn_deg : float
        Heading change between legs [deg], positive to the left.
    slope_deg, slope_length_m : float
        Downhill slope at the start of the first leg (0 where none).
    """

    name: str
    kind: str
    environment: str
    p2p_m: float | None
    amplitude_m: float | None
    distance_m: float
    end_point_m: np.ndarray
    segments_m: tuple
    turn_deg: float
    slope_deg: float = 0.0
    slope_length_m: float = 0.0

    @property
    def polyline(self) -> np.ndarray:
        """The route's centre line: the corners of its straight legs, from the origin [m], shape (legs + 1, 2).

        Examples
        --------
        >>> route("L_shape").polyline.tolist()
        [[0.0, 0.0], [18.0, 0.0], [18.0, -10.0]]
        """
        pts = [np.zeros(2)]
        heading = 0.0
        for i, length in enumerate(self.segments_m):
            if i > 0:
                heading += np.radians(self.turn_deg)
            pts.append(pts[-1] + length * np.array([np.cos(heading), np.sin(heading)]))
        return np.array(pts)


@lru_cache(maxsize=None)
def _routes_file() -> dict:
    with open(PROJECT_DATA / "routes.json") as fh:
        return json.load(fh)


@lru_cache(maxsize=1)
def _route_table() -> dict:
    """The routes of ``data/routes.json``, read once per process (end points read-only: shared)."""
    out = {}
    for name, r in _routes_file()["routes"].items():
        end = np.asarray(r["end_point_m"], dtype=float)
        end.flags.writeable = False
        out[name] = Route(name=name, kind=r["kind"], environment=r["environment"], p2p_m=r["p2p_m"],
                          amplitude_m=r["amplitude_m"], distance_m=r["distance_m"], end_point_m=end,
                          segments_m=tuple(r["segments_m"]), turn_deg=r["turn_deg"],
                          slope_deg=r.get("slope_deg", 0.0), slope_length_m=r.get("slope_length_m", 0.0))
    return out


def routes() -> dict[str, Route]:
    """Ground truth of every route, by route folder name.

    Read from the project's ``data/routes.json``.

    Returns
    -------
    dict of str -> Route
        One :class:`Route` per route folder name of the dataset.

    Examples
    --------
    >>> r = routes()
    >>> len(r), r["long_distance"].distance_m
    (6, 13.0)
    """
    return dict(_route_table())


def route(name: str) -> Route:
    """Ground truth of one route (see :func:`routes`).

    Parameters
    ----------
    name : str
        Route folder name, a key of :func:`routes`.

    Returns
    -------
    Route
        The route's kind, environment, distances, end point and legs.

    Raises
    ------
    ParameterError
        For an unknown route name.

    Examples
    --------
    >>> r = route("short_distance")
    >>> r.kind, r.distance_m, r.p2p_m, r.end_point_m.tolist()
    ('periodic', 6.3, 1.0, [6.3, 0.0])
    """
    r = routes()
    if name not in r:
        raise ParameterError(f"route {name!r}: unknown, expected one of {sorted(r)}")
    return r[name]


def layout() -> dict[str, int]:
    """Expected folders of the MoRPI dataset and their number of runs.

    Returns
    -------
    dict of str -> int
        Folder (``phone/route[/split]``) to
        the number of recordings it holds in the public dataset.

    Examples
    --------
    >>> folders = layout()
    >>> folders["s8/short_distance/test"], sum(folders.values())
    (11, 143)
    """
    return {k: v["runs"] for k, v in _routes_file()["layout"].items()}

