"""Batched, seeded Monte Carlo studies: gain error and closed-form drift.

Two studies live here.

Gain-error study (:func:`run_study`, :func:`gain_error_page`)
    For each of N runs: draw the IMU's turn-on biases and white noise from a
    :class:`~morpi_filters.units.SensorSpec` and one standard-normal number
    for the Weinberg gain error, then navigate one sine path (its duration,
    length or speed set by :class:`StudyConfig`) with INS-3D, INS-2D, MoRPI-A
    (Weinberg on ``f_y``) and MoRPI-G (Weinberg on ``omega_z``; MoRPI heading
    from the integrated gyro z), and record the horizontal position error over
    time. (``StudyConfig(ins_path="straight")`` puts the INS on the paper's
    straight baseline of the same length and speed instead.) The reference
    gains are trained on noisy runs of the same path and sensor (so the sensor
    noise's inflation of ``max - min`` is part of the gain, as in practice);
    each gain scenario multiplies them by ``1 + dG`` with
    ``dG = mean + std * z``. All scenarios share the run's draws (common
    random numbers). Results are labelled by the package's method names
    (:data:`METHODS`) and the scenarios' labels: :meth:`StudyResult.final_error`,
    :meth:`StudyResult.distance_error_of`, :meth:`StudyResult.curve`, and
    :func:`distance_law_check` tests the MoRPI distance law ``ds = dG D``.

Drift study (:func:`drift_map`, :func:`drift_page`)
    The same kind of bias draws through the nonlinear strapdown on a
    stationary trajectory and through the small-angle closed form, for 3D and
    2D INS, on a grid of gyro bias levels and times.

Reproducibility
    Run ``i`` of a study with seed ``s`` draws everything from its own
    Generator seeded with ``SeedSequence(s).spawn(N)[i]`` (built directly as
    ``SeedSequence(s, spawn_key=(i,))``, which is the same object), in a
    fixed order: 6 bias numbers (accelerometer xyz, gyro xyz), 1 gain number,
    then the ``(6, n)`` noise block (accelerometer xyz, gyro xyz; each
    channel's n samples consecutive). The noisy training runs behind the
    reference gains draw from the study seed's child
    ``SeedSequence(s, spawn_key=(TRAINING_KEY,))`` (:data:`TRAINING_KEY`,
    an index no run reaches: a study has fewer runs), so a study's training
    set changes with its seed and a seeded study fixes every number. Every
    computation is elementwise over runs, so a run's numbers do not depend on
    which chunk, thread or Dask worker computed it: the digest is the same for
    any chunk size, any number of workers and through Dask.

One pass, flat memory
    :func:`run_studies` runs several studies that share the draws and the
    paths (other calibrations, gain scenarios, training-set sizes) over one
    pass of the random numbers: each run's numbers are drawn once, each
    calibration's measurement errors are built once, and every study is a set
    of columns of the same draws, equal bit for bit to the study run alone.
    Chunks are reduced as they finish: the per-run final, gain and distance
    errors are kept (they are what the digest, the order statistics and the
    distance check need), the error series only as a sum of squares (RMS) and
    histogram counts per epoch (the 5/50/95 % bands), unless a caller asks
    for them (``series=True``); a study whose curves nobody reads (the
    gain-training studies, the page's raw-bias study) skips even those
    (``curves``). Dask workers return those reductions. The kernel's large
    planes are scratch arrays of the thread, reused from chunk to chunk, and
    a Dask worker process keeps its freed temporaries for the next chunk
    (:func:`_keep_freed_memory`; the caller's own process is left as it is).

Digest
    sha256 over the per-run final horizontal errors rounded to
    :data:`DIGEST_BITS` significant bits (a relative step of 2^-20, about
    1e-6: six significant digits), as a C-ordered little-endian float64
    array of shape ``(runs, columns)`` with the columns of
    :attr:`StudyResult.columns` (INS-3D, INS-2D, then MoRPI-A and MoRPI-G for
    each gain scenario in order). The rounding is exact bit arithmetic
    (``frexp``/``ldexp``), so the same values give the same digest
    everywhere, and it is coarse enough that the last-digit differences of
    another machine's arithmetic leave it unchanged: moving every sample of
    the simulated path by one unit in the last place changes the bits of
    81,258 of the page's 88,000 per-run errors (2000 runs, every study), by
    at most 3e-13 relative (median 4e-15); the expected number of them that
    cross a rounding boundary (the sum of each change over its step) is
    3e-4, and the page's nine digests stay as they are. A gain
    scenario set from the field recordings uses their spread and mismatch
    rounded to :data:`FIELD_GAIN_DIGITS` digits, so the field evaluation's own
    machine differences (up to a few 1e-11) do not reach the runs either.

Pieces from other modules
    Trajectories come from :mod:`morpi_filters.simulate` (``sine``,
    ``straight``); the drift study integrates with
    :func:`morpi_filters.strapdown.ins3d` / ``ins2d`` and evaluates
    :func:`morpi_filters.symbolic.closed_form_errors`. The gain-error study
    propagates the INS with a specialised kernel
    (:mod:`morpi_filters._batch_ins`: a quaternion attitude step over runs,
    compiled by numba, and trapezoid integration; the true signals go through
    the same rules once and are subtracted), because the general strapdown,
    which keeps every C_bn matrix, costs about 8 times the drawing of the
    random numbers; the tests check the kernel against strapdown.ins3d / ins2d.

References
----------
- [1] A. Etzion and I. Klein, "MoRPI: Mobile Robot Pure Inertial
  Navigation," IEEE J. Indoor and Seamless Positioning and Navigation, 2023.
- [2] H. Weinberg, "Using the ADXL202 in pedometer and personal navigation
  applications," Analog Devices AN-602, 2002.
- [3] NumPy Enhancement Proposal 19 / SPEC 7: seeding with SeedSequence.spawn.
"""
from __future__ import annotations

import functools
import hashlib
import math
import threading
import time as _time
from dataclasses import dataclass, field, replace

import numpy as np

from . import _batch_ins as bi
from .choice import choose
from .errors import ParameterError
from .parallel import Progress, chunk_ranges, execute
from .reporting import round_significant
from .steps import weinberg_length
from .units import DEG_S, G0, MPU6500, SensorSpec

__all__ = [
    "GainError", "StudyConfig", "CALIBRATIONS", "StudyResult", "METHODS", "run_study", "run_studies", "summarize",
    "digest", "child_seed", "training_seed", "TRAINING_KEY", "DRIFT_SEED", "reference_gains", "training_runs_study",
    "training_configs", "training_summary",
    "TrainingStudy", "band_quantiles", "BAND_PERCENTILES", "BAND_BINS_PER_DECADE",
    "DriftMap", "drift_map", "GainErrorPage", "gain_error_page", "DriftPage", "drift_page", "Z99",
    "final_statistics", "distance_law_check", "INS_PATHS", "PageCost", "page_cost", "study_config_json",
]

#: Error series columns of :attr:`StudyResult.errors` (the package's method names).
METHODS = ("INS-3D", "INS-2D", "MoRPI-A", "MoRPI-G")

#: Bias calibrations a study can assume (see StudyConfig.calibration): the field tables' names.
CALIBRATIONS = ("RD", "GC", "GAC")

#: Paths INS-3D and INS-2D can drive (see StudyConfig.ins_path).
INS_PATHS = ("sine", "straight")

#: Smooth speed ramp at each end of the path [s] (simulate's default).
RAMP_S = 1.0

#: The paper's short route when neither duration nor length is given: 6.3 m in 15 s.
DEFAULT_LENGTH_M = 6.3
DEFAULT_DURATION_S = 15.0

#: Per-run numbers drawn before the noise block: 3 accelerometer biases, 3 gyro biases, 1 gain.
_N_HEAD = 7

#: Spawn key of the noisy training runs that fix the reference Weinberg gains: their draws come
#: from the study seed's child ``SeedSequence(seed, spawn_key=(TRAINING_KEY,))``. Run i of a study
#: uses the key ``(i,)``, and a study has at most ``TRAINING_KEY`` runs, so no run shares it.
TRAINING_KEY = 2**32 - 1

#: Default seed of the drift study (``morpi drift --seed``, :func:`drift_page`, :func:`drift_map`).
DRIFT_SEED = 0

#: Memory budget of one chunk's noise block [bytes]; sets the default chunk size.
_CHUNK_BYTES = 32 * 2**20

#: Resolution of the histograms behind :attr:`StudyResult.bands`: log-spaced bins
#: from :data:`BAND_RANGE_M` [0] to [1] metres (plus one bin from 0 to the first edge).
BAND_BINS_PER_DECADE = 40
BAND_RANGE_M = (1e-6, 1e4)
_BAND_EDGES = np.concatenate([[0.0], np.logspace(math.log10(BAND_RANGE_M[0]), math.log10(BAND_RANGE_M[1]),
                                                 BAND_BINS_PER_DECADE * 10 + 1)])
#: Percentiles of :attr:`StudyResult.bands`.
BAND_PERCENTILES = (5.0, 50.0, 95.0)


# ----------------------------------------------------------------------------- configuration

@dataclass(frozen=True)
class GainError:
    """A Weinberg gain-error scenario: ``dG = mean + std * z``, z ~ N(0, 1) per run.

    Attributes
    ----------
    label : str
        Name shown in reports.
    mean : float
        Mean gain error, a fraction of the true gain (0.05 is 5 %).
    std : float
        Spread of the gain error across runs (fraction), >= 0.
    """

    label: str
    mean: float
    std: float = 0.0

    def errors(self, z) -> np.ndarray:
        """The gain errors ``mean + std * z`` of runs whose standard normal numbers are `z` (fractions).

        Examples
        --------
        >>> GainError("spread", 0.02, 0.05).errors(np.array([0.0, 1.0, -2.0])).round(12).tolist()
        [0.02, 0.07, -0.08]
        """
        return self.mean + self.std * np.asarray(z, dtype=float)


