"""Steps from a prepared signal: boundaries, Weinberg sums, headings per step and the periodic-motion check."""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .. import _jit
from . import _loops
from ..errors import DataError, ParameterError
from .reckon import weinberg_length
from .rules import DEFAULT_CONFIGS, Peaks, StepConfig, Steps
from .prepare import PreparedSignal, prepare_signal, recording_heading, small_median



def extract_steps(rec, method: str, config: StepConfig | None = None, *, rest_end_time: float | None = None,
                  heading=None, prepared: PreparedSignal | None = None, peak_cache: dict | None = None) -> Steps:
    """Find the steps of one run.

    Parameters
    ----------
    rec : Recording or None
        (Calibrated or raw) recording; may be None when `prepared` is given.
    method : str
        ``"MoRPI-A"`` (f_y) or ``"MoRPI-G"`` (omega_z).
    config : StepConfig, optional
        Default: ``DEFAULT_CONFIGS[method]``.
    rest_end_time : float, optional
        End of the initial rest [s] (baseline for the motion span).
    heading : ndarray, shape (n,), optional
        Heading on the recording's samples [rad]; default: as
        ``config.heading_source`` says, from the first sample: the integrated
        omega_z, or the yaw of the 3D attitude
        (:func:`morpi_filters.strapdown.attitude_heading`) started level with
        the mean specific force before `rest_end_time` (the first 2 s without
        it).
    prepared : PreparedSignal, optional
        Output of :func:`prepare_signal` with ``config.cutoff_hz`` and
        ``config.grid_hz`` (saves the
        resampling and filtering when many configs are tried).
    peak_cache : dict, optional
        Reuses the peaks found for the same recording, method, cut-off,
        grid, peak thresholds and segment rule, and the steps' Weinberg
        weights read from the same signal (``amplitude_from``). Without
        ``min_height`` the peaks do not depend on a constant offset of the
        signal (the prominence is relative to its range, the width measured
        from the prominence), so one entry serves the raw and the
        gyro-calibrated signal; with it the peaks are kept on the prepared
        signal only.

    Returns
    -------
    Steps
        Step boundaries, Weinberg weights, end-step fractions and headings,
        each of shape (k,), with the peaks, the motion span and the median
        heading swing.

    Raises
    ------
    DataError
        Naming the recording when fewer than two peaks are found (no periodic
        motion).

    Examples
    --------
    >>> from morpi_filters import simulate, units
    >>> traj = simulate.sine(6.3, p2p_m=1.0, amplitude_m=0.1)
    >>> rec = simulate.imu(traj, units.LSM6DSL, np.random.default_rng(0), bias_scale=(0.0, 0.0)).recording()
    >>> s = extract_steps(rec, "MoRPI-G")
    >>> s.start_time.shape == s.end_time.shape == s.weight.shape == s.heading.shape, bool(s.n > 2)
    (True, True)
    """
    if config is None:
        if method not in DEFAULT_CONFIGS:
            raise ParameterError(f"method={method!r}: expected one of {tuple(DEFAULT_CONFIGS)}")
        config = DEFAULT_CONFIGS[method]
    if prepared is None:
        if heading is None and config.heading_source == "attitude":
            heading = recording_heading(rec, rest_end_time)
        prepared = prepare_signal(rec, method, config.cutoff_hz, rest_end_time=rest_end_time, heading=heading,
                                  grid_hz=config.grid_hz)
    else:
        _check_prepared(prepared, method, config)
    (st, et, weight, frac, _, _, med, peaks), dpsi = _find_steps(prepared, method, config, peak_cache)
    return Steps(start_time=st, end_time=et, weight=weight, fraction=frac, heading=dpsi, peaks=peaks,
                 motion=prepared.motion, swing_deg=med)


