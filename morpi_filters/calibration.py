"""Initial rest detection and zero-order sensor calibration (RD, GC, GAC).

The MoRPI paper [1] calibrates every recording on "the first three seconds",
when the robot stands still: the gyro bias is the mean angular rate (GC), and
with the phone assumed level the accelerometer bias is the mean specific force
minus local gravity on the z axis (GAC). Several field recordings start moving
inside their first 3 s, so this module finds the rest period instead of
assuming it (:func:`detect_rest`), then calibrates over it (:func:`calibrate`).

Rest detection
--------------
The detector works on the real, non-uniform time stamps:

1. The white-noise level of each gyro and accelerometer axis is estimated from
   the first differences in blocks of ``window_s`` over the first ``noise_s``
   seconds (a trimmed standard deviation, :func:`noise_sigma`; differences
   remove the bias and slow trends), taking the lower quartile of the blocks
   so that early motion or a disturbance does not inflate it, and never below
   the datasheet white noise of the recording's IMU over the Nyquist band
   when the recording carries its figures (``Recording.imu``).
2. A centred moving window of ``window_s`` seconds (time based, so the number
   of samples per window follows the real sampling) gives a moving standard
   deviation and a moving mean per axis.
3. A sample is flagged when a gyro axis's moving standard deviation exceeds
   ``k_std`` noise sigmas, or its moving mean departs from the rest level (the
   median of the quietest block of step 1) by more than ``k_dev`` sigmas, or
   an accelerometer axis's moving standard deviation exceeds ``k_std`` sigmas
   and ``accel_floor``. The noise sigmas are measured on the recording
   itself, so a recording that never stands still measures its motion's
   vibration as its noise; the spread thresholds are therefore also bounded
   absolutely, by what a still IMU shows (:func:`still_bound`:
   :data:`STILL_NOISE_FACTOR` times the IMU's white noise over the Nyquist
   band, from its noise densities: the phone's, a given
   :class:`~morpi_filters.units.SensorSpec`, or :data:`DEFAULT_IMU`), the
   accelerometer's never below ``accel_floor``. The floor exists
   because the phones' accelerometer channels are low-pass filtered and
   settle during the first seconds (slow drifts of up to ~2 m/s^2 on an S6,
   ~0.2 m/s^2 on an S8, with moving standard deviations up to ~0.05 m/s^2
   after the first instants, in the field recordings); for the same reason
   the accelerometer level is not compared with its initial median. The gyro
   channels are not filtered and carry most of the detection.
4. Flagged runs closer than one window are merged. The motion is the first
   run lasting ``sustain_s`` or more and at least a quarter of the longest
   run (the drive itself lasts tens of seconds, handling before it a few
   seconds at most in the field recordings); shorter runs before it are
   disturbances (in the field recordings, mostly a fraction of a second of
   jitter from the tap that starts the recording) and the rest window starts
   ``guard_s`` after the last of them. A disturbance is followed by rest: a
   recording that ends inside a shorter run, with no motion before it, is
   too short to tell which it is, and is refused (``DataError``, saying how
   long it would have to be).
5. The onset is refined from the start of the motion run (up to half a window
   early) to the first sample whose gyro reading departs from the rest mean by
   more than ``k_dev`` sigmas (a run flagged from the first sample on has no
   rest before it: the motion is under way from there). The rest window ends
   ``guard_s`` before the onset and lasts at most ``max_window_s`` (the
   paper's 3 s).

No rest
-------
A recording whose motion leaves fewer than ``min_samples`` samples of rest
before it (one that moves from its first sample) has no initial rest:
:func:`detect_rest` raises :class:`NoRestError` (a ``DataError``) saying how
far the sensors spread against the still bound, and :func:`calibrate`
computes GC and GAC only over a rest window. Raw data (RD) needs none.

Gravity
-------
:func:`normal_gravity` is normal gravity on the WGS84 ellipsoid at a
latitude, from Somigliana's closed formula [2]. A dataset's calibrations take
it at the manifest's ``latitude_deg`` (:attr:`morpi_filters.field.FieldData.gravity`;
the shipped MoRPI manifest gives its experiment site's); a direct call of
:func:`calibrate` without ``g_local`` takes standard gravity,
:data:`morpi_filters.units.G0`.

References
----------
- [1] A. Etzion and I. Klein, "MoRPI: Mobile Robot Pure Inertial Navigation",
  IEEE Journal of Indoor and Seamless Positioning and Navigation, 2023
  (sections "Straight Line Trajectory" and "Periodic Motion").
- [2] National Imagery and Mapping Agency, "Department of Defense World
  Geodetic System 1984", NIMA TR8350.2, 3rd ed., 2000, eq. (4-1) and
  Table 3.4 (normal gravity on the ellipsoid, Somigliana's formula), and
  eq. (4-3) (its height correction).
"""
from __future__ import annotations

import math
import warnings
from dataclasses import asdict, dataclass, replace

import numpy as np

from .choice import tie_margin
from .dataset import Recording
from .deprecation import renamed_attribute, renamed_keywords
from .errors import DataError, MorpiError, ParameterError
from .units import G0, MPU6500, SensorSpec

__all__ = [
    "CALIBRATIONS", "normal_gravity", "RestWindow", "Calibration",
    "RestMeasures", "rest_measures", "detect_rest", "calibrate", "calibrated", "rest_windows_summary", "RestRow",
    "RestSummary", "noise_sigma", "NoRestError", "StillBound", "still_bound", "STILL_NOISE_FACTOR", "DEFAULT_IMU",
]

#: Calibrations: raw data, gyro calibration, gyro and accelerometer calibration.
CALIBRATIONS = ("RD", "GC", "GAC")

# Smallest noise sigmas used by the detector, far below any MEMS noise but above the
# rounding of running sums, for noise-free simulated recordings [rad/s], [m/s^2].
_GYRO_SIGMA_MIN = 1e-6
_ACCEL_SIGMA_MIN = 1e-5