@dataclass(frozen=True)
class StudyConfig:
    """What one gain-error study simulates.

    The robot drives a sine path from rest to rest (1 s smooth ramps at both
    ends, cruise in between), and every method navigates that same path. Its
    motion is fixed by any two of `duration`, `length_m` and `speed_mps`; the
    third follows from ``duration = length_m / speed_mps + RAMP_S``. Left
    unset: the paper's 6.3 m in 15 s; a `duration` or `length_m` alone keeps
    the paper's cruise speed for the period (:func:`morpi_filters.simulate.paper_speed`).
    :meth:`motion` gives the three values; a study's result holds its config
    with all three filled in.

    Attributes
    ----------
    spec : SensorSpec
        IMU error figures (biases 1 sigma per axis, noise densities), for
        example :meth:`~morpi_filters.units.SensorSpec.from_datasheet`.
    duration : float, optional
        Time from the start of the motion to the stop [s]: the run lasts this long.
    length_m : float, optional
        Start-to-end distance of the path along its centreline [m].
    speed_mps : float, optional
        Cruise speed along the centreline [m/s].
    rate_hz : float
        Sampling rate [Hz]; the noise standard deviation is ``density * sqrt(rate_hz)``.
    period_m : float
        Sine-path period (peak-to-peak step) [m].
    amplitude_m : float
        Sine-path lateral amplitude [m].
    ins_path : {"sine", "straight"}
        Path of INS-3D and INS-2D: the same sine path as MoRPI (default), or
        the paper's baseline, a straight line of the same length, speed and duration.
    gains : tuple of GainError
        Gain scenarios; the first is the primary one (the MoRPI series).
    keep_every : int
        Keep every k-th sample of the error series (the final sample is always kept).
    ins : bool
        Whether to run INS-3D and INS-2D (False for MoRPI-only studies).
    training_runs : int
        Noisy training runs that fix the reference gains.
    calibration : {"RD", "GC", "GAC"}
        ``"RD"``: raw data, the datasheet turn-on biases act in full.
        ``"GC"`` (gyro calibration) or ``"GAC"`` (gyro and accelerometer): a
        zero-order calibration on `cal_seconds` of rest leaves a residual bias
        equal to the mean of the white noise over that window,
        ``density / sqrt(cal_seconds)`` per axis (drawn from the same per-run
        bias numbers).
    cal_seconds : float
        Length of the stationary calibration window [s].

    Examples
    --------
    >>> cfg = StudyConfig(duration=20.0, period_m=1.0)
    >>> length, speed, duration = cfg.motion()
    >>> round(length, 3), round(speed, 4), duration
    (8.867, 0.4667, 20.0)
    """

    spec: SensorSpec = MPU6500
    duration: float | None = None
    rate_hz: float = 100.0
    length_m: float | None = None
    period_m: float = 1.0
    amplitude_m: float = 0.1
    gains: tuple = (GainError("dG = 5 %", 0.05), GainError("dG = 10 %", 0.10))
    keep_every: int = 10
    ins: bool = True
    training_runs: int = 4000
    calibration: str = "RD"
    cal_seconds: float = 3.0
    speed_mps: float | None = None
    ins_path: str = "sine"

    def motion(self) -> tuple:
        """(length_m, speed_mps, duration) of the path [m, m/s, s], from the two that fix it.

        Returns
        -------
        tuple of float
            ``(length_m, speed_mps, duration)`` with ``duration = length_m /
            speed_mps + RAMP_S``.

        Raises
        ------
        ParameterError
            When all three are given and disagree, or the motion is impossible
            (shorter than its two ramps).
        """
        given = {k: getattr(self, k) for k in ("duration", "length_m", "speed_mps") if getattr(self, k) is not None}
        for k, v in given.items():
            if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) \
                    or not (math.isfinite(v) and v > 0):
                raise ParameterError(f"StudyConfig.{k}: {v!r}, expected a finite number > 0")
        T, L, v = (None if given.get(k) is None else float(given[k]) for k in ("duration", "length_m", "speed_mps"))
        if T is None and L is None:
            L = DEFAULT_LENGTH_M
            if v is None:
                T = DEFAULT_DURATION_S
        if v is None and (T is None or L is None):
            from .simulate import paper_speed

            v = paper_speed(self.period_m)
        if T is None:
            T = L / v + RAMP_S
        elif L is None:
            L = v * (T - RAMP_S)
        elif v is None:
            v = L / (T - RAMP_S) if T > RAMP_S else math.inf
        elif abs(L / v + RAMP_S - T) > 1e-9 * T:
            raise ParameterError(f"StudyConfig: duration {T:g} s, length_m {L:g} m and speed_mps {v:g} m/s "
                                 f"disagree (duration = length_m / speed_mps + {RAMP_S:g} s ramps); "
                                 "expected at most two of them")
        if not (T >= 2 * RAMP_S and L / v >= RAMP_S):
            raise ParameterError(f"StudyConfig.duration: {T:g} s for {L:g} m; expected at least {2 * RAMP_S:g} s "
                                 f"(the path starts and stops with {RAMP_S:g} s ramps)")
        return L, v, T

    def resolved(self) -> "StudyConfig":
        """This config with `duration`, `length_m` and `speed_mps` all filled in (see :meth:`motion`).

        Returns
        -------
        StudyConfig
            A copy; the other fields are unchanged.

        Examples
        --------
        >>> c = StudyConfig().resolved()                    # the paper's 6.3 m in 15 s
        >>> c.length_m, round(c.speed_mps, 12), c.duration  # 6.3 m / (15 s - 1 s of ramps)
        (6.3, 0.45, 15.0)
        """
        L, v, T = self.motion()
        return replace(self, length_m=L, speed_mps=v, duration=T)

    def bias_sigmas(self) -> tuple:
        """(accelerometer, gyro) bias 1 sigma per axis after calibration [m/s^2, rad/s].

        Returns
        -------
        tuple of float
            ``"RD"``: the datasheet turn-on biases; ``"GC"``: the gyro one
            replaced by ``gyro_noise / sqrt(cal_seconds)``; ``"GAC"``: both
            replaced by ``noise / sqrt(cal_seconds)``.

        Examples
        --------
        >>> sa, sg = StudyConfig(calibration="GAC", cal_seconds=4.0).bias_sigmas()
        >>> sa == MPU6500.accel_noise / 2, sg == MPU6500.gyro_noise / 2
        (True, True)
        """
        ra = self.spec.accel_noise / math.sqrt(self.cal_seconds)
        rg = self.spec.gyro_noise / math.sqrt(self.cal_seconds)
        return ({"RD": self.spec.accel_bias, "GC": self.spec.accel_bias, "GAC": ra}[self.calibration],
                {"RD": self.spec.gyro_bias, "GC": rg, "GAC": rg}[self.calibration])

    def validate(self) -> None:
        """Raise ParameterError naming the first bad parameter.

        Returns
        -------
        None

        Raises
        ------
        ParameterError
            A bad sensor, rate, path, motion, gain scenario, calibration or
            run count, or a path shorter than 3 periods.

        Examples
        --------
        >>> StudyConfig(length_m=2.0).validate()
        Traceback (most recent call last):
        ...
        morpi_filters.errors.ParameterError: StudyConfig.length_m: 2 m holds fewer than 3 periods of 1.0 m (one tapered period at each end plus one step)
        """
        if not isinstance(self.spec, SensorSpec):
            raise ParameterError(f"StudyConfig.spec: {self.spec!r}, expected a SensorSpec")
        for name in ("rate_hz", "period_m", "amplitude_m"):
            v = getattr(self, name)
            if isinstance(v, bool) or not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ParameterError(f"StudyConfig.{name}: {v!r}, expected a finite number > 0")
        length, _, duration = self.motion()
        if duration * self.rate_hz < 2:
            raise ParameterError(f"StudyConfig.duration: {duration} s at {self.rate_hz} Hz gives fewer than 2 samples")
        if 3 * self.period_m > length:
            raise ParameterError(f"StudyConfig.length_m: {length:g} m holds fewer than 3 periods of "
                                 f"{self.period_m} m (one tapered period at each end plus one step)")
        if self.ins_path not in INS_PATHS:
            raise ParameterError(f"StudyConfig.ins_path: {self.ins_path!r}, expected one of {INS_PATHS}")
        if not self.gains or not all(isinstance(g, GainError) for g in self.gains):
            raise ParameterError("StudyConfig.gains: expected a non-empty tuple of GainError")
        for g in self.gains:
            if not (math.isfinite(g.mean) and math.isfinite(g.std) and g.std >= 0 and g.mean > -1):
                raise ParameterError(f"StudyConfig.gains: {g.label!r}: mean {g.mean}, std {g.std}; expected finite, "
                                     "std >= 0, mean > -1")
        if len({g.label for g in self.gains}) != len(self.gains):
            raise ParameterError("StudyConfig.gains: two scenarios share a label; expected distinct labels")
        if not (isinstance(self.keep_every, int) and self.keep_every >= 1):
            raise ParameterError(f"StudyConfig.keep_every: {self.keep_every!r}, expected a whole number >= 1")
        if self.calibration not in CALIBRATIONS:
            raise ParameterError(f"StudyConfig.calibration: {self.calibration!r}, expected one of {CALIBRATIONS}")
        if not (math.isfinite(self.cal_seconds) and self.cal_seconds > 0):
            raise ParameterError(f"StudyConfig.cal_seconds: {self.cal_seconds!r}, expected a finite number > 0")
        if not (isinstance(self.training_runs, int) and self.training_runs >= 2):
            raise ParameterError(f"StudyConfig.training_runs: {self.training_runs!r}, expected a whole number >= 2")


@dataclass(frozen=True)
class StudyResult:
    """Outcome of :func:`run_study`.

    Attributes
    ----------
    config : StudyConfig
    runs, seed : int
    time : ndarray, shape (m,)
        Times of the kept error samples [s].
    errors : ndarray, shape (runs, m, 4), or None
        Horizontal position error [m] of :data:`METHODS` for the primary gain
        scenario (NaN for INS columns when ``config.ins`` is False). MoRPI
        positions start at the first f_y peak and change at each later peak
        (0 until the first step is complete). Kept only when the study is run
        with ``series=True``; otherwise None, and the curves are summarised
        by `rms` and `bands`, whose memory does not grow with the runs.
    rms : ndarray, shape (m, 4), or None
        Root mean square over the runs of the same errors [m] (None for a
        study run without curves, see :func:`run_studies`).
    bands : ndarray, shape (m, 4, 3), or None
        5th, 50th and 95th percentiles over the runs of the same errors [m],
        read from per-epoch histograms with :data:`BAND_BINS_PER_DECADE` log
        bins per decade (relative resolution ``10 ** (1 / 40)``, 6 %); None
        like `rms`.
    columns : tuple of str
        Names of the columns of `final`.
    final : ndarray, shape (runs, len(columns))
        Final horizontal position error [m] of every method and scenario.
    distance_error : ndarray, shape (runs, S, 2)
        MoRPI-A and MoRPI-G along-track distance error ``sum(s_k) - D`` [m] per gain scenario.
    gain_draw : ndarray, shape (runs,)
        The standard normal number of each run behind its gain errors
        (:attr:`dG`); the studies of one pass share it (one array).
    distance : float
        True peak-to-peak distance covered by the MoRPI steps [m].
    steps : int
        Number of MoRPI steps (peak-to-peak windows).
    gain_ref : tuple of float
        Reference gains (G_A [m/(m/s^2)^(1/4)], G_G [m/(rad/s)^(1/4)]),
        trained on runs drawn from :func:`training_seed` of `seed`.
    gain_ref_cv : tuple of float
        Coefficient of variation of the per-run training gains behind `gain_ref`.
    digest : str
        sha256 hex digest of `final` (see module docstring).
    backends : dict
        Which implementation produced the trajectories and the mechanizations.
    elapsed : float
        Wall time of the study [s].
    """

    config: StudyConfig
    runs: int
    seed: int
    time: np.ndarray
    errors: np.ndarray | None
    columns: tuple
    final: np.ndarray
    distance_error: np.ndarray
    gain_draw: np.ndarray
    distance: float
    steps: int
    gain_ref: tuple
    gain_ref_cv: tuple
    digest: str
    backends: dict = field(default_factory=dict)
    elapsed: float = 0.0
    rms: np.ndarray | None = None
    bands: np.ndarray | None = None

    @property
    def dG(self) -> np.ndarray:
        """Gain errors applied, shape (runs, S): ``mean + std * gain_draw`` of each scenario of the config.

        Formed on each access from :attr:`gain_draw` (8 bytes per run however
        many scenarios and studies share the draws), as the study formed them.
        """
        out = np.empty((self.gain_draw.shape[0], len(self.config.gains)))
        for s_i, gain in enumerate(self.config.gains):
            out[:, s_i] = gain.errors(self.gain_draw)
        return out

    def column(self, name: str) -> np.ndarray:
        """Final errors of one column, shape (runs,): ``"INS-3D"``, ``"INS-2D"`` or ``"MoRPI-A[<gain label>]"``.

        Parameters
        ----------
        name : str
            A name of :attr:`columns`.

        Returns
        -------
        ndarray, shape (runs,)
            Final horizontal position error [m] (a view into :attr:`final`).

        Raises
        ------
        ParameterError
            For a name not in `columns`.
        """
        if name not in self.columns:
            raise ParameterError(f"column {name!r}: expected one of {', '.join(self.columns)}")
        return self.final[:, self.columns.index(name)]

    def _gain_index(self, gain) -> int:
        labels = [g.label for g in self.config.gains]
        if gain is None:
            return 0
        if gain not in labels:
            raise ParameterError(f"gain {gain!r}: expected one of {', '.join(map(repr, labels))}")
        return labels.index(gain)

    def final_error(self, method: str, gain: str | None = None) -> np.ndarray:
        """Final horizontal error of one method [m], shape (runs,).

        Parameters
        ----------
        method : {"INS-3D", "INS-2D", "MoRPI-A", "MoRPI-G"}
        gain : str, optional
            Label of the gain scenario of a MoRPI method (default: the first).

        Returns
        -------
        ndarray, shape (runs,)
            The column of :attr:`final` [m] (NaN for the INS methods when
            ``config.ins`` is False).

        Raises
        ------
        ParameterError
            An unknown method or gain label.
        """
        if method in METHODS[:2]:
            return self.column(method)
        if method not in METHODS:
            raise ParameterError(f"method {method!r}: expected one of {', '.join(METHODS)}")
        return self.column(f"{method}[{self.config.gains[self._gain_index(gain)].label}]")

    def distance_error_of(self, method: str, gain: str | None = None) -> np.ndarray:
        """Along-track distance error ``sum(s_k) - D`` of a MoRPI method [m], shape (runs,).

        Parameters
        ----------
        method : {"MoRPI-A", "MoRPI-G"}
        gain : str, optional
            Label of the gain scenario (default: the first).

        Returns
        -------
        ndarray, shape (runs,)
            The slice of :attr:`distance_error` [m].

        Raises
        ------
        ParameterError
            A method other than the two MoRPI ones, or an unknown gain label.
        """
        if method not in METHODS[2:]:
            raise ParameterError(f"method {method!r}: expected 'MoRPI-A' or 'MoRPI-G'")
        return self.distance_error[:, self._gain_index(gain), METHODS.index(method) - 2]

    def curve(self, method: str, statistic: str = "rms") -> np.ndarray:
        """Horizontal error over :attr:`time` of one method, primary gain scenario [m], shape (m,).

        Parameters
        ----------
        method : {"INS-3D", "INS-2D", "MoRPI-A", "MoRPI-G"}
        statistic : {"rms", "p5", "p50", "p95"}
            Root mean square over the runs, or a percentile band of :attr:`bands`.

        Returns
        -------
        ndarray, shape (m,)
            The column of :attr:`rms` or of :attr:`bands` [m].

        Raises
        ------
        ParameterError
            An unknown method or statistic, or a study run without curves.
        """
        if method not in METHODS:
            raise ParameterError(f"method {method!r}: expected one of {', '.join(METHODS)}")
        if self.rms is None:
            raise ParameterError("curve: this study was run without curves (run_studies(..., curves=...))")
        j = METHODS.index(method)
        if statistic == "rms":
            return self.rms[:, j]
        names = tuple(f"p{p:g}" for p in BAND_PERCENTILES)
        if statistic not in names:
            raise ParameterError(f"statistic {statistic!r}: expected 'rms' or one of {', '.join(names)}")
        return self.bands[:, j, names.index(statistic)]