class StepSums(NamedTuple):
    """What a gain and an end point need of a run's steps (:func:`step_sums`)."""

    #: ``sum(weight * fraction)`` (:attr:`Steps.effective_weight`): the distance per unit gain.
    w: float
    #: The end point's x per unit gain, ``sum(weight * fraction * cos(heading))``.
    ux: float
    #: The end point's y per unit gain, ``sum(weight * fraction * sin(heading))``.
    uy: float
    #: Median heading swing per period [deg] (:attr:`Steps.swing_deg`).
    swing_deg: float
    #: Number of steps (:attr:`Steps.n`).
    n: int


def step_sums(prepared: PreparedSignal, method: str, config: StepConfig, *, peak_cache: dict | None = None
              ) -> StepSums:
    """What a gain and an end point need of a run's steps, without building them.

    MoRPI's end point is linear in the gain: a run dead-reckoned with gain
    ``G`` travels ``G * w`` and ends at ``G * (ux, uy)``. The train-only rule
    searches score thousands of rules on these sums alone.

    Parameters
    ----------
    prepared : PreparedSignal
        Output of :func:`prepare_signal` with ``config.cutoff_hz`` and ``config.grid_hz``.
    method : str
        ``"MoRPI-A"`` or ``"MoRPI-G"``.
    config : StepConfig
        The step rule.
    peak_cache : dict, optional
        As for :func:`extract_steps` (the two share it, and the prepared
        signal's memo).

    Returns
    -------
    StepSums
        ``w = sum(weight * fraction)`` (:attr:`Steps.effective_weight`), the
        end point per unit gain ``(ux, uy) = sum(weight * fraction * [cos,
        sin](heading))``, the median heading swing per period ``swing_deg``
        [deg] and the number of steps ``n``: what the :class:`Steps` of
        :func:`extract_steps` give, the sums to rounding (a compiled loop
        adds the steps' own terms in step order).

    Raises
    ------
    DataError
        As :func:`extract_steps`.

    Examples
    --------
    >>> from morpi_filters import simulate, units
    >>> from morpi_filters.steps import extract_steps, morpi_track
    >>> traj = simulate.sine(6.3, p2p_m=1.0, amplitude_m=0.1)
    >>> rec = simulate.imu(traj, units.LSM6DSL, np.random.default_rng(0), bias_scale=(0.0, 0.0)).recording()
    >>> cfg = DEFAULT_CONFIGS["MoRPI-G"]
    >>> w, ux, uy, _, n = step_sums(prepare_signal(rec, "MoRPI-G", cfg.cutoff_hz), "MoRPI-G", cfg)
    >>> end = morpi_track(extract_steps(rec, "MoRPI-G", cfg), gain=1.0).end_point
    >>> bool(np.allclose([ux, uy], end, rtol=1e-12, atol=1e-12))
    True
    """
    _check_prepared(prepared, method, config)
    pkey, _, bt, psi_b, psi_m, per, _, weight, med, wmed = _boundaries(prepared, method, config, peak_cache)
    require_swing(prepared.source, method, med, config.min_swing_deg)
    heading = _HEADING_CODES[config.heading]
    edge = _edge_values(prepared, config, pkey, bt, psi_b) if heading >= 2 else _NO_EDGES
    m0, m1 = prepared.motion
    w, ux, uy, n = _loops.compiled()["reading_sums"](
        bt, psi_b, weight, edge, m0, m1, psi_m[0], psi_m[1], per, wmed, _ENDS_CODES[config.ends], heading)
    return StepSums(w, ux, uy, med, n)


#: The codes of the readings in ``_loops.reading_sums``.
_HEADING_CODES = {"absolute": 0, "change": 1, "turns": 2, "mean": 3}
_ENDS_CODES = {"drop": 0, "fraction": 1, "whole": 2}
_NO_EDGES = np.zeros(0)
_NO_EDGES.flags.writeable = False                               # as the edge values: one compiled reading_sums


