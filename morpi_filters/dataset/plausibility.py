"""Plausibility at rest: what a clean recording says about its units, axes and sensor (:func:`rest_problems`)."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..choice import choose
from ..errors import DataError, ParameterError
from ..units import DEG, G0, IMUS, SensorSpec
from .columns import COLUMNS
from .recording import Recording

#: Error figures the plausibility checks (:func:`rest_problems`) assume unless told another sensor's:
#: the larger of each figure of the MoRPI phones' IMUs (MPU-6500 in the Galaxy S6, LSM6DSL in the S8:
#: the paper's table of manufacturer errors, 1 sigma per axis), so that one bound serves both phone
#: folders. The bounds below are this spec's; the MoRPI catalogue uses it, and so does a dataset
#: manifest that gives no ``imu.spec``: the two are widely used consumer MEMS IMUs, and a ground robot's
#: IMU with smaller errors passes bounds set for larger ones.
MEMS_SPEC = SensorSpec("MPU-6500/LSM6DSL (larger figure of each)",
                       gyro_bias=max(s.gyro_bias for s in IMUS.values()),
                       gyro_noise=max(s.gyro_noise for s in IMUS.values()),
                       accel_bias=max(s.accel_bias for s in IMUS.values()),
                       accel_noise=max(s.accel_noise for s in IMUS.values()))
#: Initial sensitivity (scale-factor) tolerance of the accelerometer, as a fraction of the reading:
#: +-3 %, the figure InvenSense's MPU-6000/6050 product specification (table 6.2) gives for its
#: accelerometer, taken for the MPU-6500 of the same family (the LSM6DSL's is tighter).
_SENSITIVITY_TOLERANCE = 0.03
#: Spread of gravity over the Earth's surface [m/s^2]: normal gravity runs from 9.780 m/s^2 at the
#: equator to 9.832 at the poles, 0.003 less per km of height.
_PLACE_MPS2 = 0.05


def _gravity_band(spec: SensorSpec) -> float:
    """Half-width [m/s^2] of the band around :data:`G0` a sensor's rest specific force lies in (:data:`GRAVITY_BAND_MPS2`)."""
    return 3 * spec.accel_bias + _SENSITIVITY_TOLERANCE * G0 + _PLACE_MPS2


#: Plausibility at rest (:func:`rest_problems`): the magnitude of the specific force over the
#: recording's rest must lie within this band around standard gravity :data:`G0` [m/s^2]. It adds
#: three times the sensor's zero-g offset (here :data:`MEMS_SPEC`'s 60 mg, the MPU-6500's; the
#: LSM6DSL lists 40 mg), 1.77 m/s^2; the initial sensitivity tolerance of +-3 %, 0.29 m/s^2 at 1 g;
#: and 0.05 m/s^2 for the place on Earth. Tilt changes the direction of the specific force at rest,
#: not its magnitude, and the medians over the rest average vibration out, so neither takes a margin.
#: About 2.11 m/s^2: an accelerometer written in g (reading about 1) or without gravity (about 0,
#: linear acceleration) lies more than 6 m/s^2 outside it. The field recordings read 9.8066 to
#: 9.8067 m/s^2. (Dataset manifests once accepted 0.75 to 1.25 g, a round band without a source;
#: the datasheet band replaces it, and a manifest's ``imu.spec`` widens it for a worse sensor.)
GRAVITY_BAND_MPS2 = _gravity_band(MEMS_SPEC)
#: Least share of the rest specific force the z axis must carry, positive: cos 45 deg. The phone
#: frame is z up (a level phone at rest reads f_z = +g), and z is the axis nearest the vertical as
#: long as the phone is tilted less than 45 deg about a horizontal axis; beyond that x or y is nearer
#: the vertical (columns swapped under a kept header, or a phone standing on its edge), and a
#: negative f_z is a z-down frame (a phone face down, or axes written north-east-down). Both break the
#: paper's level start and its calibration, which puts gravity on +z. The field recordings carry at
#: least 0.977 of it on z (12 deg of tilt). (Dataset manifests once accepted 60 deg, a round figure;
#: 45 deg is where another axis becomes the nearer one to the vertical, so it is kept for both.)
UP_FRACTION_MIN = math.cos(math.radians(45.0))
#: Largest mean angular rate of one gyro axis at rest [rad/s]: three times the sensor's zero-rate
#: offset (here :data:`MEMS_SPEC`'s 6 deg/s, the MPU-6500's; the LSM6DSL lists 3 deg/s; 1 sigma per
#: axis in the paper's table), 18 deg/s; the earth's rate (7.3e-5 rad/s) is negligible beside it. A gyro
#: column holding gravity (9.8) or a tilted phone's horizontal specific force lies beyond it, and so
#: do rates written in deg/s (57.3 times larger) from a gyro whose offset exceeds 0.31 deg/s on some
#: axis. The field rest periods read at most 0.032 rad/s. (Dataset manifests once accepted 0.5 rad/s on
#: the magnitude, a round figure; three datasheet offsets per axis replace it.)
GYRO_REST_LIMIT_RADPS = 3 * MEMS_SPEC.gyro_bias
#: Largest white noise of a gyro axis at rest, as a multiple of the sensor's datasheet noise at the
#: recording's sampling rate (for :data:`MEMS_SPEC` the MPU-6500's 0.01 deg/s/sqrt(Hz) times sqrt(rate),
#: the sample standard deviation :func:`morpi_filters.simulate.imu` draws): 10, or 1 deg/s rms at
#: 100 Hz. Rates written in deg/s carry 57.3 times their noise, beyond the bound for any gyro whose
#: noise exceeds 10 / 57.3 = 0.17 of that density (the LSM6DSL's datasheet density is 0.4 of it). The
#: field rest periods read at most 1.8 times the density (a median change of two quantization steps on
#: the S6).
GYRO_NOISE_FACTOR = 10.0
#: Largest 99th percentile of the angular rate's magnitude over a whole recording [rad/s] (573 deg/s):
#: no ground robot turns that fast for 1 % of a run, while rates written in deg/s from turns above
#: 10 deg/s pass it; it needs no rest, so it also judges a recording that starts moving. The field
#: recordings read at most 1.9 rad/s (their peak is 12.3 rad/s).
MOVING_RATE_LIMIT_RADPS = 10.0