# WGS84 constants, NIMA TR8350.2 Table 3.1 and 3.4.
_WGS84_A = 6378137.0                      # semi-major axis [m]
_WGS84_F = 1.0 / 298.257223563            # flattening
_WGS84_GM = 3.986004418e14                # gravitational constant [m^3/s^2]
_WGS84_OMEGA = 7292115.0e-11              # earth rotation rate [rad/s]
_WGS84_GAMMA_E = 9.7803253359             # normal gravity at the equator [m/s^2]
_WGS84_K = 0.00193185265241               # Somigliana's constant
_WGS84_E2 = 6.69437999014e-3              # first eccentricity squared


def normal_gravity(latitude_deg: float, height_m: float = 0.0) -> float:
    """Normal gravity of the WGS84 ellipsoid [m/s^2].

    Somigliana's closed formula on the ellipsoid ([2] eq. 4-1)::

        gamma = gamma_e (1 + k sin^2 phi) / sqrt(1 - e^2 sin^2 phi)

    and, above it, the second-order height correction of [2] eq. (4-3)::

        gamma_h = gamma (1 - 2/a (1 + f + m - 2 f sin^2 phi) h + 3 h^2 / a^2)

    with ``m = omega^2 a^2 b / GM``.

    Parameters
    ----------
    latitude_deg : float
        Geodetic latitude [deg], in [-90, 90].
    height_m : float, optional
        Height above the ellipsoid [m] (default 0).

    Returns
    -------
    float
        Normal gravity [m/s^2].

    Raises
    ------
    ParameterError
        For a latitude outside [-90, 90] degrees or not finite.

    Examples
    --------
    >>> round(normal_gravity(0.0), 4), round(normal_gravity(90.0), 4)   # WGS84: equator and pole
    (9.7803, 9.8322)
    """
    if not (-90.0 <= latitude_deg <= 90.0) or not math.isfinite(latitude_deg):
        raise ParameterError(f"latitude_deg={latitude_deg!r}: expected a latitude in [-90, 90] degrees")
    s2 = math.sin(math.radians(latitude_deg)) ** 2
    gamma = _WGS84_GAMMA_E * (1.0 + _WGS84_K * s2) / math.sqrt(1.0 - _WGS84_E2 * s2)
    if height_m == 0.0:
        return gamma
    a, f = _WGS84_A, _WGS84_F
    b = a * (1.0 - f)
    m = _WGS84_OMEGA ** 2 * a ** 2 * b / _WGS84_GM
    return gamma * (1.0 - 2.0 / a * (1.0 + f + m - 2.0 * f * s2) * height_m + 3.0 * height_m ** 2 / a ** 2)




#: How far above its IMU's white noise a still robot's readings may spread, per axis: the bound of
#: :func:`still_bound` is this factor times the noise density over the Nyquist band. It covers the
#: vibration of a robot standing with its motors on, the quantization of the phones' gyros and a noise
#: above the datasheet's. Set on the ``train`` rests of the MoRPI recordings (40 runs): inside each run's
#: detected rest window the largest moving standard deviation (over the detector's 0.25 s window, every
#: window lying inside the rest) is at most 4.9 times the datasheet noise on a gyro axis
#: (s8/short_distance_1.5p2p/train/34) and 4.2 times on an accelerometer axis
#: (s8/short_distance/train/21), so 10 leaves a margin of two; and the noise the detector measures on
#: those runs is at most 1.9 times the datasheet's, so its relative threshold (``k_std`` = 4 times that,
#: 7.6) stays below the bound there and the bound moves none of their windows. While the robot drives,
#: the gyro's moving standard deviation (largest axis) is at its median over 70 times the datasheet
#: noise in every train run.
STILL_NOISE_FACTOR = 10.0

#: Noise figures used for an IMU that is not known (a recording without ``imu`` figures, and no spec
#: given): the InvenSense MPU-6500's, as its product specification PS-MPU-6500A-01 gives them
#: (gyro rate noise spectral density 0.01 deg/s/sqrt(Hz), accelerometer noise power spectral density
#: 300 ug/sqrt(Hz)): a common consumer MEMS IMU (the MPU-9250 carries the same sensor), and the noisier
#: of the two IMUs of the MoRPI recordings (:data:`morpi_filters.units.MPU6500`).
DEFAULT_IMU = MPU6500


def _nyquist_sigma(density: float, rate_hz: float) -> float:
    """Standard deviation of white noise of `density` [unit/sqrt(Hz)] sampled at `rate_hz`, over the Nyquist band."""
    return density * math.sqrt(rate_hz / 2.0)


@dataclass(frozen=True)
class StillBound:
    """How far the readings of a still IMU may spread (:func:`still_bound`).

    Attributes
    ----------
    gyro : float
        Largest standard deviation of a gyro axis over the rest detection's
        moving window while the robot stands [rad/s].
    accel : float
        The same for an accelerometer axis [m/s^2].
    basis : str
        What the bound rests on, for messages (an IMU and a factor, or
        ``"given"``).

    Raises
    ------
    ParameterError
        A bound that is not a positive number (``inf``: no bound on that sensor).
    """

    gyro: float
    accel: float
    basis: str = "given"

    def __post_init__(self):
        for key in ("gyro", "accel"):
            v = getattr(self, key)
            try:
                ok = float(v) > 0 and not math.isnan(float(v))
            except (TypeError, ValueError):
                ok = False
            if not ok:
                unit = "rad/s" if key == "gyro" else "m/s^2"
                raise ParameterError(f"StillBound: {key}={v!r}, expected a positive standard deviation [{unit}]")