def _check_prepared(prepared, method, config):
    if prepared.cutoff_hz != config.cutoff_hz or prepared.method != method or prepared.grid_hz != config.grid_hz:
        raise ParameterError(f"{prepared.source}: prepared signal ({prepared.method}, cutoff {prepared.cutoff_hz}, "
                             f"grid_hz {prepared.grid_hz}) does not match ({method}, cutoff {config.cutoff_hz}, "
                             f"grid_hz {config.grid_hz})")


def _boundaries(p, method, config, peak_cache):
    """What every reading of a run's peaks shares, memoized on the prepared signal (its heading) and in
    `peak_cache`: ``(pkey, wkey, bt, psi_b, psi_m, per, bounds, weight, med, wmed)``, the peak set's key
    and with the weights' source, the boundary times and headings, the headings at the motion's ends, the
    median step duration, the boundaries' grid indices, the whole steps' Weinberg weights, the median
    heading swing [deg] and the median weight."""
    memo = p.steps_memo
    rule = (config.prominence, config.min_period_s, config.min_height, config.min_width_s, config.segment,
            config.amplitude_from)
    out = memo.get(rule)                                        # the rule's peaks on this signal, found before
    if out is not None:
        return out
    grid, g, graw, t = p.grid, p.filtered, p.raw, p.time
    m0, m1 = p.motion
    i0, i1 = p.motion_index
    if i1 - i0 < 3:
        raise DataError(f"{p.source}: no periodic motion found in the {method} signal")
    lo, hi = p.span
    if not hi - lo > 0:
        raise DataError(f"{p.source}: no periodic motion found in the {method} signal (flat signal)")
    prom = config.prominence * (hi - lo)
    # the peaks, the boundaries and the weights do not depend on the heading: kept in `peak_cache` (shared by
    # the prepared signals of the same recording, method and cut-off, which may differ by a constant offset:
    # an absolute height threshold keeps its peaks on the prepared signal); the headings on the prepared signal
    shared = peak_cache if config.min_height is None else None
    cache = p.steps_memo if shared is None else shared
    pkey = (p.source, method, config.cutoff_hz, config.prominence, config.min_period_s, config.min_height,
            config.min_width_s, p.rate_hz, config.segment)
    found = cache.get(pkey)
    if found is None:
        dist = max(1, int(round(config.min_period_s * p.rate_hz)))
        width = None if config.min_width_s is None else config.min_width_s * p.rate_hz
        seg = g[i0:i1]
        ckey = (p.source, method, config.cutoff_hz, config.min_period_s, config.min_height, p.rate_hz)
        imax = _prominent(seg, dist, prom, cache, ckey + ("max",), height=config.min_height, width=width) + i0
        if config.segment == "extrema":
            imin = _prominent(-seg, dist, prom, cache, ckey + ("min",), height=config.min_height, width=width) + i0
            bounds = np.sort(np.concatenate([imax, imin]))
        else:
            bounds = imax
        bt = grid[bounds]
        bt.flags.writeable = False                              # shared by the Steps of every reading
        found = cache[pkey] = (imax, bounds, bt, small_median(bt[1:] - bt[:-1]) if bt.size >= 2 else float("nan"))
    imax, bounds, bt, per = found
    if bounds.size < 2:
        raise DataError(f"{p.source}: no periodic motion found in the {method} signal "
                        f"({bounds.size} peak(s) between {m0 - t[0]:.1f} s and {m1 - t[0]:.1f} s)")
    wkey = pkey + (config.amplitude_from,)
    found = cache.get(wkey)
    if found is None:
        amp = g if config.amplitude_from == "filtered" else graw
        # max and min over each closed interval [bounds[j], bounds[j+1]] of the grid
        vmax = np.maximum(np.maximum.reduceat(amp, bounds[:-1])[:bounds.size - 1], amp[bounds[1:]])
        vmin = np.minimum(np.minimum.reduceat(amp, bounds[:-1])[:bounds.size - 1], amp[bounds[1:]])
        weight = weinberg_length(vmax, vmin, 1.0)
        weight.flags.writeable = False                          # shared by every Steps of this key
        found = cache[wkey] = (weight, small_median(weight))
    weight, wmed = found
    # the headings: at the motion's ends, at the boundaries, and the swing between the maxima
    psi = p.heading
    kernel = _loops.compiled()
    psi_m = memo.get("motion heading")
    if psi_m is None:
        psi_m = memo["motion heading"] = np.interp([m0, m1], t, psi)
    bkey = ("boundary heading", pkey)
    psi_b = memo.get(bkey)
    if psi_b is None:
        psi_b = memo[bkey] = np.interp(bt, t, psi)
        psi_b.flags.writeable = False                           # shared by the Steps of every reading
    skey = ("swing",) + pkey[3:8]                               # the maxima: their thresholds, the grid
    med = memo.get(skey)
    if med is None:
        med = memo[skey] = float(kernel["swing_median"](_jit.read_only(t), _jit.read_only(psi),
                                                        _jit.read_only(grid[imax])))
    out = memo[rule] = (pkey, wkey, bt, psi_b, psi_m, per, bounds, weight, med, wmed)
    return out


