"""Monte Carlo configuration: the study's sensor, motion and gains, its result, its seeds and digest."""
from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, field, replace

import numpy as np

from ..deprecation import renamed_attribute, renamed_keywords
from ..errors import ParameterError
from ..units import MPU6500, SensorSpec

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
#: The duration of :data:`DEFAULT_LENGTH_M`'s route [s].
DEFAULT_DURATION_S = 15.0

#: Per-run numbers drawn before the noise block: 3 accelerometer biases, 3 gyro biases, 1 gain.
N_HEAD = 7

#: Spawn key of the noisy training runs that fix the reference Weinberg gains: their draws come
#: from the study seed's child ``SeedSequence(seed, spawn_key=(TRAINING_KEY,))``. Run i of a study
#: uses the key ``(i,)``, and a study has at most ``TRAINING_KEY`` runs, so no run shares it.
TRAINING_KEY = 2**32 - 1

#: Default seed of the drift study (``morpi drift --seed``, :func:`drift_page`, :func:`drift_map`).
DRIFT_SEED = 0

#: Memory budget of one chunk's noise block [bytes]; sets the default chunk size.
CHUNK_BYTES = 32 * 2**20

#: Resolution of the histograms behind :attr:`StudyResult.bands`: log-spaced bins
#: from :data:`BAND_RANGE_M` [0] to [1] metres (plus one bin from 0 to the first edge).
BAND_BINS_PER_DECADE = 40
#: The range of the band histograms [m]: (first edge, last edge).
BAND_RANGE_M = (1e-6, 1e4)
BAND_EDGES = np.concatenate([[0.0], np.logspace(math.log10(BAND_RANGE_M[0]), math.log10(BAND_RANGE_M[1]),
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
    motion is fixed by any two of `duration_s`, `length_m` and `speed_mps`; the
    third follows from ``duration_s = length_m / speed_mps + RAMP_S``. Left
    unset: the paper's 6.3 m in 15 s; a `duration_s` or `length_m` alone keeps
    the paper's cruise speed for the period (:func:`morpi_filters.simulate.paper_speed`).
    :meth:`motion` gives the three values; a study's result holds its config
    with all three filled in.

    Attributes
    ----------
    spec : SensorSpec
        IMU error figures (biases 1 sigma per axis, noise densities), for
        example :meth:`~morpi_filters.units.SensorSpec.from_datasheet`.
    duration_s : float, optional
        Time from the start of the motion to the stop [s]: the run lasts this long.
    length_m : float, optional
        Start-to-end distance of the path along its centreline [m].
    speed_mps : float, optional
        Cruise speed along the centreline [m/s].
    rate_hz : float
        Sampling rate [Hz]; the noise standard deviation is ``density * sqrt(rate_hz)``.
    p2p_m : float
        Peak-to-peak distance (period length) of the sine path [m].
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
        zero-order calibration on `cal_window_s` of rest leaves a residual bias
        equal to the mean of the white noise over that window,
        ``density / sqrt(cal_window_s)`` per axis (drawn from the same per-run
        bias numbers).
    cal_window_s : float
        Length of the stationary calibration window [s].

    Examples
    --------
    >>> cfg = StudyConfig(duration_s=20.0, p2p_m=1.0)
    >>> length, speed, duration = cfg.motion()
    >>> round(length, 3), round(speed, 4), duration
    (8.867, 0.4667, 20.0)
    """

    spec: SensorSpec = MPU6500
    duration_s: float | None = None
    rate_hz: float = 100.0
    length_m: float | None = None
    p2p_m: float = 1.0
    amplitude_m: float = 0.1
    gains: tuple = (GainError("dG = 5 %", 0.05), GainError("dG = 10 %", 0.10))
    keep_every: int = 10
    ins: bool = True
    training_runs: int = 4000
    calibration: str = "RD"
    cal_window_s: float = 3.0
    speed_mps: float | None = None
    ins_path: str = "sine"

    def motion(self) -> tuple:
        """(length_m, speed_mps, duration_s) of the path [m, m/s, s], from the two that fix it.

        Returns
        -------
        tuple of float
            ``(length_m, speed_mps, duration_s)`` with ``duration_s = length_m /
            speed_mps + RAMP_S``.

        Raises
        ------
        ParameterError
            When all three are given and disagree, or the motion is impossible
            (shorter than its two ramps).
        """
        given = {k: getattr(self, k) for k in ("duration_s", "length_m", "speed_mps") if getattr(self, k) is not None}
        for k, v in given.items():
            if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) \
                    or not (math.isfinite(v) and v > 0):
                raise ParameterError(f"StudyConfig.{k}: {v!r}, expected a finite number > 0")
        T, L, v = (None if given.get(k) is None else float(given[k]) for k in ("duration_s", "length_m", "speed_mps"))
        if T is None and L is None:
            L = DEFAULT_LENGTH_M
            if v is None:
                T = DEFAULT_DURATION_S
        if v is None and (T is None or L is None):
            from ..simulate import paper_speed

            v = paper_speed(self.p2p_m)
        if T is None:
            T = L / v + RAMP_S
        elif L is None:
            L = v * (T - RAMP_S)
        elif v is None:
            v = L / (T - RAMP_S) if T > RAMP_S else math.inf
        elif abs(L / v + RAMP_S - T) > 1e-9 * T:
            raise ParameterError(f"StudyConfig: duration_s {T:g} s, length_m {L:g} m and speed_mps {v:g} m/s "
                                 f"disagree (duration_s = length_m / speed_mps + {RAMP_S:g} s ramps); "
                                 "expected at most two of them")
        if not (T >= 2 * RAMP_S and L / v >= RAMP_S):
            raise ParameterError(f"StudyConfig.duration_s: {T:g} s for {L:g} m; expected at least {2 * RAMP_S:g} s "
                                 f"(the path starts and stops with {RAMP_S:g} s ramps)")
        return L, v, T

    def resolved(self) -> "StudyConfig":
        """This config with `duration_s`, `length_m` and `speed_mps` all filled in (see :meth:`motion`).

        Returns
        -------
        StudyConfig
            A copy; the other fields are unchanged.

        Examples
        --------
        >>> c = StudyConfig().resolved()                    # the paper's 6.3 m in 15 s
        >>> c.length_m, round(c.speed_mps, 12), c.duration_s  # 6.3 m / (15 s - 1 s of ramps)
        (6.3, 0.45, 15.0)
        """
        L, v, T = self.motion()
        return replace(self, length_m=L, speed_mps=v, duration_s=T)

    def bias_sigmas(self) -> tuple:
        """(accelerometer, gyro) bias 1 sigma per axis after calibration [m/s^2, rad/s].

        Returns
        -------
        tuple of float
            ``"RD"``: the datasheet turn-on biases; ``"GC"``: the gyro one
            replaced by ``gyro_noise / sqrt(cal_window_s)``; ``"GAC"``: both
            replaced by ``noise / sqrt(cal_window_s)``.

        Examples
        --------
        >>> sa, sg = StudyConfig(calibration="GAC", cal_window_s=4.0).bias_sigmas()
        >>> sa == MPU6500.accel_noise / 2, sg == MPU6500.gyro_noise / 2
        (True, True)
        """
        ra = self.spec.accel_noise / math.sqrt(self.cal_window_s)
        rg = self.spec.gyro_noise / math.sqrt(self.cal_window_s)
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
        for name in ("rate_hz", "p2p_m", "amplitude_m"):
            v = getattr(self, name)
            if isinstance(v, bool) or not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ParameterError(f"StudyConfig.{name}: {v!r}, expected a finite number > 0")
        length, _, duration = self.motion()
        if duration * self.rate_hz < 2:
            raise ParameterError(f"StudyConfig.duration_s: {duration} s at {self.rate_hz} Hz gives fewer than 2 samples")
        if 3 * self.p2p_m > length:
            raise ParameterError(f"StudyConfig.length_m: {length:g} m holds fewer than 3 periods of "
                                 f"{self.p2p_m} m (one tapered period at each end plus one step)")
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
        if not (math.isfinite(self.cal_window_s) and self.cal_window_s > 0):
            raise ParameterError(f"StudyConfig.cal_window_s: {self.cal_window_s!r}, expected a finite number > 0")
        if not (isinstance(self.training_runs, int) and self.training_runs >= 2):
            raise ParameterError(f"StudyConfig.training_runs: {self.training_runs!r}, expected a whole number >= 2")


StudyConfig.__init__ = renamed_keywords(period_m="p2p_m", duration="duration_s", cal_seconds="cal_window_s")(
    StudyConfig.__init__)
StudyConfig.period_m = renamed_attribute("StudyConfig", "period_m", "p2p_m")
StudyConfig.duration = renamed_attribute("StudyConfig", "duration", "duration_s")
StudyConfig.cal_seconds = renamed_attribute("StudyConfig", "cal_seconds", "cal_window_s")


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