def still_bound(rec: Recording, bound: SensorSpec | StillBound | None = None, *,
                factor: float = STILL_NOISE_FACTOR) -> StillBound:
    """The spread a still IMU's readings stay within, from the IMU's noise densities.

    Per axis, ``factor`` times the white-noise standard deviation over the
    Nyquist band of the recording's sampling rate, ``density * sqrt(rate / 2)``
    (a noise-free spec still gets the detector's smallest sigmas).

    Parameters
    ----------
    rec : Recording
        The recording (its median sampling rate, and its ``imu`` figures
        when `bound` is None).
    bound : SensorSpec or StillBound, optional
        A StillBound is returned as it is; a SensorSpec gives its noise
        densities. Default: the recording's IMU (``rec.imu``), else
        :data:`DEFAULT_IMU`.
    factor : float, optional
        Multiple of the white noise a still robot may show (default
        :data:`STILL_NOISE_FACTOR`).

    Returns
    -------
    StillBound
        Gyro [rad/s] and accelerometer [m/s^2] bounds, and their source.

    Raises
    ------
    ParameterError
        A `bound` of another type, or a `factor` that is not a positive number.
    DataError
        A recording of fewer than two samples (no sampling rate).

    Examples
    --------
    The S8's LSM6DSL (0.004 deg/s/sqrt(Hz), 130 ug/sqrt(Hz)) sampled at 100 Hz:

    >>> from morpi_filters.units import LSM6DSL
    >>> rec = Recording(time=np.arange(300) * 0.01, f=np.zeros((300, 3)), omega=np.zeros((300, 3)), imu=LSM6DSL)
    >>> b = still_bound(rec)
    >>> round(b.gyro, 5), round(b.accel, 4), b.basis
    (0.00494, 0.0901, 'LSM6DSL noise x 10')
    """
    if isinstance(bound, StillBound):
        return bound
    if not (isinstance(factor, (int, float)) and math.isfinite(factor) and factor > 0):
        raise ParameterError(f"factor={factor!r}: expected a positive multiple of the white noise")
    spec = bound if bound is not None else (rec.imu or DEFAULT_IMU)
    if not isinstance(spec, SensorSpec):
        raise ParameterError(f"bound={bound!r}: expected a SensorSpec, a StillBound or None")
    if rec.n < 2:
        raise DataError(f"{rec.source}: {rec.n} sample(s): no sampling rate to bound the noise of")
    rate = rec.rate_hz
    return StillBound(gyro=factor * max(_nyquist_sigma(spec.gyro_noise, rate), _GYRO_SIGMA_MIN),
                      accel=factor * max(_nyquist_sigma(spec.accel_noise, rate), _ACCEL_SIGMA_MIN),
                      basis=f"{spec.name} noise x {factor:g}")


# ----------------------------------------------------------------------------- results

@dataclass(frozen=True)
class RestWindow:
    """The initial rest period of a recording.

    Attributes
    ----------
    start_s, end_s : float
        Time stamps of the first and last sample of the window [s], on the
        recording's own clock (``rec.time[i0]`` and ``rec.time[i1 - 1]``).
    i0, i1 : int
        Sample slice of the window: ``rec.time[i0:i1]``. ``i0`` is 0 unless a
        brief disturbance (a tap on the phone) opens the recording.
    method : str
        ``"full"``: no motion or disturbance before `max_window_s`, the
        window is the first `max_window_s` seconds (the paper's choice);
        ``"detected"``: the window starts after a disturbance and/or ends
        before an early motion, and lasts at least `min_window_s`; ``"short"``: the rest
        before the motion is shorter than `min_window_s` and is used anyway
        (see `note`).
    note : str
        Plain-language account of the decision (empty for ``"full"``).
    motion_s : float or None
        Detected motion onset [s] on the recording's clock, or None when no
        motion was found in the recording.
    """

    start_s: float
    end_s: float
    i0: int
    i1: int
    method: str
    note: str = ""
    motion_s: float | None = None

    @property
    def duration_s(self) -> float:
        """Length of the window, first to last sample [s]."""
        return self.end_s - self.start_s

    @property
    def n(self) -> int:
        """Number of samples in the window."""
        return self.i1 - self.i0


class NoRestError(DataError):
    """A recording without an initial rest: it moves from its first samples (exit status 1, as a DataError).

    Raised by :func:`detect_rest` (and by :func:`calibrate` for GC and GAC,
    which need a rest window). Raw data (RD) needs no rest:
    :class:`morpi_filters.field.FieldData` evaluates such a recording under RD
    only and names it.
    """


@dataclass(frozen=True)
class Calibration:
    """Zero-order sensor biases to remove from a recording.

    Attributes
    ----------
    calibration : str
        ``"RD"``, ``"GC"`` or ``"GAC"`` (see :func:`calibrate`).
    gyro_bias : ndarray, shape (3,)
        Angular-rate bias in body axes [rad/s] (zeros for RD).
    accel_bias : ndarray, shape (3,)
        Specific-force bias in body axes [m/s^2] (zeros for RD and GC).
    window : RestWindow or None
        The rest window the biases were averaged over (None for RD).
    """

    calibration: str
    gyro_bias: np.ndarray
    accel_bias: np.ndarray
    window: RestWindow | None

    def apply(self, rec: Recording) -> Recording:
        """Return a new recording with the biases removed.

        Parameters
        ----------
        rec : Recording
            Any recording (usually the one the biases were estimated on).

        Returns
        -------
        Recording
            Same time stamps and labels; ``f - accel_bias`` and
            ``omega - gyro_bias``. The input is not modified.

        Examples
        --------
        >>> rec = Recording(time=np.arange(3) * 0.01, f=np.tile([0.1, 0.0, 9.9], (3, 1)), omega=np.zeros((3, 3)))
        >>> cal = Calibration("GAC", gyro_bias=np.zeros(3), accel_bias=np.array([0.1, 0.0, 0.1]), window=None)
        >>> cal.apply(rec).f[0].round(12).tolist(), rec.f[0].tolist()
        ([0.0, 0.0, 9.8], [0.1, 0.0, 9.9])
        """
        return replace(rec, time=rec.time.copy(), f=rec.f - self.accel_bias, omega=rec.omega - self.gyro_bias)


StillBound.__init__ = renamed_keywords(source="basis")(StillBound.__init__)
StillBound.source = renamed_attribute("StillBound", "source", "basis")
Calibration.__init__ = renamed_keywords(mode="calibration")(Calibration.__init__)
Calibration.mode = renamed_attribute("Calibration", "mode", "calibration")


def __getattr__(name):
    if name == "MODES":                      # the name of CALIBRATIONS before 0.2, kept for one release
        warnings.warn("calibration.MODES is deprecated; use calibration.CALIBRATIONS", DeprecationWarning, stacklevel=2)
        return CALIBRATIONS
    # the MoRPI site's latitude and gravity, named here before the shipped manifest held them: one release more
    if name in ("SITE_LATITUDE_DEG", "LOCAL_GRAVITY"):
        warnings.warn(f"calibration.{name} is deprecated; use the MoRPI manifest's latitude_deg "
                      "(morpi_filters.resources.morpi_manifest) and normal_gravity", DeprecationWarning, stacklevel=2)
        return 32.8 if name == "SITE_LATITUDE_DEG" else normal_gravity(32.8)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