# ----------------------------------------------------------------------------- seeding

def child_seed(seed: int, i: int) -> np.random.SeedSequence:
    """The seed of run `i`: identical to ``SeedSequence(seed).spawn(i + 1)[i]``.

    Built directly with ``spawn_key=(i,)``, so run i's seed needs neither the
    other runs' seeds nor the run count.

    Parameters
    ----------
    seed : int
        Study seed (>= 0).
    i : int
        Run index (>= 0).

    Returns
    -------
    numpy.random.SeedSequence

    Examples
    --------
    >>> a = child_seed(7, 2).generate_state(4)
    >>> b = np.random.SeedSequence(7).spawn(3)[2].generate_state(4)
    >>> bool((a == b).all())
    True
    """
    return np.random.SeedSequence(seed, spawn_key=(i,))


def training_seed(seed: int) -> np.random.SeedSequence:
    """The seed of a study's gain-training runs: the study seed's child :data:`TRAINING_KEY`.

    The same as ``child_seed(seed, TRAINING_KEY)``; no run of a study uses it
    (a study has at most :data:`TRAINING_KEY` runs, indices below it).

    Parameters
    ----------
    seed : int
        Study seed (>= 0).

    Returns
    -------
    numpy.random.SeedSequence

    Examples
    --------
    >>> training_seed(7).generate_state(2).tolist() == child_seed(7, TRAINING_KEY).generate_state(2).tolist()
    True
    """
    return child_seed(seed, TRAINING_KEY)


#: Significant bits the per-run final errors keep in :func:`digest`: a relative step of 2^-20 (about
#: 1e-6, six significant digits), far above the differences another machine's arithmetic makes (see the
#: module docstring, Digest).
DIGEST_BITS = 20


def digest(final: np.ndarray) -> str:
    """sha256 hex digest of per-run final errors rounded to :data:`DIGEST_BITS` significant bits.

    Each value is rounded to the nearest multiple of ``2**(e - DIGEST_BITS)``
    where ``2**(e - 1) <= |x| < 2**e`` (ties to even); NaN is written as one
    NaN and -0 as +0, whatever bits a machine gave them. The digest is that of
    the rounded values as float64 little-endian, shape (runs, columns), C
    order; changes below the step (one part in about a million) leave it as
    it is, unless they carry a value across a rounding boundary.

    Parameters
    ----------
    final : array_like, shape (runs, columns)
        Final errors [m]; converted to little-endian float64.

    Returns
    -------
    str
        64 hexadecimal characters.

    Examples
    --------
    >>> digest(np.zeros((0, 4))) == hashlib.sha256(b"").hexdigest()     # no bytes at all
    True
    >>> digest([[1.0]]) == hashlib.sha256(np.float64(1.0).tobytes()).hexdigest()
    True
    >>> digest([[1.0 + 2.0 ** -30]]) == digest([[1.0]]), digest([[1.0 + 2.0 ** -19]]) == digest([[1.0]])
    (True, False)
    """
    a = np.asarray(final, dtype=np.float64)
    m, e = np.frexp(a)
    r = np.ldexp(np.rint(np.ldexp(m, DIGEST_BITS)), e - DIGEST_BITS) + 0.0   # exact; + 0.0 turns -0 into +0
    r = np.where(np.isnan(r), np.nan, r)
    return hashlib.sha256(np.ascontiguousarray(r, dtype="<f8").tobytes(order="C")).hexdigest()


# ----------------------------------------------------------------------------- trajectories

@dataclass(frozen=True)
class _Path:
    """An exact trajectory sampled on `time` (private; see simulate.Trajectory)."""

    time: np.ndarray        # (n,)
    position: np.ndarray    # (n, 3)
    velocity: np.ndarray    # (n, 3)
    f_b: np.ndarray         # (n, 3)
    omega_b: np.ndarray     # (n, 3)
    psi: np.ndarray         # (n,) heading
    peaks: np.ndarray       # sample indices of period boundaries (lateral f_y maxima)


def _time_grid(cfg: StudyConfig) -> np.ndarray:
    n = _samples(cfg.motion()[2], cfg.rate_hz)
    return np.arange(n) / cfg.rate_hz


def _samples(duration: float, rate_hz: float) -> int:
    """Samples of a run from t = 0 until the first sample at or after `duration`."""
    return int(math.ceil(duration * rate_hz - 1e-9)) + 1


def _as_path(traj, t: np.ndarray, peaks: np.ndarray) -> _Path:
    return _Path(t, traj.position, traj.velocity, traj.f_b, traj.omega_b, traj.heading, peaks)


@functools.lru_cache(maxsize=8)
def _paths_cached(length, speed, period, amplitude, duration, rate_hz, ins_path):
    from . import simulate

    t = np.arange(_samples(duration, rate_hz)) / rate_hz
    sn = simulate.sine(length, period=period, amplitude=amplitude, speed=speed, rest=0.0, rate_hz=rate_hz)
    if abs(sn.end_time - duration) > 1e-9 * duration:
        raise ParameterError(f"StudyConfig: the sine path lasts {sn.end_time:.6g} s, expected {duration:.6g} s")
    sine = sn.at(t)
    if np.abs(sine.heading[0]) > 1e-12 or np.abs(sine.pitch).max() > 0:
        raise ParameterError("simulate.sine: expected a level path starting along x "
                             "(the INS kernel starts at C_bn = I)")
    # f_y maxima: the right-hand lateral extremes (centripetal acceleration to the left)
    pt = sn.peak_times[sn.peak_side < 0]
    peaks = np.unique(np.rint(pt * rate_hz).astype(int))
    sine = _as_path(sine, t, peaks)
    if ins_path == "sine":
        return sine, sine
    st = simulate.straight(length, speed=speed, rest=0.0, rate_hz=rate_hz).at(t)
    return _as_path(st, t, np.array([0, t.size - 1])), sine


def _paths(cfg: StudyConfig):
    """(path of the INS, sine path of MoRPI, backend name) sampled on the study's time grid."""
    L, v, T = cfg.motion()
    ins, sn = _paths_cached(L, v, cfg.period_m, cfg.amplitude_m, T, cfg.rate_hz, cfg.ins_path)
    return ins, sn, f"simulate.sine / simulate.{cfg.ins_path} (rest 0 s, sampled on the study grid)"


# ----------------------------------------------------------------------------- mechanizations

def _mechanizations():
    """(ins3d, ins2d, backend name): batched strapdown returning positions (R, n, 3)."""
    from . import strapdown

    return (lambda *a, **k: strapdown.ins3d(*a, **k).position,
            lambda *a, **k: strapdown.ins2d(*a, **k).position,
            "strapdown.ins3d / strapdown.ins2d")


# ----------------------------------------------------------------------------- MoRPI

def _weinberg_sums(sig: np.ndarray, peaks: np.ndarray) -> np.ndarray:
    """(max - min)^(1/4) of `sig` (R, n) over each peak-to-peak window (inclusive): (R, K)."""
    K = peaks.size - 1
    out = np.empty((sig.shape[0], K))
    for j in range(K):
        w = sig[:, peaks[j]:peaks[j + 1] + 1]
        out[:, j] = weinberg_length(w.max(axis=1), w.min(axis=1), 1.0)
    return out


def _chord_sum(path: _Path) -> float:
    """True distance D covered by the Weinberg steps: sum of the peak-to-peak chords [m]."""
    return float(np.linalg.norm(np.diff(path.position[path.peaks, :2], axis=0), axis=1).sum())