def _edge_values(p, config, pkey, bt, psi_b) -> np.ndarray:
    """What the heading readings "turns" and "mean" read at ``[m0, bt..., m1]`` (the motion's ends and the
    boundaries, where every step starts and ends): the turn heading, or the heading's running integral.
    Memoized on the prepared signal; read-only."""
    memo = p.steps_memo
    if config.heading == "turns":
        key = ("turn values", pkey, config.turn_deg)            # the stretches do not depend on the ends
    else:
        key = ("integral values", pkey)
    out = memo.get(key)
    if out is None:
        x = np.empty(bt.shape[0] + 2)
        x[0], x[1:-1], x[-1] = p.motion[0], bt, p.motion[1]
        if config.heading == "turns":
            # turn_heading(x, t, psi, turn_stretches(bt, psi_b, ...), integral=...) in one compiled call
            out = np.empty(x.shape[0])
            ro = _jit.read_only
            _loops.compiled()["turn_values"](ro(bt), ro(psi_b), np.radians(config.turn_deg),
                                             2 if config.segment == "extrema" else 1,
                                             ro(x), ro(p.time), ro(p.heading), ro(p.heading_integral), out)
        else:
            out = np.interp(x, p.time, p.heading_integral)
        out.flags.writeable = False
        memo[key] = out
    return out


def _find_steps(p, method, config, peak_cache):
    """The steps of :func:`extract_steps`: the parts every heading reading shares and the heading."""
    pkey, wkey, bt, psi_b, psi_m, per, bounds, weight, med, wmed = _boundaries(p, method, config, peak_cache)
    m0, m1 = p.motion
    memo = p.steps_memo
    peaks = memo.get(("peaks", pkey))
    if peaks is None:
        idx = np.minimum(np.searchsorted(p.time, bt), p.time.shape[0] - 1)
        idx.flags.writeable = False
        lo, hi = p.span
        peaks = memo[("peaks", pkey)] = Peaks(grid_time=p.grid, grid_signal=p.filtered, grid_index=bounds, index=idx,
                                              properties={"prominence_threshold": config.prominence * (hi - lo)})
    mkey = wkey + (config.ends,)
    if mkey in memo:
        st, et, weight, frac, psi_s, psi_e, med, peaks = memo[mkey]
    else:
        if config.ends == "drop":
            st, et, psi_s, psi_e = bt[:-1], bt[1:], psi_b[:-1], psi_b[1:]
            frac = np.ones_like(weight)
        else:
            parts = []
            for f in ((bt[0] - m0) / per, (m1 - bt[-1]) / per):
                f = min(max(f, 0.0), 1.0)
                if config.ends == "whole":
                    f = 1.0 if f >= 0.5 else 0.0
                parts.append(f)
            st = np.concatenate([[m0], bt])
            et = np.concatenate([bt, [m1]])
            psi_s = np.concatenate([psi_m[:1], psi_b])
            psi_e = np.concatenate([psi_b, psi_m[1:]])
            weight = np.concatenate([[wmed], weight, [wmed]])
            frac = np.concatenate([[parts[0]], np.ones(bt.shape[0] - 1), [parts[1]]])
        for a in (st, et, weight, frac, psi_s, psi_e):
            a.flags.writeable = False                           # shared by the Steps of every reading
        memo[mkey] = (st, et, weight, frac, psi_s, psi_e, med, peaks)
    require_swing(p.source, method, med, config.min_swing_deg)
    if config.heading == "absolute":
        return memo[mkey], psi_e
    if config.heading == "change":
        return memo[mkey], psi_e - psi_s
    # the turn heading or the heading's integral at the steps' edges: the steps tile the motion (each
    # starts where the one before ends), so the edges are [m0, bt..., m1], or bt when the ends are dropped
    edge = _edge_values(p, config, pkey, bt, psi_b)
    edge = edge[1:-1] if config.ends == "drop" else edge
    if config.heading == "turns":
        return memo[mkey], psi_e - psi_s + edge[:-1]
    # the mean heading over each step; the heading at its start for a step of no length
    span = et - st
    return memo[mkey], np.divide(edge[1:] - edge[:-1], span, out=np.array(psi_s), where=span > 1e-9)