# ----------------------------------------------------------------------------- detection

def noise_sigma(x: np.ndarray) -> np.ndarray:
    """Robust white-noise standard deviation per column from first differences.

    Parameters
    ----------
    x : ndarray, shape (n, k)
        Samples at rest (a few slow trends or outliers are tolerated).

    Returns
    -------
    ndarray, shape (k,)
        Standard deviation of the first differences over sqrt(2), computed on
        the 90 % of differences closest to their median and rescaled by the
        standard deviation of a normal law truncated at +-1.645 sigma (0.7891),
        so that quantized signals (many zero differences), for which a median
        absolute deviation collapses to zero, are still measured. A difference
        whose deviation lies within the tie margin of the 90 % quantile
        (:func:`morpi_filters.choice.tie_margin`) is kept, so a change of the
        input in its last bits cannot move a difference across the cut. Never below
        the signal's resolution / sqrt(12) (its smallest non-zero step).
        With fewer than three rows: the smallest positive float per column.

    Examples
    --------
    White noise of standard deviation 0.1 on top of a slow drift:

    >>> rng = np.random.default_rng(0)
    >>> x = 0.1 * rng.standard_normal((10000, 2)) + np.linspace(0.0, 5.0, 10000)[:, None]
    >>> noise_sigma(x).round(1).tolist()
    [0.1, 0.1]
    """
    d = np.diff(np.asarray(x, dtype=float), axis=0)
    if d.shape[0] < 2:
        return np.full(x.shape[1], np.finfo(float).tiny)
    dev = np.abs(d - np.median(d, axis=0))
    q90 = np.quantile(dev, 0.9, axis=0)
    keep = dev <= q90 + tie_margin(q90)                  # within the tie band: rounding cannot flip a kept value
    sigma = np.sqrt((np.where(keep, dev, 0.0) ** 2).sum(axis=0) / keep.sum(axis=0)) / 0.7891 / math.sqrt(2.0)
    floor = np.array([np.min(c[c > 0]) if np.any(c > 0) else 0.0 for c in np.abs(d).T]) / math.sqrt(12.0)
    return np.maximum(np.maximum(sigma, floor), np.finfo(float).tiny)


def _block_sigma(t: np.ndarray, x: np.ndarray, span: float, block: float, source: str = "<array>"):
    """Noise sigma and rest level from blocks of `block` seconds within the first `span` seconds.

    Returns the lower quartile over the blocks of :func:`noise_sigma` (shape
    (k,)) and the median of the quietest block (shape (k,)): the compiled loops
    of ``_calibration_loops.block_sigma_loops`` (the blocks of at least five
    samples; the quietest is chosen with the tie tolerance of
    :func:`morpi_filters.choice.choose`). Without a block of five samples,
    :func:`noise_sigma` and the median of the samples up to `span`. A
    non-finite value (or a sum that overflows) is a DataError naming `source`.
    """
    from ._calibration_loops import compiled

    if not (block > 0 and math.isfinite(block) and math.isfinite(span)):
        raise ParameterError(f"block={block!r}, span={span!r}: expected finite lengths, block > 0 [s]")
    t = np.ascontiguousarray(t, dtype=float)
    x = np.ascontiguousarray(x, dtype=float)
    q, med = np.empty(x.shape[1]), np.empty(x.shape[1])
    nb = compiled()["block_sigma_loops"](t, x, float(span), float(block), q, med)
    if nb < 0:
        raise DataError(f"{source}: a value that is not finite (or too large to sum) in the first "
                        f"{max(span, block):g} s")
    if nb == 0:
        stop = max(int(np.searchsorted(t, span, side="right")), 3)
        return noise_sigma(x[:stop]), np.median(x[:stop], axis=0)
    return q, med


def _moving_stats(t: np.ndarray, x: np.ndarray, half: float):
    """Centred time-window mean and std of each column (window [t-half, t+half]): a compiled loop."""
    from ._calibration_loops import compiled

    t = np.array(t, dtype=float, order="C")                   # writable C arrays: one compiled signature
    x = np.array(x, dtype=float, order="C")
    mean, std = np.empty_like(x), np.empty_like(x)
    compiled()["moving_stats"](t, x, float(half), mean, std)
    return mean, std


@dataclass(frozen=True)
class RestMeasures:
    """What :func:`detect_rest` measures on a recording before it sets any threshold.

    The noise sigmas, the quiet gyro level and the centred moving statistics
    depend on the recording and on `max_window_s`, `window_s` and `noise_s`
    only, so one measurement serves every threshold (every accelerometer
    floor, for example). Made by :func:`rest_measures`.

    Attributes
    ----------
    max_window_s, window_s : float
        The parameters they were taken with [s].
    noise_s : float or None
        The parameter they were taken with [s].
    n : int
        Samples of the recording measured.
    sig_g, sig_a : ndarray, shape (3,)
        Gyro [rad/s] and accelerometer [m/s^2] noise sigmas (at least the
        datasheet's white noise of ``rec.imu`` when it is known).
    med_g : ndarray, shape (3,)
        Median gyro reading of the quietest noise block [rad/s].
    m_g, s_g : ndarray, shape (n, 3)
        Centred moving mean and standard deviation of the gyro [rad/s].
    s_a : ndarray, shape (n, 3)
        Centred moving standard deviation of the accelerometer [m/s^2].
    """

    max_window_s: float
    window_s: float
    noise_s: float | None
    n: int
    sig_g: np.ndarray
    sig_a: np.ndarray
    med_g: np.ndarray
    m_g: np.ndarray
    s_g: np.ndarray
    s_a: np.ndarray