def reference_gains(cfg: StudyConfig, seed: int):
    """Train the MoRPI-A and MoRPI-G reference gains on noisy runs of the sine path.

    Each training run gives ``G_j = D / sum_k df_k`` (D: true peak-to-peak
    distance, df_k: Weinberg term of step k); the reference gain is the mean of
    the G_j, as in the paper's gain calculation [1]. The runs draw from one
    Generator seeded with :func:`training_seed` of the study seed, in blocks of
    500 runs (a larger training set extends a smaller one's draws).

    Parameters
    ----------
    cfg : StudyConfig
        Sensor, path, rate and ``training_runs`` of the training set.
    seed : int
        Study seed (>= 0).

    Returns
    -------
    gains : tuple of float
        (G_A [m/(m/s^2)^(1/4)], G_G [m/(rad/s)^(1/4)]).
    cv : tuple of float
        Coefficient of variation of the per-run gains (spread / mean).

    Examples
    --------
    >>> (ga, gg), (cv_a, cv_g) = reference_gains(StudyConfig(training_runs=20), seed=0)
    >>> bool(ga > 0 and gg > 0 and cv_a < 0.01 and cv_g < 0.01)
    True
    >>> reference_gains(StudyConfig(training_runs=20), seed=0) == ((ga, gg), (cv_a, cv_g))   # the same seed
    True
    >>> reference_gains(StudyConfig(training_runs=20), seed=1) == ((ga, gg), (cv_a, cv_g))   # another seed
    False
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ParameterError(f"seed: {seed!r}, expected a whole number >= 0")
    L, v, _ = cfg.motion()
    return _reference_gains(cfg.spec, L, v, cfg.period_m, cfg.amplitude_m, cfg.rate_hz, cfg.training_runs, int(seed))


@functools.lru_cache(maxsize=16)
def _reference_gains(spec, length_m, speed_mps, period_m, amplitude_m, rate_hz, training_runs, seed):
    cfg = StudyConfig(spec=spec, length_m=length_m, speed_mps=speed_mps, period_m=period_m, amplitude_m=amplitude_m,
                      rate_hz=rate_hz, training_runs=training_runs)
    _, sine, _ = _paths(cfg)
    rng = np.random.Generator(np.random.PCG64(training_seed(seed)))
    sa = cfg.spec.accel_noise * math.sqrt(cfg.rate_hz)
    sg = cfg.spec.gyro_noise * math.sqrt(cfg.rate_hz)
    D = _chord_sum(sine)
    M = cfg.training_runs
    ga, gg = np.empty(M), np.empty(M)
    # the Weinberg windows span the first to the last peak: only those samples of the signals are formed,
    # in two buffers kept over the blocks of 500 runs
    lo, hi = sine.peaks[0], sine.peaks[-1] + 1
    z = np.empty((min(500, M), 2, sine.time.size))
    sig = np.empty((min(500, M), hi - lo))
    for a in range(0, M, 500):
        m = min(500, M - a)
        rng.standard_normal(out=z[:m])
        for c, sd, true, g in ((0, sa, sine.f_b[lo:hi, 1], ga), (1, sg, sine.omega_b[lo:hi, 2], gg)):
            np.multiply(z[:m, c, lo:hi], sd, out=sig[:m])       # the measured signal: true + sd z
            sig[:m] += true
            g[a:a + m] = D / _weinberg_sums(sig[:m], sine.peaks - lo).sum(axis=1)
    return (float(ga.mean()), float(gg.mean())), (float(ga.std(ddof=1) / ga.mean()), float(gg.std(ddof=1) / gg.mean()))


# ----------------------------------------------------------------------------- the chunk kernel

@dataclass(frozen=True)
class _Payload:
    configs: tuple          # StudyConfig of each study; they share the draws and the paths
    seed: int
    ins_path: _Path         # the path INS-3D and INS-2D drive
    ins_heading: np.ndarray | None   # its heading integrated by the kernel's rule (None: straight)
    ins_truth: tuple        # ((x, y) 3D, (x, y) 2D) of the kernels on its true signals, at `keep`
    sine: _Path
    gain_ref: tuple
    keep: np.ndarray
    series: bool            # return the per-run error series too
    curves: tuple           # per study: whether its error series are reduced (RMS, histogram counts)


#: Scratch arrays of the chunk kernel, per thread, kept from one chunk to the next (see :func:`_scratch`).
_SCRATCH = threading.local()

#: Whether :func:`_keep_freed_memory` has run in this process.
_MALLOC_TUNED = False


def _on_dask_worker() -> bool:
    """Whether this code runs inside a Dask worker (a process the study's scheduler owns)."""
    import sys

    if "distributed" not in sys.modules:
        return False
    from distributed import get_worker

    try:
        get_worker()
    except ValueError:
        return False
    return True


def _keep_freed_memory() -> None:
    """Ask the C library's allocator to keep freed memory for reuse (glibc; once per process).

    A chunk allocates and frees many numpy temporaries of 0.1 to 6 MB. With
    glibc's default thresholds, in a process that has not yet freed a larger
    block (a fresh Dask worker), each of them is mapped and unmapped, or the
    heap grown and trimmed again, so the system maps and zeroes that memory
    every time: measured 64,000 page faults and 1.8 times the CPU of a chunk
    in a fresh worker. Fixing the mmap threshold at 32 MB and the trim
    threshold at 256 MB keeps such blocks in the heap. Nothing happens where
    the allocator is not glibc's. Called in Dask worker processes only: a
    library does not change the allocator of the process that imports it.
    """
    global _MALLOC_TUNED
    if _MALLOC_TUNED:
        return
    _MALLOC_TUNED = True
    try:
        import ctypes

        libc = ctypes.CDLL("libc.so.6")
        libc.mallopt(-3, 32 * 2**20)     # M_MMAP_THRESHOLD
        libc.mallopt(-1, 256 * 2**20)    # M_TRIM_THRESHOLD
    except (OSError, AttributeError):    # not glibc: its own allocator, left as it is
        pass


def _scratch(name: str, shape: tuple) -> np.ndarray:
    """A scratch array of this thread (uninitialised), reused by the next chunk of the same shape.

    The chunk kernel's large planes (the draws, the noise, the measured
    signals) are tens of MB each; allocating them afresh for every chunk makes
    the system map and zero that memory again each time. Nothing returned by a
    chunk may be a view of a scratch array.
    """
    cache = getattr(_SCRATCH, "arrays", None)
    if cache is None:
        cache = _SCRATCH.arrays = {}
    a = cache.get(name)
    if a is None or a.shape != shape:
        cache[name] = None
        a = cache[name] = np.empty(shape)
    return a


def _release_scratch() -> None:
    """Free this thread's scratch arrays (the end of a study)."""
    _SCRATCH.arrays = {}


def _draw(seed: int, a: int, b: int, n: int, out: np.ndarray | None = None) -> np.ndarray:
    """Per-run draws of runs a..b-1: (b - a, 7 + 6 n) standard normals, each from its own Generator."""
    z = np.empty((b - a, _N_HEAD + 6 * n)) if out is None else out
    for r in range(a, b):
        np.random.Generator(np.random.PCG64(child_seed(seed, r))).standard_normal(out=z[r - a])
    return z


def _chunk(payload: _Payload, a: int, b: int) -> tuple:
    """Runs a..b-1 of every study of the payload from one draw of their random numbers.

    The studies differ only in the calibration (which scales the same bias
    numbers), the gain scenarios and whether the INS runs. The noise planes
    are built once; each calibration adds its biases to them once (into the
    draws' buffer, free once the noise is built, and the last calibration in
    place, the noise being needed no more), and those measurement errors
    serve all its studies. Returns the runs' gain draws (``{"gain_draw": z}``,
    shared by every study: each forms its gain errors from them) and one dict
    per study: per-run final errors and distance errors, and, for a study
    whose curves are kept, the chunk's reductions of the error series (sum of
    squares and histogram counts per epoch), plus the series themselves when
    ``payload.series``.
    """
    if _on_dask_worker():
        _keep_freed_memory()
    cfg0, sine = payload.configs[0], payload.sine
    n = sine.time.size
    h = 1.0 / cfg0.rate_hz
    R = b - a
    z = _draw(payload.seed, a, b, n, out=_scratch("draws", (R, _N_HEAD + 6 * n)))
    zg = z[:, 6].copy()
    head = z[:, :6].copy()
    sa, sg = cfg0.spec.accel_noise * math.sqrt(cfg0.rate_hz), cfg0.spec.gyro_noise * math.sqrt(cfg0.rate_hz)
    # time-major planes (6, n, R) of the white noise at the discrete sigma (accelerometer xyz, gyro xyz)
    noise = _scratch("noise", (6, n, R))
    zr = z[:, _N_HEAD:].reshape(R, 6, n)
    for c in range(6):
        # a plain copy transposes faster than a multiply reading the transposed planes
        noise[c] = zr[:, c, :].T
        noise[c] *= sa if c < 3 else sg
    spare = z.reshape(-1)[:6 * n * R].reshape(6, n, R)     # the draws' buffer, free from here on
    del z, zr
    psi = _scratch("psi", (n, R))
    keep = payload.keep
    out = [None] * len(payload.configs)
    cals = list(dict.fromkeys(c.calibration for c in payload.configs))
    for cal in cals:
        members = [i for i, c in enumerate(payload.configs) if c.calibration == cal]
        cfg = payload.configs[members[0]]
        sig_ba, sig_bg = cfg.bias_sigmas()
        # the measured errors: white noise + bias (the biases as contiguous rows, one per channel); the last
        # calibration writes them over the noise planes
        bias = np.concatenate([sig_ba * head[:, 0:3], sig_bg * head[:, 3:6]], axis=1).T.copy()
        err = noise if cal == cals[-1] else spare
        for c in range(6):
            np.add(noise[c], bias[c], out=err[c])
        _heading_error(err[5], h, psi)
        # MoRPI on the sine path: Weinberg terms from the measured signals (constant biases cancel in
        # max - min); heading = true heading + integrated gyro-z error.
        pk = sine.peaks
        dfa = _weinberg_terms(err[1], sine.f_b[:, 1], pk)          # (R, K)
        dfg = _weinberg_terms(err[5], sine.omega_b[:, 2], pk)
        hd = (psi[pk[1:]] + sine.psi[pk[1:], None]).T                # (R, K) heading at each step's end peak
        trig = (np.cos(hd), np.sin(hd))
        ins_e = None
        if any(payload.configs[i].ins for i in members):
            ins_e = _ins_errors(payload, err, psi, h, keep)
        for i in members:
            out[i] = _study_chunk(payload, payload.configs[i], ins_e, dfa, dfg, trig, zg, R, payload.curves[i])
    return {"gain_draw": zg}, out


def _heading_error(w, h, out, block: int = 64):
    """Heading error integrated from the gyro-z error `w` (n, R) by the trapezoid rule, into `out` (n, R).

    ``psi_k = h (sum_{i<k} w_i + (w_k - w_0) / 2)``, formed as
    ``((P_k + w_k / 2) - w_0 / 2) h`` with ``P_k = sum_{i<k} w_i`` by
    :func:`_batch_ins.prefix_rows`; block by block of `block`
    rows, each finished while it is in cache (the same operations as over
    the whole array in turn).
    """
    n, R = w.shape
    w0 = 0.5 * w[0]
    half = np.empty((block, R))
    last = np.zeros(R)                      # P of the row before the block
    first = np.empty(R)
    for r0 in range(0, n, block):
        r1 = min(r0 + block, n)
        p = bi.prefix_rows(w[r0:r1 - 1], out[r0:r1], start=np.add(last, w[r0 - 1], out=first) if r0 else None)
        last[...] = p[-1]
        p += np.multiply(w[r0:r1], 0.5, out=half[:r1 - r0])
        p -= w0
        p *= h
    return out


def _ins_errors(payload, err, psi, h, keep):
    """INS-3D and INS-2D horizontal errors (R, m) on the INS path from rest.

    The measured signals are the true ones of the path plus `err`; both go
    through the same integration rules (the truth once, in
    :func:`_ins_truth`), so the difference is the error the sensor errors
    cause. Overwrites `err` with the measured signals, and then with the
    four horizontal accelerations, which take the planes of the signals
    already consumed: the 3D x and y those of the x and y rates (the kernel
    reads each sample's rates before it writes the sample's accelerations),
    the 2D x and y those of f_z and the z rate (not read by the 2D kernel).
    Planes 2 to 5 of `err` are then integrated twice in one call (the
    integration is elementwise over its columns).
    """
    path = payload.ins_path
    for c in range(3):
        err[c] += path.f_b[:, c, None]
        if path.omega_b[:, c].any():
            err[3 + c] += path.omega_b[:, c, None]
    f, w = [err[0], err[1], err[2]], [err[3], err[4], err[5]]
    bi.horizontal_accel_3d(h, f, w, err[3], err[4])
    bi.horizontal_accel_2d(f, psi, err[2], err[5], heading=payload.ins_heading)
    del f, w
    # columns: 2D x, 3D x, 3D y, 2D y
    pos = bi.double_integral_at(err[2:].transpose(1, 0, 2), h, keep)
    (x3, y3), (x2, y2) = payload.ins_truth
    return [np.hypot(pos[:, 1] - x3, pos[:, 2] - y3).T, np.hypot(pos[:, 0] - x2, pos[:, 3] - y2).T]


def _ins_truth(path: _Path, h: float, keep: np.ndarray):
    """(trapezoid heading (n,) or None, ((x, y) of the 3D kernel, (x, y) of the 2D kernel)) on the true signals."""
    f = [path.f_b[:, c, None].copy() for c in range(3)]
    w = [path.omega_b[:, c, None].copy() for c in range(3)]
    heading = None
    if path.omega_b[:, 2].any():
        wz = path.omega_b[:, 2]
        heading = np.concatenate([[0.0], np.cumsum(0.5 * h * (wz[1:] + wz[:-1]))])
    zero = np.zeros((path.time.size, 1))
    return heading, (bi.horizontal_3d(h, f, w, keep), bi.horizontal_2d(f, zero, h, keep, heading=heading))


def _study_chunk(payload, cfg, ins_e, dfa, dfg, trig, zg, R, curves) -> dict:
    """One study's part of a chunk: finals and distance errors, and (`curves`) series reductions."""
    sine, keep = payload.sine, payload.keep
    pk = sine.peaks
    cps, sps = trig
    S = len(cfg.gains)
    series = np.full((R, keep.size, 4), np.nan) if payload.series else None
    final = np.full((R, 2 + 2 * S), np.nan)
    if cfg.ins:
        for j, e in enumerate(ins_e):
            if series is not None:
                series[:, :, j] = e
            final[:, j] = e[:, -1]
    truth = sine.position[pk, :2] - sine.position[pk[0], :2]   # (K+1, 2)
    D = _chord_sum(sine)
    steps_done = np.clip(np.searchsorted(pk, keep, side="right") - 1, 0, None)   # 0 before the first peak
    dist = np.empty((R, S, 2))
    morpi = []                                                  # (R, K+1) MoRPI errors after 0..K steps
    for s_i, gain in enumerate(cfg.gains):
        scale = 1.0 + gain.errors(zg)[:, None]
        for m, (df, G) in enumerate(((dfa, payload.gain_ref[0]), (dfg, payload.gain_ref[1]))):
            st = (G * scale) * df                           # (R, K) step lengths
            x = np.cumsum(st * cps, axis=1)
            y = np.cumsum(st * sps, axis=1)
            e = np.hypot(x - truth[1:, 0], y - truth[1:, 1])   # (R, K)
            final[:, 2 + 2 * s_i + m] = e[:, -1]
            dist[:, s_i, m] = st.sum(axis=1) - D
            if s_i == 0 and (curves or series is not None):
                e0 = np.concatenate([np.zeros((R, 1)), e], axis=1)
                morpi.append(e0)
                if series is not None:
                    series[:, :, 2 + m] = e0[:, steps_done]
    part = {"final": final, "dist": dist}
    if curves and series is not None:
        part.update(sumsq=np.nansum(series * series, axis=0), count=np.isfinite(series).sum(axis=0),
                    hist=_band_counts(series))
    elif curves:
        part.update(_curve_reductions(ins_e if cfg.ins else None, morpi, steps_done, R))
    if series is not None:
        part["series"] = series
    return part


def _curve_reductions(ins_e, morpi, steps_done, R) -> dict:
    """``sumsq``, ``count`` and ``hist`` of the error series (R, m, 4) without building it.

    The same numbers as ``np.nansum(series ** 2, axis=0)``, ``np.isfinite(series).sum(axis=0)``
    and :func:`_band_counts` of the series: column by column, each sum over the
    runs in run order. A MoRPI column changes only at a step, so its sums and
    histograms are those of its K + 1 values (after 0..K steps), repeated over
    the epochs that have taken as many steps.
    """
    m = steps_done.size
    nb = _BAND_EDGES.size - 1
    sumsq = np.zeros((m, 4))
    count = np.zeros((m, 4), np.int64)
    hist = np.zeros((m, 4, nb), np.int64)
    cols = [] if ins_e is None else [(j, e, None) for j, e in enumerate(ins_e)]
    cols += [(2 + j, e0, steps_done) for j, e0 in enumerate(morpi)]
    for j, e, rows in cols:
        sq = np.multiply(e, e, out=np.empty(e.shape))          # C order: the sum over axis 0 goes run by run
        ok = np.isfinite(e)
        sq[np.isnan(sq)] = 0.0
        s, c = np.add.reduce(sq, axis=0), ok.sum(axis=0)
        x = e[ok]
        k = np.broadcast_to(np.arange(e.shape[1]), e.shape)[ok]
        h = np.bincount(k * nb + _band_bins(x), minlength=e.shape[1] * nb).reshape(e.shape[1], nb)
        if rows is None:
            sumsq[:, j], count[:, j], hist[:, j] = s, c, h
        else:
            sumsq[:, j], count[:, j], hist[:, j] = s[rows], c[rows], h[rows]
    cells = np.flatnonzero(hist)
    return {"sumsq": sumsq, "count": count, "hist": (cells.astype(np.int32), hist.reshape(-1)[cells].astype(np.int32))}


def _band_counts(series) -> tuple:
    """Histogram of series (R, m, k) over :data:`_BAND_EDGES` (NaN left out), sparse.

    Returns ``(cells, counts)``: the occupied cells of the (m, k, bins)
    histogram as flat indices (int32) and their counts (int32). A chunk's runs
    occupy a few bins per epoch, so this is far smaller than the dense array
    (which matters when chunks travel back from Dask workers).
    """
    R, m, k = series.shape
    nb = _BAND_EDGES.size - 1
    ok = np.isfinite(series)
    idx = _band_bins(series[ok])
    flat = np.broadcast_to(((np.arange(m)[:, None] * k + np.arange(k)[None, :]) * nb)[None], series.shape)[ok] + idx
    dense = np.bincount(flat, minlength=m * k * nb)
    cells = np.flatnonzero(dense)
    return cells.astype(np.int32), dense[cells].astype(np.int32)


def _band_bins(x) -> np.ndarray:
    """Bin of each finite value of `x` among :data:`_BAND_EDGES` (int64): ``edges[i] <= x < edges[i + 1]``.

    Values below 0 go to the first bin and values at or above the last edge to the last one.
    """
    nb = _BAND_EDGES.size - 1
    # bin from the logarithm (the edges are log-spaced), then corrected against the edges themselves
    lo = _BAND_EDGES[1]
    with np.errstate(divide="ignore", invalid="ignore"):
        idx = np.floor(np.log10(np.maximum(x, lo) / lo) * BAND_BINS_PER_DECADE).astype(np.int64) + 1
    idx[x < lo] = 0
    np.clip(idx, 0, nb - 1, out=idx)
    idx -= x < _BAND_EDGES[idx]
    idx += (x >= _BAND_EDGES[idx + 1]) & (idx < nb - 1)
    return idx


def band_quantiles(counts, q=BAND_PERCENTILES) -> np.ndarray:
    """Percentiles from histogram counts over :data:`_BAND_EDGES`.

    The bins are the first one from 0 to ``BAND_RANGE_M[0]`` and then
    ``10 * BAND_BINS_PER_DECADE`` log-spaced ones up to ``BAND_RANGE_M[1]``
    (401 in all) [m].

    Parameters
    ----------
    counts : ndarray, shape (..., 401)
        Counts per bin.
    q : sequence of float
        Percentiles in [0, 100].

    Returns
    -------
    ndarray, shape (..., len(q))
        Interpolated geometrically inside a bin (linearly in the first bin,
        which starts at 0); NaN where the counts are all zero.

    Examples
    --------
    Everything in the first bin (0 to 1 um) reads linearly; nothing at all is NaN:

    >>> counts = np.zeros((2, 401))
    >>> counts[0, 0] = 10
    >>> (band_quantiles(counts, q=(50.0, 100.0)) * 1e6).round(9).tolist()
    [[0.5, 1.0], [nan, nan]]

    Everything in the bin from 1 to ``10 ** (1 / 40)`` m reads geometrically:

    >>> one = np.zeros(401)
    >>> one[241] = 4
    >>> round(float(band_quantiles(one, q=(50.0,))[0]), 12) == round(10 ** (1 / 80), 12)
    True
    """
    counts = np.asarray(counts, float)
    cum = np.cumsum(counts, axis=-1)
    total = cum[..., -1:]
    out = []
    lo_e, hi_e = _BAND_EDGES[:-1], _BAND_EDGES[1:]
    for p in q:
        target = p / 100.0 * total
        j = np.minimum((cum < target).sum(axis=-1, keepdims=True), counts.shape[-1] - 1)
        before = np.take_along_axis(cum, j, axis=-1) - np.take_along_axis(counts, j, axis=-1)
        inbin = np.take_along_axis(counts, j, axis=-1)
        with np.errstate(invalid="ignore", divide="ignore"):
            frac = np.clip(np.where(inbin > 0, (target - before) / inbin, 0.0), 0.0, 1.0)
        lo, hi = lo_e[j], hi_e[j]
        val = np.where(lo > 0, lo * (hi / np.where(lo > 0, lo, 1.0)) ** frac, hi * frac)
        out.append(np.where(total > 0, val, np.nan)[..., 0])
    return np.stack(out, axis=-1)


def _weinberg_terms(err, true, peaks):
    """(max - min)^(1/4) of ``true[:, None] + err`` over each peak-to-peak window (inclusive).

    err: (n, R) time-major measurement errors; true: (n,) true signal. Returns (R, K).
    """
    K = peaks.size - 1
    out = np.empty((err.shape[1], K))
    for j in range(K):
        win = err[peaks[j]:peaks[j + 1] + 1] + true[peaks[j]:peaks[j + 1] + 1, None]
        out[:, j] = weinberg_length(win.max(axis=0), win.min(axis=0), 1.0)
    return out


# ----------------------------------------------------------------------------- the engine

def _default_chunk(n: int) -> int:
    return max(1, _CHUNK_BYTES // (8 * (_N_HEAD + 6 * n)))


def _study_seed(seed) -> int:
    """A study seed from an int, or drawn once from a numpy Generator (``rng``)."""
    if isinstance(seed, np.random.Generator):
        return int(seed.integers(0, 2**63))
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ParameterError(f"seed: {seed!r}, expected a whole number >= 0 or a numpy.random.Generator")
    return int(seed)


def _check_runs(runs, seed, chunk):
    if isinstance(runs, bool) or not isinstance(runs, (int, np.integer)) or not 1 <= runs <= TRAINING_KEY:
        raise ParameterError(f"runs: {runs!r}, expected a whole number from 1 to {TRAINING_KEY}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ParameterError(f"seed: {seed!r}, expected a whole number >= 0")
    if chunk is not None and (isinstance(chunk, bool) or not isinstance(chunk, (int, np.integer)) or chunk < 1):
        raise ParameterError(f"chunk: {chunk!r}, expected a whole number >= 1")


#: StudyConfig fields that fix the draws and the paths: the studies of one
#: :func:`run_studies` call must agree on them.
_SHARED_FIELDS = ("spec", "duration", "rate_hz", "length_m", "speed_mps", "period_m", "amplitude_m", "ins_path",
                  "keep_every", "training_runs", "cal_seconds")


def run_study(runs: int, seed: int, config: StudyConfig | None = None, *, chunk: int | None = None,
              workers: int = 1, scheduler=None, progress: bool | None = None, series: bool = False) -> StudyResult:
    """Run a seeded gain-error Monte Carlo study.

    Parameters
    ----------
    runs : int
        Number of runs N (axis 0 of every output).
    seed : int or numpy.random.Generator
        Study seed; run i uses ``SeedSequence(seed).spawn(N)[i]``. A
        Generator (``rng``) gives the seed by one draw of ``rng.integers(0, 2**63)``.
    config : StudyConfig, optional
        What to simulate (default: a :class:`StudyConfig` with its defaults).
    chunk : int, optional
        Runs per batch (bounds memory; results do not depend on it). Default:
        as many as fit a 32 MiB noise block.
    workers : int
        Local threads running chunks (results do not depend on it).
    scheduler : str or distributed.Client, optional
        Run the chunks on this Dask cluster instead (results identical).
    progress : bool, optional
        Progress on stderr; default on when the study has more than 1000 runs.
    series : bool
        Keep every run's error series (:attr:`StudyResult.errors`, 8 bytes x
        runs x epochs x 4); by default only their reductions are kept.

    Returns
    -------
    StudyResult
        With the config resolved (:meth:`StudyConfig.resolved`), the final
        errors of every method and scenario, the per-epoch RMS and bands, the
        distance errors, the applied gain errors and the digest.

    Raises
    ------
    ParameterError
        A bad run count, seed, chunk or config.

    Examples
    --------
    A MoRPI-only study with a 5 % gain error: the distance error is about
    5 % of the distance, and the numbers do not depend on the chunk size.

    >>> cfg = StudyConfig(training_runs=20, ins=False, gains=(GainError("dG = 5 %", 0.05),))
    >>> r = run_study(40, 3, cfg)
    >>> r.columns
    ('INS-3D', 'INS-2D', 'MoRPI-A[dG = 5 %]', 'MoRPI-G[dG = 5 %]')
    >>> r.final.shape, r.rms.shape == (r.time.size, 4), r.errors is None
    ((40, 4), True, True)
    >>> round(float(r.distance_error_of("MoRPI-G").mean() / r.distance), 2)
    0.05
    >>> run_study(40, 3, cfg, chunk=7).digest == r.digest
    True
    """
    return run_studies(runs, seed, (StudyConfig() if config is None else config,), chunk=chunk, workers=workers,
                       scheduler=scheduler, progress=progress, series=series)[0]


def run_studies(runs: int, seed: int, configs, *, chunk: int | None = None, workers: int = 1, scheduler=None,
                progress: bool | None = None, series: bool = False, curves=None,
                label: str = "montecarlo gain-error study") -> tuple:
    """Several gain-error studies over one pass of the same random numbers.

    The studies may differ in calibration, gain scenarios and whether the
    INS runs; everything that fixes the draws and the paths (sensor, duration,
    rate, path, kept epochs, training runs, calibration window) must be the
    same. Each run's numbers are drawn once and serve every study, and every
    study's result is identical, bit for bit, to what :func:`run_study` gives
    for it alone with the same seed. Chunks are reduced as they finish, so
    memory grows with the runs only by the per-run final and distance errors
    (8 bytes x (2 + 4 x scenarios) per run and study) and the runs' gain
    draws (8 bytes per run, shared by the studies), not by the error series
    (unless `series`).

    Parameters
    ----------
    runs, seed, chunk, workers, scheduler, progress, series
        As in :func:`run_study`.
    configs : sequence of StudyConfig
        The studies; they must agree on the fields that fix the draws and paths.
    curves : sequence of bool, optional
        Per study, whether to reduce its error series to :attr:`StudyResult.rms`
        and :attr:`StudyResult.bands` (default: every study). A study left out
        has ``rms`` and ``bands`` None and costs only its per-run final, gain
        and distance errors; `series` keeps the curves of every study.
    label : str
        Name of the progress line.

    Returns
    -------
    tuple of StudyResult
        One per config, in order.

    Raises
    ------
    ParameterError
        An empty or invalid config list, configs that differ in a shared
        field, or a bad run count, seed or chunk.

    Examples
    --------
    >>> raw = StudyConfig(training_runs=20, ins=False)
    >>> gac = replace(raw, calibration="GAC")
    >>> both = run_studies(20, 5, (raw, gac))
    >>> [r.config.calibration for r in both], both[1].digest == run_study(20, 5, gac).digest
    (['RD', 'GAC'], True)
    """
    t0 = _time.perf_counter()
    configs = tuple(configs)
    if not configs or not all(isinstance(c, StudyConfig) for c in configs):
        raise ParameterError("configs: expected a non-empty sequence of StudyConfig")
    for c in configs:
        c.validate()
    configs = tuple(c.resolved() for c in configs)
    for c in configs:
        for name in _SHARED_FIELDS:
            if getattr(c, name) != getattr(configs[0], name):
                raise ParameterError(f"configs: StudyConfig.{name} differs between studies of one pass "
                                     f"({getattr(configs[0], name)!r} and {getattr(c, name)!r}); run them separately")
    seed = _study_seed(seed)
    _check_runs(runs, seed, chunk)
    runs = int(runs)
    curves = (True,) * len(configs) if curves is None or series else tuple(bool(c) for c in curves)
    if len(curves) != len(configs):
        raise ParameterError(f"curves: {len(curves)} values for {len(configs)} studies; expected one per study")
    cfg = configs[0]
    ins_path, sine, traj_backend = _paths(cfg)
    if sine.peaks.size < 2:
        raise ParameterError("StudyConfig: the sine path has fewer than two period boundaries")
    n = sine.time.size
    keep = np.unique(np.r_[np.arange(0, n, cfg.keep_every), n - 1])
    gain_ref, cv = reference_gains(cfg, seed)
    ins_heading, ins_truth = _ins_truth(ins_path, 1.0 / cfg.rate_hz, keep)
    payload = _Payload(configs, seed, ins_path, ins_heading, ins_truth, sine, gain_ref, keep, bool(series), curves)
    chunk = _default_chunk(n) if chunk is None else int(chunk)
    ranges = chunk_ranges(runs, min(chunk, runs))
    prog = Progress(runs, label, runs > 1000 if progress is None else progress)
    acc = [_Reduction(runs) for _ in configs]
    draws = _Reduction(runs)            # the gain draws, shared by every study (each forms its dG from them)
    try:
        execute(_chunk, payload, ranges, workers=workers, scheduler=scheduler, progress=prog,
                reduce=lambda res: (draws.add(res[0]), [r.add(p) for r, p in zip(acc, res[1])]))
    finally:
        _release_scratch()
    out = []
    for c, red in zip(configs, acc):
        final = red.cat("final")
        columns = METHODS[:2] + tuple(f"{m}[{g.label}]" for g in c.gains for m in METHODS[2:])
        rms = bands = None
        if red.sumsq is not None:
            with np.errstate(invalid="ignore", divide="ignore"):
                rms = np.where(red.count > 0, np.sqrt(red.sumsq / np.maximum(red.count, 1)), np.nan)
            bands = band_quantiles(red.hist)
        out.append(StudyResult(
            config=c, runs=runs, seed=seed, time=sine.time[keep], errors=red.cat("series") if series else None,
            columns=columns, final=final, distance_error=red.cat("dist"), gain_draw=draws.cat("gain_draw"),
            distance=_chord_sum(sine), steps=int(sine.peaks.size - 1), gain_ref=gain_ref, gain_ref_cv=cv,
            digest=digest(final),
            backends={"trajectories": traj_backend,
                      "ins": f"batched strapdown kernel on the {c.ins_path} path (quaternion attitude, "
                             "trapezoid integration, the truth through the same rules; tested against "
                             "strapdown.ins3d/ins2d)"},
            elapsed=_time.perf_counter() - t0, rms=rms, bands=bands))
    return tuple(out)


class _Reduction:
    """Running reduction of one study's chunks, fed in run order.

    Per-run arrays are written into arrays allocated once for all the runs
    (no list of chunks concatenated at the end, which would hold them twice).
    """

    _PER_RUN = ("final", "dist", "series", "gain_draw")

    def __init__(self, runs: int):
        self.runs, self.filled = runs, 0
        self.arrays = {}
        self.sumsq = self.count = self.hist = None

    def add(self, part: dict) -> None:
        m = next(part[k] for k in self._PER_RUN if k in part).shape[0]
        for k in self._PER_RUN:
            if k in part:
                if k not in self.arrays:
                    self.arrays[k] = np.empty((self.runs,) + part[k].shape[1:], part[k].dtype)
                self.arrays[k][self.filled:self.filled + m] = part[k]
        self.filled += m
        if "sumsq" not in part:
            return
        if self.sumsq is None:
            m_, k_ = part["sumsq"].shape
            self.sumsq, self.count = part["sumsq"].copy(), part["count"].copy()
            self.hist = np.zeros((m_, k_, _BAND_EDGES.size - 1), np.int64)
        else:
            self.sumsq += part["sumsq"]
            self.count += part["count"]
        cells, counts = part["hist"]
        np.add.at(self.hist.reshape(-1), cells, counts)

    def cat(self, key: str) -> np.ndarray:
        return self.arrays[key]


def summarize(x: np.ndarray) -> dict:
    """mean, std (ddof=1), median and 95th percentile of a sample (NaN-free) [same unit as x].

    Parameters
    ----------
    x : array_like, shape (n,)
        The sample, n >= 1.

    Returns
    -------
    dict
        ``mean``, ``std`` (sample standard deviation, 0.0 for one value),
        ``median`` and ``p95`` (linear interpolation), as floats.

    Examples
    --------
    >>> {k: round(v, 6) for k, v in summarize([1.0, 2.0, 3.0, 4.0]).items()}
    {'mean': 2.5, 'std': 1.290994, 'median': 2.5, 'p95': 3.85}
    """
    x = np.asarray(x, float)
    return {"mean": float(x.mean()), "std": float(x.std(ddof=1)) if x.size > 1 else 0.0,
            "median": float(np.median(x)), "p95": float(np.percentile(x, 95))}


# ----------------------------------------------------------------------------- training runs vs gain error

@dataclass(frozen=True)
class TrainingStudy:
    """How the MoRPI error shrinks with the number k of training runs behind the gain.

    The gain is the mean of k per-run gains, each off by ``mismatch + spread * z_j``
    (a fraction of the true gain), so ``dG = mismatch + spread * mean(z_1..z_k)``,
    i.e. ``dG ~ N(mismatch, spread^2 / k)``.

    Attributes
    ----------
    k : ndarray, shape (K,)
        Numbers of training runs.
    mismatch, spread : float
        Motion mismatch between training and use, and per-run gain spread (fractions).
    rms_distance : ndarray, shape (K, 2)
        Monte Carlo RMS of the MoRPI-A / MoRPI-G distance error [m].
    rms_expected : ndarray, shape (K,)
        ``D * sqrt(mismatch^2 + spread^2 / k)`` [m] (gain term only).
    final : ndarray, shape (K, 2, 4)
        mean, std, median, p95 of the MoRPI-A / MoRPI-G final position error [m].
    digests : tuple of str
    distance : float
        D [m].
    """

    k: np.ndarray
    mismatch: float
    spread: float
    rms_distance: np.ndarray
    rms_expected: np.ndarray
    final: np.ndarray
    digests: tuple
    distance: float


def training_runs_study(ks, *, mismatch: float, spread: float, runs: int, seed: int,
                        config: StudyConfig | None = None, chunk=None, scheduler=None,
                        progress=None) -> TrainingStudy:
    """MoRPI-only studies with ``dG ~ N(mismatch, spread^2 / k)`` for each k in `ks`.

    Each k reuses the study seed, so the runs share their sensor draws and only
    the gain differs (common random numbers).

    Parameters
    ----------
    ks : sequence of int
        Numbers of training runs, each >= 1.
    mismatch : float
        Motion mismatch between training and use (fraction of the gain).
    spread : float
        Per-run gain spread, 1 sigma (fraction), >= 0.
    runs, seed, chunk, scheduler, progress
        As in :func:`run_study`.
    config : StudyConfig, optional
        Path and sensor (default :class:`StudyConfig`); its INS and gain
        scenarios are replaced.

    Returns
    -------
    TrainingStudy

    Examples
    --------
    >>> t = training_runs_study([1, 4], mismatch=0.0, spread=0.05, runs=20, seed=0,
    ...                         config=StudyConfig(training_runs=20))
    >>> round(float(t.rms_expected[0] / t.rms_expected[1]), 12)     # sqrt(4 / 1)
    2.0
    >>> t.rms_distance.shape, t.final.shape
    ((2, 2), (2, 2, 4))
    """
    base = StudyConfig() if config is None else config
    cfgs = training_configs(ks, mismatch=mismatch, spread=spread, config=base)
    results = run_studies(runs, seed, cfgs, chunk=chunk, scheduler=scheduler, progress=progress,
                          curves=(False,) * len(cfgs), label="montecarlo training-runs study")
    return training_summary(ks, results, mismatch=mismatch, spread=spread)


def training_configs(ks, *, mismatch: float, spread: float, config: StudyConfig | None = None) -> tuple:
    """The MoRPI-only study configs of :func:`training_runs_study`, one per k (for :func:`run_studies`).

    Parameters
    ----------
    ks : sequence of int
        Numbers of training runs, each >= 1.
    mismatch, spread : float
        As in :func:`training_runs_study`.
    config : StudyConfig, optional
        The base config (default :class:`StudyConfig`).

    Returns
    -------
    tuple of StudyConfig
        Copies of `config` with ``ins=False`` and one gain scenario
        ``GainError("k = <k>", mismatch, spread / sqrt(k))``.

    Raises
    ------
    ParameterError
        An empty `ks` or one below 1, a negative spread or a non-finite value.

    Examples
    --------
    >>> cfgs = training_configs([1, 4], mismatch=0.02, spread=0.1)
    >>> [(c.gains[0].label, c.gains[0].mean, c.gains[0].std, c.ins) for c in cfgs]
    [('k = 1', 0.02, 0.1, False), ('k = 4', 0.02, 0.05, False)]
    """
    ks = np.asarray(ks, int)
    if ks.ndim != 1 or ks.size == 0 or (ks < 1).any():
        raise ParameterError(f"ks: {ks.tolist()!r}, expected whole numbers >= 1")
    if not (math.isfinite(spread) and spread >= 0 and math.isfinite(mismatch)):
        raise ParameterError(f"spread/mismatch: {spread!r}/{mismatch!r}, expected finite, spread >= 0")
    base = StudyConfig() if config is None else config
    return tuple(replace(base, ins=False, gains=(GainError(f"k = {k}", mismatch, spread / math.sqrt(k)),))
                 for k in ks)


def training_summary(ks, results, *, mismatch: float, spread: float) -> TrainingStudy:
    """A :class:`TrainingStudy` from the results of the :func:`training_configs` studies.

    Parameters
    ----------
    ks : sequence of int
        The numbers of training runs given to :func:`training_configs`.
    results : sequence of StudyResult
        The studies of those configs, in the same order.
    mismatch, spread : float
        As given to :func:`training_configs`.

    Returns
    -------
    TrainingStudy

    Examples
    --------
    >>> ks = [2, 8]
    >>> cfgs = training_configs(ks, mismatch=0.0, spread=0.04, config=StudyConfig(training_runs=20))
    >>> t = training_summary(ks, run_studies(20, 1, cfgs), mismatch=0.0, spread=0.04)
    >>> t.k.tolist(), bool(np.allclose(t.rms_expected, t.distance * 0.04 / np.sqrt(ks)))
    ([2, 8], True)
    """
    ks = np.asarray(ks, int)
    rms, fin, dig = [], [], []
    D = results[0].distance
    for r in results:
        label = r.config.gains[0].label
        rms.append(np.sqrt(np.mean(r.distance_error[:, 0, :] ** 2, axis=0)))
        fin.append([[summarize(r.column(f"{m}[{label}]"))[q] for q in ("mean", "std", "median", "p95")]
                    for m in METHODS[2:]])
        dig.append(r.digest)
    return TrainingStudy(ks, float(mismatch), float(spread), np.array(rms),
                         D * np.sqrt(mismatch ** 2 + spread ** 2 / ks), np.array(fin), tuple(dig), float(D))


# ----------------------------------------------------------------------------- drift: closed form vs strapdown

@dataclass(frozen=True)
class DriftMap:
    """Closed form against nonlinear strapdown, over gyro bias level and time.

    Attributes
    ----------
    gyro_bias : ndarray, shape (L,)
        Gyro bias levels, 1 sigma per axis [rad/s].
    time : ndarray, shape (m,)
        Times [s] (t > 0).
    rel_3d, rel_2d : ndarray, shape (L, m)
        Median over the draws of ``|dp_sim - dp_cf| / |dp_sim|`` (horizontal).
    p90_3d, p90_2d : ndarray, shape (L, m)
        90th percentile of the same.
    final_3d, final_2d : ndarray, shape (L, 2)
        Median final horizontal error [m]: (strapdown, closed form).
    accel_bias : float
        Accelerometer bias 1 sigma per axis [m/s^2].
    draws, seed : int
        Bias draws per level (shared by every level) and their seed.
    backends : dict
    """

    gyro_bias: np.ndarray
    time: np.ndarray
    rel_3d: np.ndarray
    rel_2d: np.ndarray
    p90_3d: np.ndarray
    p90_2d: np.ndarray
    final_3d: np.ndarray
    final_2d: np.ndarray
    accel_bias: float
    draws: int
    seed: int
    backends: dict = field(default_factory=dict)

    def onset(self, which: str = "INS-3D", level: float = 0.01) -> np.ndarray:
        """Time [s] from which the median disagreement stays above `level` to the end, per bias
        (NaN: below it at the end).

        Parameters
        ----------
        which : {"INS-3D", "INS-2D"}
            Which mechanization's disagreement (anything but ``"INS-3D"`` reads ``"INS-2D"``).
        level : float
            Relative disagreement threshold (0.01 is 1 %).

        Returns
        -------
        ndarray, shape (L,)
            One time per gyro bias level [s].
        """
        rel = self.rel_3d if which == "INS-3D" else self.rel_2d
        out = np.full(rel.shape[0], np.nan)
        for i, row in enumerate(rel):
            if row[-1] > level:
                below = np.flatnonzero(row <= level)
                out[i] = self.time[below[-1] + 1] if below.size else self.time[0]
        return out


def _closed_form_symbolic(ba, bg, t, g, kind):
    """Closed-form horizontal position error (z up, C = I, f^n = gravity, gyro-z terms kept).

    ba, bg: (R, 3) biases; t: (m,) times; kind "INS-3D" or "INS-2D". Returns (R, m, 2): the
    function of :func:`morpi_filters.symbolic.closed_form_errors` evaluated for every run at once
    (runs along axis 0, times along axis 1; elementwise, so each run's numbers are those of its
    own evaluation).
    """
    from . import symbolic

    which = {"INS-3D": "INS-3D position", "INS-2D": "INS-2D position"}[kind]
    fn = symbolic.lambdified(which, "z_up", True)
    R = ba.shape[0]
    zero = np.zeros((R, 1))
    cols = fn(t[None, :], zero, zero, zero, *(ba[:, j:j + 1] for j in range(3)), *(bg[:, j:j + 1] for j in range(3)),
              float(g))
    return np.stack([np.broadcast_to(np.asarray(c, float), (R, t.size)) for c in cols[:2]], axis=2)


def _closed_form():
    return _closed_form_symbolic, "symbolic.lambdified (z_up, keep_bgz=True), every run at once"


@dataclass(frozen=True)
class _DriftPayload:
    levels: np.ndarray
    z: np.ndarray          # (draws, 6)
    time: np.ndarray       # (n,)
    keep: np.ndarray
    accel_bias: float
    g: float


def _drift_chunk(payload: _DriftPayload, a: int, b: int) -> dict:
    D = payload.z.shape[0]
    idx = np.arange(a, b)
    lev, d = idx // D, idx % D
    z = payload.z[d]
    ba = payload.accel_bias * z[:, :3]
    bg = payload.levels[lev][:, None] * z[:, 3:]
    t, keep, g = payload.time, payload.keep, payload.g
    R, n = b - a, t.size
    f = np.empty((R, n, 3))
    f[:] = ba[:, None, :]
    f[:, :, 2] += g
    w = np.empty((R, n, 3))
    w[:] = bg[:, None, :]
    ins3d, ins2d, _ = _mechanizations()
    cf, _ = _closed_form()
    out = {}
    tk = t[keep]
    for kind, p in (("INS-3D", ins3d(t, f, w, g=g)), ("INS-2D", ins2d(t, f, w))):
        sim = p[:, keep, :2]
        cfv = cf(ba, bg, tk, g, kind)
        num = np.hypot(*(sim - cfv).transpose(2, 0, 1))
        den = np.hypot(*sim.transpose(2, 0, 1))
        out["rel_" + kind[-2:].lower()] = num / den
        out["end_" + kind[-2:].lower()] = np.stack([den[:, -1], np.hypot(*cfv[:, -1].T)], axis=1)
    return out


def drift_map(gyro_bias=None, *, spec: SensorSpec = MPU6500, duration: float = 15.0, rate_hz: float = 100.0,
              draws: int = 32, seed: int = DRIFT_SEED, keep_every: int = 10, chunk: int | None = None,
              scheduler=None, progress: bool | None = None) -> DriftMap:
    """Compare the closed-form and the strapdown position error of a stationary INS.

    Every level of `gyro_bias` uses the same `draws` bias draws (run d of the
    study: 3 accelerometer then 3 gyro standard normals from
    ``SeedSequence(seed).spawn(draws)[d]``), the gyro numbers scaled by the
    level and the accelerometer ones by ``spec.accel_bias``. The strapdown
    integrates the biased IMU at `rate_hz` (no noise); the closed form is the
    small-angle error polynomial of the 15-state model with C = I and
    f^n = (0, 0, g) [1], including the gyro-z terms.

    Parameters
    ----------
    gyro_bias : array_like, shape (L,), optional
        Gyro bias levels, 1 sigma per axis [rad/s]. Default: 25 levels from
        0.01 to 10 deg/s, log spaced.
    spec : SensorSpec
        Source of the accelerometer bias sigma.
    duration, rate_hz : float
        Length [s] and sampling rate [Hz].
    draws : int
        Bias draws per level.
    seed : int or numpy.random.Generator
        Their seed (a Generator gives it by one draw, as in :func:`run_study`;
        default :data:`DRIFT_SEED`, the seed of ``morpi drift``).
    keep_every : int
        Keep every k-th sample in time.
    chunk, scheduler, progress
        As in :func:`run_study` (results do not depend on them).

    Returns
    -------
    DriftMap
        Medians and 90th percentiles over the draws of the relative
        disagreement per level and kept time, and the median final errors.

    Raises
    ------
    ParameterError
        Bad levels, duration, rate, draw count, seed or chunk.

    Examples
    --------
    Over 2 s the two models agree to well below 1 % at 0.1 and 1 deg/s:

    >>> d = drift_map([0.1 * DEG_S, 1.0 * DEG_S], draws=4, duration=2.0)
    >>> d.rel_3d.shape, bool((d.rel_3d[:, -1] < 0.01).all()), d.onset("INS-3D").tolist()
    ((2, 20), True, [nan, nan])
    >>> bool(np.allclose(d.final_3d[:, 0], d.final_3d[:, 1], rtol=0.01))
    True
    """
    levels = np.logspace(-2, 1, 25) * DEG_S if gyro_bias is None else np.asarray(gyro_bias, float)
    if levels.ndim != 1 or levels.size == 0 or not np.all(np.isfinite(levels)) or (levels <= 0).any():
        raise ParameterError("gyro_bias: expected a 1-D list of finite levels > 0 [rad/s]")
    if not (math.isfinite(duration) and duration > 0 and math.isfinite(rate_hz) and duration * rate_hz >= 2):
        raise ParameterError(f"duration/rate_hz: {duration!r} s at {rate_hz!r} Hz, expected at least 2 samples")
    seed = _study_seed(seed)
    _check_runs(draws, seed, chunk)
    n = int(round(duration * rate_hz)) + 1
    t = np.arange(n) / rate_hz
    keep = np.unique(np.r_[np.arange(keep_every, n, keep_every), n - 1])
    z = np.stack([np.random.Generator(np.random.PCG64(child_seed(seed, d))).standard_normal(6)
                  for d in range(draws)])
    payload = _DriftPayload(levels, z, t, keep, float(spec.accel_bias), G0)
    total = levels.size * draws
    # a run of the strapdown holds about 40 floats per sample (its inputs, attitude matrices, increments,
    # derivative estimates, velocity and position): 43 measured at 58 runs per chunk, 36 at 465
    chunk = max(1, _CHUNK_BYTES // (8 * 48 * n)) if chunk is None else int(chunk)
    prog = Progress(total, "drift study (gyro bias x time)", total > 1000 if progress is None else progress)
    parts = execute(_drift_chunk, payload, chunk_ranges(total, min(chunk, total)), scheduler=scheduler, progress=prog)
    cat = {k: np.concatenate([p[k] for p in parts]).reshape(levels.size, draws, *parts[0][k].shape[1:])
           for k in parts[0]}
    return DriftMap(
        gyro_bias=levels, time=t[keep],
        rel_3d=np.median(cat["rel_3d"], axis=1), rel_2d=np.median(cat["rel_2d"], axis=1),
        p90_3d=np.percentile(cat["rel_3d"], 90, axis=1), p90_2d=np.percentile(cat["rel_2d"], 90, axis=1),
        final_3d=np.median(cat["end_3d"], axis=1), final_2d=np.median(cat["end_2d"], axis=1),
        accel_bias=float(spec.accel_bias), draws=int(draws), seed=int(seed),
        backends={"strapdown": _mechanizations()[2], "closed form": _closed_form()[1]})


# ----------------------------------------------------------------------------- the pages' studies

#: Two-sided 99 % normal quantile used for the Monte Carlo confidence bounds.
Z99 = 2.5758293035489004

#: Assumed per-run gain spread and motion mismatch (fractions) when no field gain training is available.
ASSUMED_SPREAD = 0.05
ASSUMED_MISMATCH = 0.02

#: Significant digits of the field's per-run gain spread and mismatch when they set a gain scenario: the
#: field evaluation differs from machine to machine by up to a few 1e-11 relative, which a study would
#: otherwise carry into every per-run error (and its digest); a step of 1e-6 is crossed by such a
#: difference with a chance of about 1e-5, and no page reads either figure to more than six digits.
FIELD_GAIN_DIGITS = 6

#: Training-run counts of the gain-training study.
TRAINING_KS = (1, 2, 3, 5, 10, 20, 50)


def _field_gain_spread(source, tables=None):
    """(spread, mismatch, note) of the per-run training gains of a dataset, or (None, None, note)."""
    if source is None or getattr(source, "root", None) is None:
        return None, None, "no dataset configured"
    try:
        from . import evaluate  # noqa: F401
        fn = getattr(evaluate, "training_gain_spread")
    except (ImportError, AttributeError):
        return None, None, ("the per-run gain training of the field pipeline (steps.py / evaluate.py) "
                            "is not available in this build")
    from .fetch import dataset_identity

    spread, mismatch = fn(source, tables)
    name = dataset_identity(source.root, synthetic=getattr(source, "synthetic", False),
                            seed=getattr(source, "seed", None)).text
    return (round_significant(spread, FIELD_GAIN_DIGITS), round_significant(mismatch, FIELD_GAIN_DIGITS),
            f"per-run training gains of the {name}")


def final_statistics(result: StudyResult) -> dict:
    """Statistics of the final horizontal error of each method, primary gain scenario.

    Parameters
    ----------
    result : StudyResult

    Returns
    -------
    dict
        Method name (:data:`METHODS`) -> :func:`summarize` of its final
        errors [m] (None for the INS methods when ``config.ins`` is False).

    Examples
    --------
    >>> r = run_study(20, 0, StudyConfig(training_runs=20))
    >>> sorted(final_statistics(r)), sorted(final_statistics(r)["MoRPI-G"])
    (['INS-2D', 'INS-3D', 'MoRPI-A', 'MoRPI-G'], ['mean', 'median', 'p95', 'std'])
    """
    g0 = result.config.gains[0].label
    out = {m: (summarize(result.column(m)) if result.config.ins else None) for m in METHODS[:2]}
    out.update({m: summarize(result.column(f"{m}[{g0}]")) for m in METHODS[2:]})
    return out


def distance_law_check(result: StudyResult) -> list:
    """Check the MoRPI distance law ``ds = dG D`` on a study's own gain draws.

    A Weinberg gain off by the fraction dG scales every step, so the distance
    error of a run is ``dG D`` plus what the sensor noise adds to the peak
    amplitudes. Per gain scenario and MoRPI method, the residual
    ``x_i - dG_i D`` of the simulated distance errors x_i must have a mean
    within ``Z99 * std / sqrt(N)`` of zero (a two-sided 99 % test).

    Parameters
    ----------
    result : StudyResult

    Returns
    -------
    list of dict
        One per gain scenario, with keys ``label``, ``dG_mean``, ``dG_std``,
        ``analytic_mean`` (``mean_i(dG_i) D`` [m]), ``analytic_expected``
        (``dG_mean D``), ``analytic_std_gain_only`` and, for ``"MoRPI-A"`` and
        ``"MoRPI-G"``, a dict with ``mc_mean``, ``mc_std``, ``residual_mean``,
        ``residual_std``, ``bound`` [m] and ``within`` (bool).

    The reference gain's own training error is not in the bound: it needs a
    training set whose mean gain is known well (the default 4000 runs; the
    error of a 50-run set's mean is about as large as the bound).

    Examples
    --------
    >>> r = run_study(200, 1, StudyConfig(ins=False, gains=(GainError("dG = 5 %", 0.05, 0.01),)))
    >>> row = distance_law_check(r)[0]
    >>> row["label"], row["MoRPI-A"]["within"], row["MoRPI-G"]["within"]
    ('dG = 5 %', True, True)
    """
    rows = []
    N = result.runs
    D = result.distance
    for s_i, g in enumerate(result.config.gains):
        ds = result.dG[:, s_i] * D
        row = {"label": g.label, "dG_mean": g.mean, "dG_std": g.std,
               "analytic_mean": float(ds.mean()), "analytic_expected": g.mean * D,
               "analytic_std_gain_only": float(ds.std(ddof=1)) if N > 1 else 0.0}
        for m, name in enumerate(METHODS[2:]):
            x = result.distance_error[:, s_i, m]
            res = x - ds
            sd = float(res.std(ddof=1)) if N > 1 else float("inf")
            half = Z99 * sd / math.sqrt(N)
            row[name] = {"mc_mean": float(x.mean()), "mc_std": float(x.std(ddof=1)) if N > 1 else 0.0,
                         "residual_mean": float(res.mean()), "residual_std": sd, "bound": half,
                         "within": bool(abs(res.mean()) <= half)}
        rows.append(row)
    return rows


def study_config_json(cfg: StudyConfig) -> dict:
    """A study's configuration as its JSON shows it: sensor, motion, calibration, bias and noise sigmas, gains.

    Parameters
    ----------
    cfg : StudyConfig
        The study's configuration.

    Returns
    -------
    dict
        JSON values; sigmas in SI units (noise as the per-sample sigma at the study's rate).
    """
    sa, sg = cfg.bias_sigmas()
    length, speed, duration = cfg.motion()
    return {"sensor": cfg.spec.name, "duration_s": duration, "rate_hz": cfg.rate_hz, "length_m": length,
            "speed_mps": speed, "ins_path": cfg.ins_path, "period_m": cfg.period_m, "amplitude_m": cfg.amplitude_m, "calibration": cfg.calibration,
            "cal_seconds": cfg.cal_seconds, "accel_bias_sigma_mps2": sa, "gyro_bias_sigma_radps": sg,
            "accel_noise_sigma_mps2": cfg.spec.accel_noise * math.sqrt(cfg.rate_hz),
            "gyro_noise_sigma_radps": cfg.spec.gyro_noise * math.sqrt(cfg.rate_hz),
            "gains": [{"label": g.label, "mean": g.mean, "std": g.std} for g in cfg.gains]}


# ----------------------------------------------------------------------------- what a page costs

#: The cost model of :func:`gain_error_page` run by ``morpi montecarlo`` (whole command, one thread), from
#: ``benchmarks/montecarlo_cost.py``: every shape of path run as the whole command at two run counts on a
#: 2-core machine shared with other work, CPU seconds read from the child process. With n samples per run
#: (duration x 100 Hz) and K steps per run:
#:
#: - per run, ``RUN_SECONDS . (n, n^2, K n)`` [s] (a chunk holds fewer runs the longer they are, and each
#:   chunk reduces every kept epoch and loops over the steps);
#: - once, ``FIXED_SECONDS . (1, n, n^2, K)`` [s]: the interpreter and imports, the path, the noisy
#:   training runs of the reference gains, the page and its figures;
#: - memory, ``FIXED_BYTES . (1, n, n^2, K)`` [bytes] plus ``RUN_BYTES`` a run (its per-run results,
#:   measured at 1,000,000 runs of 15 s: 0.83 GB peak over a 0.19 GB base) and
#:   ``CHUNK_SAMPLE_BYTES`` a sample of each run a ``chunk`` holds beyond the default one;
#: - with a dataset, ``FIELD_SECONDS`` and ``FIELD_BYTES`` more (the gains trained on the recordings).
#:
#: Measured (CPU seconds, load average 6 on the 2 cores): 10,000 runs of 15 s took 6.5 s; 4000 of 60 s,
#: 10.3 s; 400 of 300 s, 13.7 s; 240 of 600 s, 25.7 s (0.79 GB); 80 of 600 s at 10 m/s (5990 steps),
#: 32.3 s (1.28 GB); the fit gives each of the 16 points within 8 % (the per-run slopes within 25 %).
#: A chunk of 4000 runs of 15 s peaked at 0.81 GB against 0.24 GB in the default chunks of 465 runs, and
#: one of 1000 runs of 60 s at 0.83 GB against 0.26 GB (chunks of 116): 107 bytes a sample of a run.
RUN_SECONDS = (1.91e-7, 1.2e-11, 1.45e-10)
FIXED_SECONDS = (3.16, 8.32e-5, 1.02e-9, 2.0e-3)
FIXED_BYTES = (2.55e8, 815.0, 0.13, 8.43e4)
RUN_BYTES = 0.63e3
CHUNK_SAMPLE_BYTES = 107.0
FIELD_SECONDS, FIELD_BYTES = 5.3, 0.17e9


@dataclass(frozen=True)
class PageCost:
    """The estimated cost of a gain-error page (:func:`page_cost`).

    Attributes
    ----------
    runs : int
        Monte Carlo runs.
    duration : float
        Time of one run [s].
    samples : int
        Samples of one run.
    steps : int
        Steps of one run (about the path length over the period).
    seconds : float
        Estimated time of ``morpi montecarlo`` on one core of the measured machine [s].
    bytes : float
        Estimated peak memory [bytes].
    """

    runs: int
    duration: float
    samples: int
    steps: int
    seconds: float
    bytes: float


def page_cost(runs: int, *, duration: float | None = None, speed_mps: float | None = None, chunk: int | None = None,
              field: bool = False) -> PageCost:
    """Estimate the time and memory of ``morpi montecarlo`` before running it.

    From the run count, the samples and steps of one run and the measured
    constants above (:data:`RUN_SECONDS`, :data:`FIXED_SECONDS`,
    :data:`FIXED_BYTES`, :data:`RUN_BYTES`, ...). The time is for one core
    of the machine they were measured on, with no other work; a busy machine
    takes longer.

    Parameters
    ----------
    runs : int
        Monte Carlo runs (>= 1).
    duration, speed_mps : float, optional
        The path's shape, as in :func:`gain_error_page`.
    chunk : int, optional
        Runs per batch (default: as many as fit a 32 MiB noise block); a larger one takes more memory.
    field : bool
        Whether a dataset is configured (the gains are then trained on its recordings).

    Returns
    -------
    PageCost

    Raises
    ------
    ParameterError
        A bad run count, chunk or path shape (as :func:`gain_error_page` raises it).

    Examples
    --------
    The cost grows with the runs and, faster than linearly, with their duration:

    >>> short, long = page_cost(100_000), page_cost(100_000, duration=60.0)
    >>> short.samples, long.samples, bool(long.seconds > 4 * short.seconds > 0)
    (1501, 6001, True)
    """
    _check_runs(runs, 0, chunk)
    cfg = StudyConfig(duration=duration, speed_mps=speed_mps)
    cfg.validate()
    length, _, T = cfg.motion()
    n = _samples(T, cfg.rate_hz)
    k = max(1, math.ceil(length / cfg.period_m) - 1)
    terms = (1.0, float(n), float(n) * n, float(k))
    seconds = runs * sum(c * t for c, t in zip(RUN_SECONDS, (float(n), float(n) * n, float(k) * n)))
    seconds += sum(c * t for c, t in zip(FIXED_SECONDS, terms))
    nbytes = sum(c * t for c, t in zip(FIXED_BYTES, terms)) + runs * RUN_BYTES
    default = min(_default_chunk(n), runs)
    if chunk is not None and min(chunk, runs) > default:
        nbytes += (min(chunk, runs) - default) * n * CHUNK_SAMPLE_BYTES
    if field:
        seconds, nbytes = seconds + FIELD_SECONDS, nbytes + FIELD_BYTES
    return PageCost(runs=int(runs), duration=T, samples=n, steps=k, seconds=seconds, bytes=nbytes)


@dataclass(frozen=True)
class GainErrorPage:
    """Every study of the gain-error Monte Carlo page, from one pass over the draws.

    Attributes
    ----------
    runs, seed : int
    calibrated : StudyResult
        After a zero-order calibration on 3 s of rest (the paper's GAC baselines).
    raw : StudyResult
        With the full datasheet turn-on biases (its final errors; run without
        curves: ``rms`` and ``bands`` None).
    training : TrainingStudy
        The gain from k training runs.
    checks : list of dict
        :func:`distance_law_check` of `calibrated`.
    spread, mismatch : float
        Per-run gain spread and motion mismatch of the training scenario (fractions).
    spread_note : str
        Where they come from.
    assumed : bool
        True when they are :data:`ASSUMED_SPREAD` and :data:`ASSUMED_MISMATCH`.
    synthetic : bool
        Whether the dataset they come from is synthetic.
    """

    runs: int
    seed: int
    calibrated: StudyResult
    raw: StudyResult
    training: TrainingStudy
    checks: list
    spread: float
    mismatch: float
    spread_note: str
    assumed: bool
    synthetic: bool = False


def gain_error_page(*, runs: int, seed: int, chunk=None, scheduler=None, source=None, tables=None,
                    duration: float | None = None, speed_mps: float | None = None) -> GainErrorPage:
    """Compute the gain-error Monte Carlo section.

    Two studies with the same seed: the primary one after a zero-order
    calibration on 3 s of rest (the paper's GAC baselines; MoRPI does not use
    the accelerometer bias), and one with the full datasheet turn-on biases.
    Gain scenarios: 5 % and 10 % (the paper) and the spread of per-run training
    gains (from the dataset when the field gain training is available,
    otherwise an assumed value, stated on the page). Then the gain-training
    study over k training runs. `tables` (an ``evaluate.TablesResult`` of
    ``source.root``) gives the trained gains when already computed;
    `duration` and `speed_mps` shape the sine path as in :class:`StudyConfig`.

    Parameters
    ----------
    runs : int
        Monte Carlo runs per study.
    seed : int or numpy.random.Generator
        Study seed, as in :func:`run_study`.
    chunk, scheduler
        As in :func:`run_study`.
    source : reporting.DataSource, optional
        The dataset whose per-run training gains give the spread scenario
        (None: the assumed spread and mismatch).
    tables : evaluate.TablesResult, optional
        Already computed tables of ``source.root``.
    duration : float, optional
        Motion time [s].
    speed_mps : float, optional
        Cruise speed [m/s].

    Returns
    -------
    GainErrorPage

    Raises
    ------
    ParameterError
        A bad run count, seed, chunk or path shape.

    Examples
    --------
    >>> page = gain_error_page(runs=10, seed=0)
    >>> page.assumed, page.spread == ASSUMED_SPREAD, page.calibrated.config.calibration, page.raw.config.calibration
    (True, True, 'GAC', 'RD')
    >>> [row["label"] for row in page.checks]
    ['dG = 5 %', 'dG = 10 %', 'training spread']
    """
    seed = _study_seed(seed)
    _check_runs(runs, seed, chunk)
    spread, mismatch, spread_note = _field_gain_spread(source, tables)
    assumed = spread is None
    if assumed:
        spread, mismatch = ASSUMED_SPREAD, ASSUMED_MISMATCH
    gains = (GainError("dG = 5 %", 0.05), GainError("dG = 10 %", 0.10),
             GainError("training spread", mismatch, spread))
    cal = StudyConfig(gains=gains, calibration="GAC", duration=duration, speed_mps=speed_mps)
    cal.validate()
    raw = replace(cal, calibration="RD")
    # one pass over the random numbers: every study of the page is a set of columns of the same draws
    tcfg = training_configs(TRAINING_KS, mismatch=mismatch, spread=spread, config=cal)
    # curves for the calibrated study only: the page shows the raw study's and the training studies'
    # final and distance errors
    r, rr, *tres = run_studies(runs, seed, (cal, raw, *tcfg), chunk=chunk, scheduler=scheduler,
                               curves=(True, False) + (False,) * len(tcfg))
    tr = training_summary(TRAINING_KS, tres, mismatch=mismatch, spread=spread)
    return GainErrorPage(runs=runs, seed=seed, calibrated=r, raw=rr, training=tr, checks=distance_law_check(r),
                         spread=spread, mismatch=mismatch, spread_note=spread_note, assumed=assumed,
                         synthetic=bool(getattr(source, "synthetic", False)))


def _loglog_slope(x, y):
    x, y = np.log(np.asarray(x, float)), np.log(np.asarray(y, float))
    if x.size < 2:
        return float("nan")
    return float(np.polyfit(x, y, 1)[0])


def _drift_levels(spec: SensorSpec) -> np.ndarray:
    """Gyro bias levels of the drift page [rad/s]: 25 log-spaced from 0.01 to 10 deg/s and the datasheet's."""
    return np.union1d(np.logspace(-2, 1, 25), [spec.gyro_bias / DEG_S]) * DEG_S


@dataclass(frozen=True)
class DriftPage:
    """The drift page's study: the map and how fast the two models part.

    Attributes
    ----------
    spec : SensorSpec
    drift : DriftMap
    growth : dict
        Per kind (``"INS-3D"``, ``"INS-2D"``): log-log slopes of the disagreement in
        the bias (at the end) and in time (near 1 %).
    onset : dict
        ``"<kind>_<level>pct"`` -> first time each bias level passes the level [s].
    """

    spec: SensorSpec
    drift: DriftMap
    growth: dict
    onset: dict


def drift_page(*, seed: int = DRIFT_SEED, scheduler=None, spec: SensorSpec = MPU6500) -> DriftPage:
    """Compute the closed-form vs strapdown drift section.

    Runs :func:`drift_map` on 25 log-spaced gyro bias levels from 0.01 to
    10 deg/s plus the datasheet's (32 draws, 15 s); it takes seconds, so
    there is no example here.

    Parameters
    ----------
    seed : int or numpy.random.Generator, optional
        Seed of the bias draws (default :data:`DRIFT_SEED`, the seed of
        ``morpi drift``), as in :func:`drift_map`.
    scheduler : str or distributed.Client, optional
        As in :func:`run_study`.
    spec : SensorSpec
        Accelerometer bias sigma and the extra datasheet gyro bias level.

    Returns
    -------
    DriftPage
        The map, the log-log growth slopes per kind (``slope_in_bias_at_end``,
        ``slope_in_time``, ``slope_in_time_bias_deg_s``) and the onset times
        at 1 % and 10 % (keys ``INS-3D_1pct``, ``INS-3D_10pct``, ``INS-2D_1pct``, ``INS-2D_10pct``).
    """
    d = drift_map(_drift_levels(spec), spec=spec, seed=seed, scheduler=scheduler)
    bdeg = d.gyro_bias / DEG_S
    # growth: slope of log disagreement in log time (15 s row region) and in log bias (at 15 s)
    growth = {}
    for kind, rel in (("INS-3D", d.rel_3d), ("INS-2D", d.rel_2d)):
        end = rel[:, -1]
        sel = (end > 1e-4) & (end < 0.05)
        i_mid = choose(np.abs(np.log(np.where(end > 0, end, 1e-30)) - np.log(0.01)))   # the first of ties
        row = rel[i_mid]
        tsel = (d.time >= 2.0) & (row > 1e-5) & (row < 0.05)
        growth[kind] = {"slope_in_bias_at_end": _loglog_slope(d.gyro_bias[sel], end[sel]),
                        "slope_in_time": _loglog_slope(d.time[tsel], row[tsel]),
                        "slope_in_time_bias_deg_s": float(bdeg[i_mid])}
    onset = {f"{k}_{int(100 * lv)}pct": d.onset(k, lv) for k in ("INS-3D", "INS-2D") for lv in (0.01, 0.1)}
    return DriftPage(spec=spec, drift=d, growth=growth, onset=onset)