#: Still-stretch search of :func:`rest_problems`: blocks of this length [s] ...
_STILL_BLOCK_S = 0.5
#: ... each still when every gyro column's peak-to-peak stays within this multiple of its quietest
#: block's (at least one quantization step): the peak-to-peak of white noise over a block of 50
#: samples is about 4.5 sigma and rarely leaves 3 to 6.5 sigma, so rest blocks stay within about
#: twice the quietest one, while a turn or a hand moves the gyro by hundreds of noise sigmas.
_STILL_RATIO = 4.0
#: Shortest and longest still stretch used [blocks]: 1 to 3 s (the paper calibrates on 3 s).
_STILL_BLOCKS = (2, 6)
#: Fewest samples a block needs to count (a block at a gap or at the end may hold a few).
_STILL_MIN_SAMPLES = 5


def _still_stretch(time: np.ndarray, omega: np.ndarray) -> tuple[int, int]:
    """Sample slice ``(i0, i1)`` of the first still stretch of a recording.

    The recording is cut into blocks of :data:`_STILL_BLOCK_S` from its first
    sample; a block is still when the peak-to-peak of each gyro column is at
    most :data:`_STILL_RATIO` times that column's quietest block (floored at
    its smallest step, the quantization). The stretch is the first run of at
    least ``_STILL_BLOCKS[0]`` still blocks, cut at ``_STILL_BLOCKS[1]``; when
    there is none, the quietest block. Stillness is read from the gyro
    columns alone, each against itself, so it does not depend on their units:
    the phones' accelerometer channels are low-pass filtered and settle during
    the first seconds (whole blocks of repeated values, then slow drifts, in
    the field recordings), while a hand or a turn shows on the gyro.
    """
    n = time.shape[0]
    block = np.floor((time - time[0]) / _STILL_BLOCK_S)
    starts = np.concatenate(([0], np.flatnonzero(block[1:] != block[:-1]) + 1))
    ends = np.concatenate((starts[1:], [n]))
    ptp = np.maximum.reduceat(omega, starts, axis=0) - np.minimum.reduceat(omega, starts, axis=0)
    counted = (ends - starts) >= _STILL_MIN_SAMPLES
    if not counted.any():
        return 0, n
    ref = ptp[counted].min(axis=0)
    for j in np.flatnonzero(ref == 0):              # a block without a change: its quantization step instead
        steps = np.abs(np.diff(omega[:, j]))
        ref[j] = steps[steps > 0].min() if (steps > 0).any() else 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(ptp > 0, ptp / ref, 0.0).max(axis=1)      # a column never moving: ratio 0
    still = counted & (ratio <= _STILL_RATIO)
    shortest, longest = _STILL_BLOCKS
    b = 0
    while b < still.size:
        if still[b]:
            e = b
            while e + 1 < still.size and still[e + 1]:
                e += 1
            if e - b + 1 >= shortest:
                return int(starts[b]), int(ends[min(e, b + longest - 1)])
            b = e + 1
        else:
            b += 1
    quiet = choose(np.where(counted, ratio, np.inf))                # the first of ties (choice.choose)
    return int(starts[quiet]), int(ends[quiet])