def rest_measures(rec: Recording, *, max_window_s: float = 3.0, window_s: float = 0.25,
                  noise_s: float | None = None) -> RestMeasures:
    """Measure what :func:`detect_rest` thresholds, once for many thresholds.

    Parameters
    ----------
    rec : Recording
        The recording.
    max_window_s, window_s, noise_s : float
        As for :func:`detect_rest`.

    Returns
    -------
    RestMeasures
        To pass to :func:`detect_rest` (``measures=``) with the same
        `max_window_s`, `window_s` and `noise_s`.

    Raises
    ------
    ParameterError
        For a parameter that is not a positive number.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> t = np.arange(600) * 0.01
    >>> w = 0.001 * rng.standard_normal((600, 3)); w[300:, 2] += 0.5 * np.sin(2 * np.pi * t[300:])
    >>> rec = Recording(time=t, f=[0.0, 0.0, 9.8] + 0.01 * rng.standard_normal((600, 3)), omega=w)
    >>> m = rest_measures(rec)
    >>> [detect_rest(rec, accel_floor=a, measures=m) == detect_rest(rec, accel_floor=a) for a in (0.05, 1.0)]
    [True, True]
    """
    for name, v in (("max_window_s", max_window_s), ("window_s", window_s),
                    ("noise_s", 1.0 if noise_s is None else noise_s)):
        if not (math.isfinite(v) and v > 0):
            raise ParameterError(f"{name}={v!r}: expected a positive number")
    t = rec.time - rec.time[0]
    span = max_window_s if noise_s is None else noise_s
    sig_g, med_g = _block_sigma(t, rec.omega, span, window_s, rec.source)
    sig_a, _ = _block_sigma(t, rec.f, span, window_s, rec.source)
    # Noise-free (simulated) rests: stay above floating-point rounding.
    sig_g = np.maximum(sig_g, _GYRO_SIGMA_MIN)
    sig_a = np.maximum(sig_a, _ACCEL_SIGMA_MIN)
    if rec.imu is not None:
        # Never below the datasheet white noise over the Nyquist band.
        spec = rec.imu
        sig_g = np.maximum(sig_g, _nyquist_sigma(spec.gyro_noise, rec.rate_hz))
        sig_a = np.maximum(sig_a, _nyquist_sigma(spec.accel_noise, rec.rate_hz))
    half = window_s / 2.0
    m_g, s_g = _moving_stats(t, rec.omega, half)
    _, s_a = _moving_stats(t, rec.f, half)
    return RestMeasures(max_window_s=max_window_s, window_s=window_s, noise_s=noise_s, n=rec.n, sig_g=sig_g,
                        sig_a=sig_a, med_g=med_g, m_g=m_g, s_g=s_g, s_a=s_a)


