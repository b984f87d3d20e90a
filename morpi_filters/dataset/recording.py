"""The :class:`Recording`: one IMU recording in SI units and phone axes, its values and times checked."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import DataError, ParameterError
from ..units import SensorSpec
from .truth import Route, route


@dataclass(frozen=True, eq=False)
class Recording:
    """One IMU recording in SI units and phone axes.

    Attributes
    ----------
    time : ndarray, shape (n,)
        Sample times [s], strictly increasing, not uniformly spaced.
    f : ndarray, shape (n, 3)
        Specific force in the body frame [m/s^2].
    omega : ndarray, shape (n, 3)
        Angular rate in the body frame [rad/s].
    source : str
        The file it came from (or a label for synthetic data).
    phone : str or None
        ``"s6"`` or ``"s8"``.
    route : str or None
        Route folder name, key of :func:`routes`.
    split : str or None
        ``"train"``, ``"test"`` or None for folders without a split.
    imu : SensorSpec or None
        The error figures of the IMU that recorded it, when the dataset names
        them (the MoRPI catalogue: the phone's IMU; a manifest: ``imu.spec``;
        a simulation: its spec). What reads a recording's noise floor (rest
        detection) reads it here, never from the phone's name.
    label : str or None
        The recording's name within its dataset, when the dataset gives it
        one (a manifest: the recording's id); otherwise :attr:`name` is made
        from the labels above.

    Raises
    ------
    ParameterError
        Arrays of the wrong shapes.
    DataError
        A value that is not finite, or times that do not strictly increase (naming the sample).

    Examples
    --------
    >>> t = 10.0 + np.arange(201) * 0.01
    >>> rec = Recording(time=t, f=np.tile([0.0, 0.0, 9.8], (201, 1)), omega=np.zeros((201, 3)),
    ...                 source="/data/s8/L_shape/test/3.csv", phone="s8", route="L_shape", split="test")
    >>> rec.n, round(rec.duration, 9), round(rec.rate_hz, 6), rec.name
    (201, 2.0, 100.0, 's8/L_shape/test/3.csv')
    """

    time: np.ndarray
    f: np.ndarray
    omega: np.ndarray
    source: str = "<memory>"
    phone: str | None = None
    route: str | None = None
    split: str | None = None
    imu: SensorSpec | None = None
    label: str | None = None

    def __post_init__(self):
        n = self.time.shape[0]
        if self.time.ndim != 1 or self.f.shape != (n, 3) or self.omega.shape != (n, 3):
            raise ParameterError(
                f"{self.source}: expected time (n,), f (n, 3), omega (n, 3); got "
                f"{self.time.shape}, {self.f.shape}, {self.omega.shape}")
        for label, values in (("time", self.time), ("f", self.f), ("omega", self.omega)):
            bad = ~np.isfinite(values)
            if bad.any():
                i = int(np.flatnonzero(bad.reshape(n, -1).any(axis=1))[0])
                raise DataError(f"{self.source}: {label} of sample {i} is {values[i].tolist()}, expected finite numbers")
        if n > 1:
            step = np.diff(self.time)
            if not (step > 0).all():
                i = int(np.flatnonzero(~(step > 0))[0]) + 1
                raise DataError(f"{self.source}: time of sample {i} ({float(self.time[i])!r}) is not after the one before "
                                f"({float(self.time[i - 1])!r}), expected strictly increasing times")

    @property
    def n(self) -> int:
        """Number of samples."""
        return int(self.time.shape[0])

    @property
    def dt(self) -> np.ndarray:
        """Sample intervals, shape (n - 1,) [s]."""
        return np.diff(self.time)

    @property
    def duration(self) -> float:
        """Time from first to last sample [s]."""
        return float(self.time[-1] - self.time[0])

    @property
    def rate_hz(self) -> float:
        """Median sampling rate [Hz]."""
        return float(1.0 / np.median(np.diff(self.time)))

    @property
    def ground_truth(self) -> Route | None:
        """Deprecated: the route catalogue's truth of :attr:`route`. A recording's truth is its dataset's
        (:attr:`morpi_filters.manifest.DatasetRecording.truth`); kept for one release."""
        import warnings

        warnings.warn("Recording.ground_truth is deprecated; use the dataset's truth (DatasetRecording.truth) "
                      "or dataset.route(name)", DeprecationWarning, stacklevel=2)
        return route(self.route) if self.route is not None else None

    @property
    def name(self) -> str:
        """Short label: :attr:`label` when given, else ``phone/route/split/file`` (the source without labels)."""
        if self.label:
            return self.label
        parts = [p for p in (self.phone, self.route, self.split) if p]
        return "/".join(parts + [Path(self.source).name]) if parts else self.source