def _gyro_noise(omega: np.ndarray) -> np.ndarray:
    """White-noise standard deviation per gyro axis, from the median absolute sample-to-sample change.

    For white noise of standard deviation sigma the changes have standard deviation sqrt(2) sigma and
    their median absolute value is 0.6745 of it; the median ignores a few outliers. Zeros with fewer
    than three samples.
    """
    if omega.shape[0] < 3:
        return np.zeros(omega.shape[1])
    return np.median(np.abs(np.diff(omega, axis=0)), axis=0) / (0.6745 * math.sqrt(2.0))


def _vec(v) -> str:
    return "(" + ", ".join(f"{x:.3g}" for x in v) + ")"


#: Least share of a column's successive changes that turn back for a recording without a known rest
#: (``rest="none"``) to count as carrying sensor noise (so that a column that never moves is a dead
#: channel): white noise turns back in 2/3 of its sample-to-sample changes (two consecutive differences
#: of independent samples correlate by -1/2), while motion sampled far above its bandwidth turns back
#: only at its extremes; the bound lies halfway between 0 and 2/3.
_NOISE_TURNS = 1.0 / 3.0


def _turns_like_noise(x: np.ndarray) -> bool:
    """Whether some column of `x` changes direction between successive samples as white noise does."""
    for j in range(x.shape[1]):
        d = np.diff(x[:, j])
        d = d[d != 0]
        if d.size > 2 and float(np.mean(np.sign(d[1:]) != np.sign(d[:-1]))) > _NOISE_TURNS:
            return True
    return False


@dataclass(frozen=True)
class RestProblem:
    """One way a recording is implausible for an IMU in SI units and the z-up frame (:func:`rest_problems`).

    Attributes
    ----------
    kind : str
        What is wrong, as the setting to fix: ``"dead_channel"`` (a sensor
        column that never moves), ``"accel_unit"`` (the specific force's
        magnitude is not gravity's), ``"axes"`` (gravity not up the z axis),
        ``"gyro_unit"`` (rates beyond a gyro's offset or noise at rest, or
        beyond a ground robot's turns) or ``"columns"`` (specific force under
        the gyro columns).
    cause : str
        The finding within its kind: ``"dead"``; ``"in_g"``, ``"no_gravity"``,
        ``"not_gravity"``; ``"z_down"``, ``"across"``; ``"rest_bias"``,
        ``"rest_noise"``, ``"percentile"``; ``"gravity_on_gyro"``.
    message : str
        One line starting with the recording's source: what was read, what
        was expected and the likely cause.
    value : float
        The figure that broke the bound, SI: the magnitude of the rest
        specific force [m/s^2] (``accel_unit``, ``columns``), its share on +z
        (``axes``), the largest rest rate or noise [rad/s] or the rate
        percentile [rad/s] (``gyro_unit``); NaN for a dead channel.
    bound : float
        The bound it broke, in the same unit.
    column : str
        The column named (``"f_x"`` ... ``"g_z"``), or ``""``.
    f_rest : tuple of float
        The median specific force over the rest, or over the recording
        without one [m/s^2].
    """

    kind: str
    cause: str
    message: str
    value: float
    bound: float
    column: str
    f_rest: tuple


def _rest_slice(rec: Recording, rest) -> tuple[int, int] | None:
    """Sample slice of the rest: the first still stretch (``"auto"``), a window ``(t0, t1)`` [s from the first
    sample], or None (``"none"``)."""
    if isinstance(rest, str) and rest == "auto":
        return _still_stretch(rec.time, rec.omega)
    if isinstance(rest, str) and rest == "none":
        return None
    try:
        if isinstance(rest, str):
            raise ValueError(rest)
        t0, t1 = (float(v) for v in rest)
    except (TypeError, ValueError):
        raise ParameterError(f"{rec.source}: rest={rest!r}, expected 'auto', 'none' or (t0, t1) in seconds from "
                             "the first sample") from None
    t = rec.time - rec.time[0]
    inside = np.flatnonzero((t >= t0) & (t <= t1))
    if inside.size < 2:
        raise ParameterError(f"{rec.source}: rest=({t0:g}, {t1:g}) holds {inside.size} sample(s), expected a "
                             "window of several samples inside the recording")
    return int(inside[0]), int(inside[-1]) + 1