def detect_rest(rec: Recording, *, max_window_s: float = 3.0, min_window_s: float = 1.0,
                window_s: float = 0.25, noise_s: float | None = None, k_std: float = 4.0, k_dev: float = 6.0,
                accel_floor: float = 0.1, sustain_s: float = 1.5, guard_s: float = 0.05,
                min_samples: int = 10, measures: RestMeasures | None = None,
                bound: SensorSpec | StillBound | None = None) -> RestWindow:
    """Find the initial rest period of a recording.

    Parameters
    ----------
    rec : Recording
        The recording (real, non-uniform time stamps). When it carries its
        IMU's figures (``rec.imu``) their white noise bounds the noise sigmas
        from below.
    max_window_s : float
        Longest window returned [s] (the paper calibrates on the first 3 s).
    min_window_s : float
        Shortest rest accepted without a warning [s]; a shorter rest is still
        used (method ``"short"``) and `note` says so.
    window_s : float
        Length of the centred moving window [s].
    noise_s : float, optional
        Length of the initial segment the noise sigmas are estimated on [s]
        (default `max_window_s`). It is cut into blocks of `window_s`; each
        block gives a sigma (:func:`noise_sigma`) and the lower quartile of
        the blocks is used, so up to three quarters of the segment may move
        or be disturbed.
    k_std : float
        Motion threshold on the moving standard deviation, in noise sigmas.
        For white noise over a window of >= 10 samples the sample standard
        deviation exceeds 4 sigma with negligible probability; the margin
        covers the coarse quantization of the phones' gyros (the S8's step is
        about its noise sigma, so windowed standard deviations reach ~2 sigma
        at rest in the field recordings).
    k_dev : float
        Motion threshold on the moving mean's departure from the rest level,
        and on single gyro samples when refining the onset, in noise sigmas
        (a Gaussian sample exceeds 6 sigma with probability 2e-9).
    accel_floor : float
        Lowest accelerometer threshold [m/s^2] (see the module docstring).
    sustain_s : float
        Shortest flagged run taken as the start of the motion [s] (runs
        shorter than a quarter of the longest one are not taken either);
        shorter runs before it are disturbances, skipped.
    guard_s : float
        Gap left between the end of the window and the motion onset [s].
    min_samples : int
        Fewest samples a rest window may have; fewer raise DataError.
    measures : RestMeasures, optional
        The recording's :func:`rest_measures` with the same `max_window_s`,
        `window_s` and `noise_s`; measured here when None. Passing them saves
        measuring again when only thresholds change.
    bound : SensorSpec or StillBound, optional
        What a still IMU's readings may spread (:func:`still_bound`): a
        StillBound as it is, or :data:`STILL_NOISE_FACTOR` times a
        SensorSpec's white noise; default: the recording's IMU (``rec.imu``)
        when it is known, else :data:`DEFAULT_IMU`. The spread thresholds never
        exceed it (the accelerometer's never go below `accel_floor`). An
        explicit rest window needs none of this: pass it to :func:`calibrate`.

    Returns
    -------
    RestWindow
        The window's samples and time stamps, how it was chosen
        (``"full"``, ``"detected"`` or ``"short"``), a note, and the motion
        onset on the recording's clock.

    Raises
    ------
    NoRestError
        Naming the recording, when it moves from its first samples (fewer than
        `min_samples` samples at rest before its motion); the message gives
        the sensors' spread there against the still bound.
    DataError
        Naming the recording, when it is too short to tell: it ends inside a
        movement that has not yet lasted `sustain_s` (with no motion before),
        or fewer than `min_samples` samples after the last disturbance. The
        message says how long the recording would have to be.
    ParameterError
        For a bad parameter.

    Examples
    --------
    A phone at rest for 2 s that then swings about z at 1 Hz (0.5 rad/s
    amplitude): the window ends a guard before the first gyro sample beyond
    6 sigmas of the rest noise, 2.01 s after the start.

    >>> rng = np.random.default_rng(0)
    >>> t = 100.0 + np.arange(600) * 0.01
    >>> f = [0.0, 0.0, 9.8] + 0.01 * rng.standard_normal((600, 3))
    >>> w = [0.0, 0.0, 0.02] + 0.001 * rng.standard_normal((600, 3))
    >>> w[200:, 2] += 0.5 * np.sin(2 * np.pi * (t[200:] - t[200]))
    >>> win = detect_rest(Recording(time=t, f=f, omega=w))
    >>> win.method, win.i0, win.i1, round(win.motion_s - 100.0, 2), round(win.duration_s, 2)
    ('detected', 0, 197, 2.01, 1.96)

    A robot that vibrates from its first sample (0.03 rad/s and 0.1 m/s^2 at
    13 Hz) has no rest, however steady the vibration; this IMU is not known,
    so the bound is :data:`DEFAULT_IMU`'s:

    >>> shake = np.sin(2 * np.pi * 13.0 * (t - 100.0))[:, None]
    >>> detect_rest(Recording(time=t, f=f + 0.1 * shake, omega=w + 0.03 * shake, source="moving.csv"))
    Traceback (most recent call last):
    ...
    morpi_filters.calibration.NoRestError: moving.csv: no initial rest found: motion starts 0.000 s after the first sample (0 samples at rest, expected at least 10); over its first 0.25 s the gyro spreads up to 0.0219 rad/s and ... where a still IMU stays within 0.0123 rad/s and 0.208 m/s^2 (MPU-6500 noise x 10); cannot calibrate moving.csv
    """
    for name, v in (("max_window_s", max_window_s), ("min_window_s", min_window_s), ("window_s", window_s),
                    ("noise_s", 1.0 if noise_s is None else noise_s), ("k_std", k_std), ("k_dev", k_dev),
                    ("sustain_s", sustain_s)):
        if not (math.isfinite(v) and v > 0):
            raise ParameterError(f"{name}={v!r}: expected a positive number")
    if min_window_s > max_window_s:
        raise ParameterError(f"min_window_s={min_window_s!r}: expected at most max_window_s={max_window_s!r}")
    if not (math.isfinite(guard_s) and guard_s >= 0) or not (math.isfinite(accel_floor) and accel_floor >= 0):
        raise ParameterError(f"guard_s={guard_s!r}, accel_floor={accel_floor!r}: expected non-negative numbers")
    if rec.n < min_samples:
        raise DataError(f"{rec.source}: {rec.n} samples is too short for a rest window: at least "
                        f"min_samples={min_samples} samples needed")
    if measures is None:
        measures = rest_measures(rec, max_window_s=max_window_s, window_s=window_s, noise_s=noise_s)
    elif (measures.max_window_s, measures.window_s, measures.noise_s, measures.n) != (
            max_window_s, window_s, noise_s, rec.n):
        raise ParameterError(f"measures: taken with max_window_s={measures.max_window_s!r}, "
                             f"window_s={measures.window_s!r}, noise_s={measures.noise_s!r} on {measures.n} samples; "
                             f"expected max_window_s={max_window_s!r}, window_s={window_s!r}, noise_s={noise_s!r} "
                             f"on the {rec.n} samples of {rec.source}")
    t = rec.time - rec.time[0]
    n = rec.n
    sig_g, sig_a, med_g = measures.sig_g, measures.sig_a, measures.med_g
    m_g, s_g, s_a = measures.m_g, measures.s_g, measures.s_a
    # The spread thresholds: `k_std` sigmas of the noise measured on the recording, never above what a still
    # IMU shows (an absolute bound: a recording that never stands still measures its motion as its noise),
    # and for the accelerometer never below the floor.
    still = still_bound(rec, bound)
    thr_sg = np.minimum(k_std * sig_g, still.gyro)
    thr_sa = np.maximum(np.minimum(k_std * sig_a, still.accel), accel_floor)
    # a sample moves when, on any axis, the gyro's spread or its deviation from the quiet level, or the
    # accelerometer's spread, exceeds its threshold (a compiled loop over the samples)
    from ._calibration_loops import compiled

    moving = np.empty(n, dtype=bool)
    compiled()["motion_flags"](s_g, m_g, s_a, np.array(thr_sg, dtype=float), np.array(med_g, dtype=float),
                               np.array(k_dev * sig_g), np.array(thr_sa, dtype=float), moving)
    # Runs of flagged samples, merged across gaps shorter than `window_s`
    # (a window's worth of quiet inside motion is not rest).
    runs = _runs(moving, t, window_s)
    longest = max((t[s1 - 1] - t[s0] for s0, s1 in runs), default=0.0)
    need = max(sustain_s, 0.25 * longest)
    main = next(((s0, s1) for s0, s1 in runs if t[s1 - 1] - t[s0] >= need), None)
    name = rec.name
    if main is None:
        onset = None
        end_idx = n
    else:
        coarse = main[0]
        # Refine: the first sample, from the coarse onset to one window
        # later, whose gyro reading leaves the rest band around the mean of
        # the quiet samples before it. Without any (flagged from the first
        # sample on) there is no rest to leave: the motion is under way.
        quiet = ~moving[:coarse]
        onset = coarse
        if quiet.any():
            rest_mean = rec.omega[:coarse][quiet].mean(axis=0)
            stop = int(np.searchsorted(t, t[coarse] + window_s, side="right"))
            out = np.flatnonzero((np.abs(rec.omega[coarse:stop] - rest_mean) > k_dev * sig_g).any(axis=1))
            onset = coarse + int(out[0]) if out.size else coarse
        end_idx = int(np.searchsorted(t, t[onset] - guard_s, side="left"))
    if main is None and runs and runs[-1][1] == n:
        # The recording ends inside a movement shorter than `sustain_s`: whether it is the motion or a
        # disturbance the rest resumes after cannot be told from what the recording holds.
        s0 = runs[-1][0]
        until = t[s0] + sustain_s
        raise DataError(f"{rec.source}: {n} samples ({t[-1]:.2f} s) is too short: it ends {t[-1] - t[s0]:.2f} s "
                        f"into a movement that starts at {t[s0]:.2f} s, which is told from a disturbance only "
                        f"once it lasts sustain_s={sustain_s:g} s: at least {until:.2f} s "
                        f"(about {s0 + math.ceil(sustain_s * rec.rate_hz) + 1} samples) needed")
    motion_s = None if onset is None else float(rec.time[onset])
    # The window starts after the last brief disturbance before the motion
    # (a tap on the screen when the recording starts), plus a guard.
    before = [(s0, s1) for s0, s1 in runs if s1 <= (main[0] if main else n)]
    i0 = 0
    if before:
        i0 = int(np.searchsorted(t, t[before[-1][1] - 1] + guard_s, side="right"))
    i1 = min(end_idx, int(np.searchsorted(t, t[i0] + max_window_s, side="right"))) if i0 < n else n
    if i1 - i0 < min_samples:
        if onset is not None:
            # what the sensors show up to one window after the onset, against a still IMU
            j = max(int(np.searchsorted(t, t[onset] + window_s, side="right")), 1)
            raise NoRestError(f"{rec.source}: no initial rest found: motion starts {t[onset]:.3f} s after the first "
                              f"sample ({max(i1 - i0, 0)} samples at rest, expected at least {min_samples}); over "
                              f"its first {t[j - 1]:.2f} s the gyro spreads up to {s_g[:j].max():.3g} rad/s and the "
                              f"accelerometer up to {s_a[:j].max():.3g} m/s^2, where a still IMU stays within "
                              f"{still.gyro:.3g} rad/s and {still.accel:.3g} m/s^2 ({still.basis}); "
                              f"cannot calibrate {name}")
        # no motion: the recording ends too soon after its first samples or after a disturbance
        after = f" after a movement at {t[before[-1][0]]:.2f}-{t[before[-1][1] - 1]:.2f} s" if before else ""
        raise DataError(f"{rec.source}: {n} samples ({t[-1]:.2f} s) is too short: {max(i1 - i0, 0)} samples at "
                        f"rest{after}, expected at least min_samples={min_samples}: at least {i0 + min_samples} "
                        f"samples needed")
    dur = float(t[i1 - 1] - t[i0])
    notes = []
    if i0 > 0:
        notes.append(f"disturbance in the first {t[i0]:.2f} s skipped")
    if onset is not None and end_idx <= i1:
        notes.append(f"motion starts at {t[onset]:.2f} s")
    if i0 == 0 and end_idx >= i1 and dur >= max_window_s - 2.0 / rec.rate_hz:
        method = "full"
    elif dur >= min_window_s:
        method = "detected"
        notes.append(f"window {t[i0]:.2f}-{t[i1 - 1]:.2f} s ({dur:.2f} s)")
    else:
        method = "short"
        notes.append(f"rest of only {dur:.2f} s (< min_window_s {min_window_s:g} s) used anyway: "
                     "the biases carry more noise")
    return RestWindow(start_s=float(rec.time[i0]), end_s=float(rec.time[i1 - 1]), i0=i0, i1=i1,
                      method=method, note="; ".join(notes), motion_s=motion_s)