def _prominent(x, distance, prominence, cache, key, *, height=None, width=None):
    """``scipy.signal.find_peaks(x, height=height, distance=distance, prominence=prominence, width=width)[0]``,
    with the peaks kept by the height and the distance, their prominences and, once asked, their widths cached
    under `key`: find_peaks applies the height and the distance before it measures the prominences, and
    measures each peak's width from its own prominence, so every prominence and width threshold selects from
    the same candidates."""
    from scipy import signal as scipy_signal

    found = cache.get(key)
    if found is None:
        peaks, props = scipy_signal.find_peaks(x, height=height, distance=distance, prominence=0.0)
        found = cache[key] = {"peaks": peaks, "prominences": props["prominences"],
                              "bases": (props["left_bases"], props["right_bases"])}
    keep = found["prominences"] >= prominence
    if width is not None:
        widths = found.get("widths")
        if widths is None:
            widths = found["widths"] = scipy_signal.peak_widths(
                x, found["peaks"], rel_height=0.5, prominence_data=(found["prominences"], *found["bases"]))[0]
        keep &= widths >= width
    return found["peaks"][keep]


def require_swing(source, method: str, swing_deg: float, min_swing_deg: float) -> None:
    """Refuse a run whose median heading swing per period is below `min_swing_deg` (not a sine path).

    Parameters
    ----------
    source : str
        The recording, named in the message.
    method : str
        The MoRPI method whose signal the periods were found on.
    swing_deg : float
        The run's median heading swing per period [deg] (:attr:`Steps.swing_deg`;
        NaN when fewer than two periods: nothing to check).
    min_swing_deg : float
        The least swing of a periodic run [deg] (:attr:`StepConfig.min_swing_deg`).

    Returns
    -------
    None

    Raises
    ------
    DataError
        Naming the recording, its swing and the least swing expected.

    Examples
    --------
    >>> require_swing("run.csv", "MoRPI-G", 40.0, 15.0)          # a sine path: nothing happens
    >>> require_swing("run.csv", "MoRPI-G", 6.0, 15.0)
    Traceback (most recent call last):
    ...
    morpi_filters.errors.DataError: run.csv: no periodic motion found in the MoRPI-G signal (median heading swing 6.0 deg per period, expected at least 15 deg for a sine path)
    """
    if swing_deg < min_swing_deg:
        raise DataError(f"{source}: no periodic motion found in the {method} signal (median heading "
                        f"swing {swing_deg:.1f} deg per period, expected at least "
                        f"{min_swing_deg:g} deg for a sine path)")