def rest_problems(rec: Recording, *, spec: SensorSpec | None = None, rest="auto") -> tuple:
    """Every way a recording is implausible for an IMU in SI units and the z-up frame, structured.

    The one home of these checks: the MoRPI catalogue (:func:`plausibility_problems`,
    :func:`check_plausible`, ``morpi check --data``) and dataset manifests
    (:func:`morpi_filters.manifest.load_dataset`, ``morpi check --dataset``)
    both call it. The checks read the recording's rest: its first still
    stretch (``rest="auto"``: the MoRPI recordings start at rest; a handling
    disturbance before the rest is skipped), a known window, or none. Each
    bound is a sensor or physics figure, given with its source beside its
    constant, and scales with the sensor's error figures `spec`:

    - dead channel: a sensor column that reads the same value in every sample
      (all zero, or stuck), when the recording carries sensor noise (some
      column moves during the rest; without a rest, some column turns back
      between successive samples as often as white noise does); a
      noise-free synthetic recording is not judged on this;
    - gravity: the magnitude of the median specific force over the rest (over
      the recording with ``rest="none"``: a ground robot's accelerations
      average out beside gravity) within :data:`GRAVITY_BAND_MPS2` of
      :data:`G0` (for `spec`: three zero-g offsets, the sensitivity
      tolerance and the place on Earth); an accelerometer in g, one without
      gravity, or specific force on the gyro columns is named;
    - up axis: ``f_z`` at least :data:`UP_FRACTION_MIN` of that magnitude,
      positive (gravity on x or y, or a z-down frame, is named);
    - gyro at rest (not with ``rest="none"``): each axis's median within
      three zero-rate offsets of `spec` (:data:`GYRO_REST_LIMIT_RADPS`) and
      its white noise within :data:`GYRO_NOISE_FACTOR` times the noise
      density of `spec` at the rest's sampling rate (deg/s, or gravity on a
      gyro column, is named);
    - turns: the 99th percentile of the rate's magnitude over the recording
      within :data:`MOVING_RATE_LIMIT_RADPS` (said when the rest found the
      gyro plausible, or without a rest).

    Parameters
    ----------
    rec : Recording
        The recording in SI units and the body or phone frame (z up).
    spec : SensorSpec, optional
        The IMU's error figures; default :data:`MEMS_SPEC`.
    rest : str or tuple of float
        ``"auto"`` (the first still stretch), ``"none"`` (no rest is assumed:
        only dead channels, gravity over the recording and the turns are
        checked) or ``(t0, t1)``: the rest window in seconds from the first
        sample.

    Returns
    -------
    tuple of RestProblem
        In the order above; empty when the recording is plausible.

    Raises
    ------
    ParameterError
        A `rest` that is none of the three forms, or a window holding fewer
        than two samples.

    Examples
    --------
    A level IMU at rest whose z axis points down:

    >>> rng = np.random.default_rng(2)
    >>> t = np.arange(300) * 0.01
    >>> f = [0.1, 0.0, -9.8] + 0.02 * rng.standard_normal((300, 3))
    >>> w = 0.002 * rng.standard_normal((300, 3))
    >>> [(p.kind, p.cause) for p in rest_problems(Recording(time=t, f=f, omega=w))]
    [('axes', 'z_down')]
    """
    spec = MEMS_SPEC if spec is None else spec
    if rec.n == 0:
        return ()
    src = rec.source
    out = []
    window = _rest_slice(rec, rest)
    i0, i1 = window if window is not None else (0, rec.n)
    resting = np.concatenate((rec.f[i0:i1], rec.omega[i0:i1]), axis=1)
    noisy = (resting.max(axis=0) > resting.min(axis=0)).any() if window is not None else \
        _turns_like_noise(resting)
    f_mean, w_mean = np.split(np.median(resting, axis=0), 2)
    f_rest = tuple(float(v) for v in f_mean)

    def add(kind, cause, message, value=math.nan, bound=math.nan, column=""):
        out.append(RestProblem(kind, cause, message, float(value), float(bound), column, f_rest))

    if noisy:
        dead = np.concatenate([np.maximum.reduceat(x, [0], axis=0)[0] == np.minimum.reduceat(x, [0], axis=0)[0]
                               for x in (rec.f, rec.omega)])     # (reduceat: much faster than max(axis=0) here)
        first = np.concatenate((rec.f[0], rec.omega[0]))
        for j in np.flatnonzero(dead):
            v, col = float(first[j]), COLUMNS[1 + j]
            what = "all zero" if v == 0 else f"stuck at {v!r}"
            add("dead_channel", "dead", f"{src}: column {col} is {what} in all {rec.n} samples: a dead channel, "
                "expected a live sensor (white noise moves every MEMS axis, as the recording's other columns move "
                "at rest)", column=col)
    mag, w_mag = float(np.linalg.norm(f_mean)), float(np.linalg.norm(w_mean))
    band = _gravity_band(spec)
    gravity_ok = abs(mag - G0) <= band
    in_g = abs(mag * G0 - G0) <= band
    gravity_on_gyro = abs(w_mag - G0) <= band
    expect_f = f"expected |f| = {G0:.2f} +- {band:.2f} m/s^2"
    if not gravity_ok:
        kind = "accel_unit"
        if in_g:
            cause, hint = "in_g", "looks like the accelerometer is in g, not m/s^2"
        elif gravity_on_gyro:
            kind, cause = "columns", "gravity_on_gyro"
            hint = (f"the gyro columns carry it instead (|w| = {w_mag:.3g} at rest, w = {_vec(w_mean)}): "
                    "looks like specific-force and angular-rate columns swapped under their header")
        elif mag < band:
            cause = "no_gravity"
            hint = "no gravity: looks like linear acceleration (gravity removed) or a column that is not specific force"
        else:
            cause = "not_gravity"
            hint = "not the gravity a phone at rest reads: another unit or another quantity under the header"
        add(kind, cause, f"{src}: specific force at rest is {mag:.2f} m/s^2 (f = {_vec(f_mean)}), {expect_f}: {hint}",
            mag, band)
    if gravity_ok or in_g:
        share = f_mean[2] / mag
        if share < UP_FRACTION_MIN:
            if -share >= UP_FRACTION_MIN:
                add("axes", "z_down", f"{src}: f_z at rest is {f_mean[2]:.3g} (f = {_vec(f_mean)}), expected +|f| on "
                    "z (the phone frame is z up): a z-down frame (north-east-down axes) or a phone lying face down",
                    share, UP_FRACTION_MIN, "f_z")
            else:
                j = int(np.argmax(np.abs(f_mean)))
                other = COLUMNS[1 + j]
                cause = (f"looks like {other} and f_z swapped under their header, or a phone standing on its edge"
                         if j < 2 else "a phone tilted beyond 45 deg")
                add("axes", "across", f"{src}: gravity at rest is on {other} (f = {_vec(f_mean)}), expected at least "
                    f"{UP_FRACTION_MIN:.2f} of |f| on +f_z (the phone frame is z up): {cause}", share,
                    UP_FRACTION_MIN, other)
    rest_limit = 3 * spec.gyro_bias
    gyro_said = gravity_on_gyro
    if window is not None:
        noise = _gyro_noise(resting[:, 3:])
        dt = np.diff(rec.time[i0:i1] if i1 - i0 > 1 else rec.time)
        rate = float(1.0 / np.median(dt)) if dt.size else 100.0      # the rest's median sampling rate [Hz]
        noise_limit = GYRO_NOISE_FACTOR * spec.gyro_noise * math.sqrt(rate)
        bias_bad = np.abs(w_mean) > rest_limit
        noise_bad = noise > noise_limit
        if bias_bad.any() or noise_bad.any():
            gyro_said = True
            said = []
            jb, jn = int(np.argmax(np.abs(w_mean))), int(np.argmax(noise))
            if bias_bad.any():
                said.append(f"mean {w_mean[jb]:.3g} rad/s on {COLUMNS[4 + jb]} (expected within "
                            f"+-{rest_limit:.2f} rad/s, three zero-rate offsets)")
            if noise_bad.any():
                said.append(f"noise {noise[jn]:.3g} rad/s on {COLUMNS[4 + jn]} (expected at most {noise_limit:.3g} "
                            f"rad/s, {GYRO_NOISE_FACTOR:g} times the datasheet noise at {rate:.0f} Hz)")
            as_deg = (np.abs(w_mean) * DEG <= rest_limit).all() and (noise * DEG <= noise_limit).all()
            odd = np.flatnonzero(bias_bad | noise_bad)
            kind = "gyro_unit"
            if gravity_on_gyro:
                # said with the specific force when the accelerometer lacks it
                kind, hint = "columns", "looks like gravity, specific force under a gyro header" if gravity_ok else None
            elif as_deg and odd.size > 1:            # deg/s scales every axis, its noise too
                hint = "looks like deg/s, not rad/s"
            elif as_deg:
                hint = f"looks like deg/s (not rad/s), or specific force under the {COLUMNS[4 + odd[0]]} header"
            else:
                hint = "the gyro columns do not read a gyro at rest: another unit or another quantity under the header"
            if hint is not None:
                if kind == "columns":
                    cause, value, bound, col = "gravity_on_gyro", w_mag, band, ""
                elif bias_bad.any():
                    cause, value, bound, col = "rest_bias", abs(w_mean[jb]), rest_limit, COLUMNS[4 + jb]
                else:
                    cause, value, bound, col = "rest_noise", noise[jn], noise_limit, COLUMNS[4 + jn]
                add(kind, cause, f"{src}: angular rate at rest: {'; '.join(said)}: {hint}", value, bound, col)
    if not gyro_said:
        p99 = float(np.percentile(np.linalg.norm(rec.omega, axis=1), 99))
        if p99 > MOVING_RATE_LIMIT_RADPS:
            add("gyro_unit", "percentile", f"{src}: angular rate: 1 % of the samples exceed {p99:.3g} rad/s, expected "
                f"at most {MOVING_RATE_LIMIT_RADPS:g} rad/s (a ground robot's turns): looks like deg/s, not rad/s, "
                "or another quantity under the gyro header", p99, MOVING_RATE_LIMIT_RADPS)
    return tuple(out)