def _runs(flags: np.ndarray, t: np.ndarray, gap_s: float) -> list[tuple[int, int]]:
    """Index ranges [s0, s1) of True runs, merging runs separated by less than `gap_s`."""
    idx = np.flatnonzero(np.diff(np.concatenate([[0], flags.astype(np.int8), [0]])))
    raw = list(zip(idx[::2].tolist(), idx[1::2].tolist()))
    out: list[list[int]] = []
    for s0, s1 in raw:
        if out and t[s0] - t[out[-1][1] - 1] < gap_s:
            out[-1][1] = s1
        else:
            out.append([s0, s1])
    return [(a, b) for a, b in out]


# ----------------------------------------------------------------------------- calibration

@renamed_keywords(mode="calibration")
def calibrate(rec: Recording, calibration: str, *, window: RestWindow | None = None,
              g_local: float = G0) -> Calibration:
    """Zero-order calibration over the initial rest window.

    Parameters
    ----------
    rec : Recording
        The recording to calibrate.
    calibration : str
        ``"RD"``: raw data, no correction. ``"GC"``: gyro bias = mean angular
        rate over the window. ``"GAC"``: GC plus accelerometer bias = mean
        specific force over the window minus ``(0, 0, g_local)`` (the phone is
        assumed level, z up; paper [1]).
    window : RestWindow, optional
        The window to average over; found with :func:`detect_rest` when None
        (not used for RD).
    g_local : float, optional
        Local gravity magnitude [m/s^2] (default: standard gravity,
        :data:`morpi_filters.units.G0`; a dataset's is normal gravity at its
        latitude, :func:`normal_gravity`).

    Returns
    -------
    Calibration
        The calibration's name, the gyro bias [rad/s] and accelerometer bias [m/s^2] (zeros
        where the calibration does not estimate them) and the window (None for RD).

    Raises
    ------
    NoRestError
        GC or GAC without a `window` on a recording that has no initial rest
        (:func:`detect_rest`).
    ParameterError
        For an unknown `calibration`, a bad `g_local` or a window outside the
        recording.
    DataError
        For a recording too short to tell its rest (:func:`detect_rest`).

    Examples
    --------
    A level phone at rest reading f_z = 9.9 m/s^2 where gravity is 9.8 m/s^2:

    >>> rec = Recording(time=np.arange(400) * 0.01, f=np.tile([0.0, 0.05, 9.9], (400, 1)),
    ...                 omega=np.tile([0.001, 0.0, -0.002], (400, 1)))
    >>> cal = calibrate(rec, "GAC", g_local=9.8)
    >>> cal.window.method, cal.gyro_bias.round(12).tolist(), cal.accel_bias.round(12).tolist()
    ('full', [0.001, 0.0, -0.002], [0.0, 0.05, 0.1])
    >>> calibrate(rec, "GC").accel_bias.tolist(), calibrate(rec, "RD").window is None
    ([0.0, 0.0, 0.0], True)
    """
    mode = calibration
    if mode not in CALIBRATIONS:
        raise ParameterError(f"calibration={mode!r}: unknown calibration, expected one of {', '.join(CALIBRATIONS)}")
    if not (math.isfinite(g_local) and g_local > 0):
        raise ParameterError(f"g_local={g_local!r}: expected a positive gravity magnitude in m/s^2")
    zero = np.zeros(3)
    if mode == "RD":
        return Calibration(calibration="RD", gyro_bias=zero, accel_bias=zero.copy(), window=None)
    if window is None:
        window = detect_rest(rec)
    if not (0 <= window.i0 < window.i1 <= rec.n):
        raise ParameterError(f"window [{window.i0}, {window.i1}): outside {rec.source} ({rec.n} samples)")
    sl = slice(window.i0, window.i1)
    gyro_bias = rec.omega[sl].mean(axis=0)
    accel_bias = zero.copy()
    if mode == "GAC":
        accel_bias = rec.f[sl].mean(axis=0) - np.array([0.0, 0.0, g_local])
    return Calibration(calibration=mode, gyro_bias=gyro_bias, accel_bias=accel_bias, window=window)