def plausibility_problems(rec: Recording) -> list[str]:
    """One line per way a recording of the MoRPI layout is implausible for a phone IMU in SI units and z up.

    The lines of :func:`rest_problems` with the phones' error figures
    (:data:`MEMS_SPEC`) and the first still stretch as the rest.

    Parameters
    ----------
    rec : Recording
        The recording, as loaded (SI units claimed, phone axes).

    Returns
    -------
    list of str
        The problems, each one line starting with ``rec.source``; empty when
        the recording is plausible.

    Examples
    --------
    A phone at rest, then the same recording with the accelerometer written in g:

    >>> rng = np.random.default_rng(0)
    >>> t = np.arange(400) * 0.01
    >>> f = [0.1, -0.2, 9.8] + 0.02 * rng.standard_normal((400, 3))
    >>> w = [0.01, 0.0, -0.02] + 0.002 * rng.standard_normal((400, 3))
    >>> plausibility_problems(Recording(time=t, f=f, omega=w, source="a.csv"))
    []
    >>> import textwrap
    >>> for line in plausibility_problems(Recording(time=t, f=f / G0, omega=w, source="a.csv")):
    ...     print(textwrap.fill(line, 90))
    a.csv: specific force at rest is 1.00 m/s^2 (f = (0.00994, -0.0204, 0.999)), expected |f|
    = 9.81 +- 2.11 m/s^2: looks like the accelerometer is in g, not m/s^2
    """
    return [p.message for p in rest_problems(rec, spec=MEMS_SPEC, rest="auto")]


def check_plausible(rec: Recording) -> Recording:
    """Return `rec` when it is plausible (:func:`plausibility_problems`), else raise.

    Parameters
    ----------
    rec : Recording
        The recording to check.

    Returns
    -------
    Recording
        `rec` itself.

    Raises
    ------
    DataError
        One line: the source, then every problem of :func:`plausibility_problems`.

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> t = np.arange(300) * 0.01
    >>> w = 0.002 * rng.standard_normal((300, 3))
    >>> f = np.column_stack([np.zeros(300), 0.02 * rng.standard_normal(300), 9.8 + 0.02 * rng.standard_normal(300)])
    >>> check_plausible(Recording(time=t, f=f, omega=w, source="b.csv"))
    Traceback (most recent call last):
    ...
    morpi_filters.errors.DataError: b.csv: column f_x is all zero in all 300 samples: a dead channel, ...
    """
    problems = plausibility_problems(rec)
    if problems:
        prefix = f"{rec.source}: "
        raise DataError(prefix + "; ".join(p[len(prefix):] if p.startswith(prefix) else p for p in problems))
    return rec