@renamed_keywords(mode="calibration")
def calibrated(rec: Recording, calibration: str, *, window: RestWindow | None = None,
               g_local: float = G0) -> tuple[Recording, Calibration]:
    """A recording with its biases removed, in one call: :func:`calibrate`, then :meth:`Calibration.apply`.

    Parameters
    ----------
    rec : Recording
        The recording to calibrate.
    calibration : {"RD", "GC", "GAC"}
        Calibration (see :func:`calibrate`).
    window : RestWindow, optional
        As in :func:`calibrate`.
    g_local : float, optional
        As in :func:`calibrate` [m/s^2].

    Returns
    -------
    recording : Recording
        The calibrated recording (a new object).
    calibration : Calibration
        The biases that were removed.

    Examples
    --------
    >>> t = np.arange(500) * 0.01
    >>> rec = Recording(time=t, f=np.tile([0.0, 0.0, 9.8], (500, 1)), omega=np.tile([0.0, 0.0, 0.01], (500, 1)))
    >>> crec, cal = calibrated(rec, "GC", window=RestWindow(0.0, 2.99, 0, 300, "full"))
    >>> round(float(cal.gyro_bias[2]), 12), round(float(abs(crec.omega[:, 2]).max()), 12)
    (0.01, 0.0)
    """
    cal = calibrate(rec, calibration, window=window, g_local=g_local)
    return cal.apply(rec), cal


@dataclass(frozen=True)
class RestRow:
    """The rest window of one recording, as reported.

    Attributes
    ----------
    name : str
        Recording label (``phone/route/split/file``).
    method : str
        :attr:`RestWindow.method`, or ``"none"`` when no rest was found.
    start_s, window_s : float or None
        Window start after the first sample, and window length [s].
    motion_s : float or None
        Motion onset after the first sample [s] (None: none found).
    gyro_shift : float or None
        Largest per-axis difference between the gyro bias over the paper's
        first `max_window_s` seconds and over the detected window [rad/s]:
        what assuming rest would have cost.
    note, error : str
        The window's note; the MorpiError message when no rest was found.
    """

    name: str
    method: str
    start_s: float | None
    window_s: float | None
    motion_s: float | None
    gyro_shift: float | None
    note: str = ""
    error: str = ""


@dataclass(frozen=True)
class RestSummary:
    """Which rest window each recording used, for reports.

    Attributes
    ----------
    rows : tuple of RestRow
        One per recording, in input order.
    n_moving_early : int
        Recordings whose sustained motion starts within `max_window_s` of
        their first sample (or that have no rest at all).
    n_disturbed : int
        Recordings whose window starts after a brief initial disturbance.
    n_total : int
        Recordings examined.
    """

    rows: tuple
    n_moving_early: int
    n_disturbed: int
    n_total: int

    def to_json(self) -> dict:
        """Counts and rows as plain JSON-ready values.

        Returns
        -------
        dict
            ``n_total``, ``n_moving_early``, ``n_disturbed`` (int) and ``rows``
            (a list with one dict per :class:`RestRow`, keyed by its fields).
        """
        return dict(n_total=self.n_total, n_moving_early=self.n_moving_early, n_disturbed=self.n_disturbed,
                    rows=[asdict(r) for r in self.rows])


def rest_windows_summary(recordings, *, max_window_s: float = 3.0, **kwargs) -> RestSummary:
    """Detect the rest window of each recording and tabulate them.

    Parameters
    ----------
    recordings : iterable of Recording
        The recordings to examine.
    max_window_s : float, optional
        Passed to :func:`detect_rest` [s] (default 3); also the horizon of
        ``n_moving_early`` and of the paper's fixed window in ``gyro_shift``.
    **kwargs
        Further :func:`detect_rest` parameters.

    Returns
    -------
    RestSummary
        One :class:`RestRow` per recording and the counts. Recordings without
        a rest are listed with their error (method ``"none"``), not raised.

    Examples
    --------
    One recording at rest throughout, one that turns from its first sample:

    >>> t = np.arange(500) * 0.01
    >>> still = Recording(time=t, f=np.tile([0.0, 0.0, 9.8], (500, 1)), omega=np.zeros((500, 3)), source="still")
    >>> turning = Recording(time=t, f=still.f, omega=np.c_[0 * t, 0 * t, np.sin(10 * t)], source="turning")
    >>> s = rest_windows_summary([still, turning])
    >>> s.n_total, s.n_moving_early, [(r.method, r.motion_s) for r in s.rows]
    (2, 1, [('full', None), ('none', None)])
    """
    rows, early, disturbed, total = [], 0, 0, 0
    for rec in recordings:
        total += 1
        try:
            w = detect_rest(rec, max_window_s=max_window_s, **kwargs)
        except MorpiError as exc:
            rows.append(RestRow(name=rec.name, method="none", start_s=None, window_s=None, motion_s=None,
                                gyro_shift=None, error=str(exc)))
            early += 1
            continue
        t0 = float(rec.time[0])
        onset = None if w.motion_s is None else w.motion_s - t0
        if onset is not None and onset <= max_window_s:
            early += 1
        disturbed += w.i0 > 0
        fixed = rec.omega[: int(np.searchsorted(rec.time - t0, max_window_s, side="right"))].mean(axis=0)
        shift = float(np.abs(fixed - rec.omega[w.i0:w.i1].mean(axis=0)).max())
        rows.append(RestRow(name=rec.name, method=w.method, start_s=w.start_s - t0, window_s=w.duration_s,
                            motion_s=onset, gyro_shift=shift, note=w.note))
    return RestSummary(rows=tuple(rows), n_moving_early=early, n_disturbed=disturbed, n_total=total)
