"""The pages' studies (gain error, drift) and what a page costs."""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..choice import choose
from ..deprecation import renamed_attribute, renamed_keywords
from ..results import round_significant
from ..units import DEG_S, MPU6500, SensorSpec
from .config import DRIFT_SEED, METHODS, GainError, StudyConfig, StudyResult
from .drift import DriftMap, drift_map
from .engine import check_runs, default_chunk, run_studies, sample_count, study_seed, summarize
from .training import TrainingStudy, training_configs, training_summary

# ----------------------------------------------------------------------------- the pages' studies

#: Two-sided 99 % normal quantile used for the Monte Carlo confidence bounds.
Z99 = 2.5758293035489004

#: Assumed per-run gain spread and motion mismatch (fractions) when no field gain training is available.
ASSUMED_SPREAD = 0.05
#: The motion mismatch of :data:`ASSUMED_SPREAD`'s assumption (a fraction).
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
        from .. import evaluate  # noqa: F401
        fn = getattr(evaluate, "training_gain_spread")
    except (ImportError, AttributeError):
        return None, None, ("the per-run gain training of the field pipeline (steps.py / evaluate.py) "
                            "is not available in this build")
    from ..fetch import dataset_identity

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
    >>> from morpi_filters.montecarlo import StudyConfig, run_study
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
    >>> from morpi_filters.montecarlo import GainError, StudyConfig, run_study
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
        JSON values; sigmas in SI units (noise as the per-sample sigma at the study's rate). ``period_m``
        repeats ``p2p_m`` and ``cal_seconds`` ``cal_window_s``, their names before 0.2, for one
        release.
    """
    sa, sg = cfg.bias_sigmas()
    length, speed, duration = cfg.motion()
    return {"sensor": cfg.spec.name, "duration_s": duration, "rate_hz": cfg.rate_hz, "length_m": length,
            "speed_mps": speed, "ins_path": cfg.ins_path, "p2p_m": cfg.p2p_m, "period_m": cfg.p2p_m, "amplitude_m": cfg.amplitude_m, "calibration": cfg.calibration,
            "cal_window_s": cfg.cal_window_s, "cal_seconds": cfg.cal_window_s, "accel_bias_sigma_mps2": sa, "gyro_bias_sigma_radps": sg,
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
#: The cost model's fixed seconds, coefficients of ``(1, n, n^2, K)`` (see :data:`RUN_SECONDS`).
FIXED_SECONDS = (3.16, 8.32e-5, 1.02e-9, 2.0e-3)
#: The cost model's fixed memory [bytes], coefficients of ``(1, n, n^2, K)`` (see :data:`RUN_SECONDS`).
FIXED_BYTES = (2.55e8, 815.0, 0.13, 8.43e4)
#: The cost model's memory per run [bytes] (see :data:`RUN_SECONDS`).
RUN_BYTES = 0.63e3
#: The cost model's memory per sample of a run a chunk holds beyond the default chunk [bytes].
CHUNK_SAMPLE_BYTES = 107.0
FIELD_SECONDS, FIELD_BYTES = 5.3, 0.17e9


@dataclass(frozen=True)
class PageCost:
    """The estimated cost of a gain-error page (:func:`page_cost`).

    Attributes
    ----------
    runs : int
        Monte Carlo runs.
    duration_s : float
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
    duration_s: float
    samples: int
    steps: int
    seconds: float
    bytes: float


PageCost.__init__ = renamed_keywords(duration="duration_s")(PageCost.__init__)
PageCost.duration = renamed_attribute("PageCost", "duration", "duration_s")


@renamed_keywords(duration="duration_s")
def page_cost(runs: int, *, duration_s: float | None = None, speed_mps: float | None = None, chunk: int | None = None,
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
    duration_s, speed_mps : float, optional
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

    >>> short, long = page_cost(100_000), page_cost(100_000, duration_s=60.0)
    >>> short.samples, long.samples, bool(long.seconds > 4 * short.seconds > 0)
    (1501, 6001, True)
    """
    check_runs(runs, 0, chunk)
    cfg = StudyConfig(duration_s=duration_s, speed_mps=speed_mps)
    cfg.validate()
    length, _, T = cfg.motion()
    n = sample_count(T, cfg.rate_hz)
    k = max(1, math.ceil(length / cfg.p2p_m) - 1)
    terms = (1.0, float(n), float(n) * n, float(k))
    seconds = runs * sum(c * t for c, t in zip(RUN_SECONDS, (float(n), float(n) * n, float(k) * n)))
    seconds += sum(c * t for c, t in zip(FIXED_SECONDS, terms))
    nbytes = sum(c * t for c, t in zip(FIXED_BYTES, terms)) + runs * RUN_BYTES
    default = min(default_chunk(n), runs)
    if chunk is not None and min(chunk, runs) > default:
        nbytes += (min(chunk, runs) - default) * n * CHUNK_SAMPLE_BYTES
    if field:
        seconds, nbytes = seconds + FIELD_SECONDS, nbytes + FIELD_BYTES
    return PageCost(runs=int(runs), duration_s=T, samples=n, steps=k, seconds=seconds, bytes=nbytes)


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


@renamed_keywords(source="data_source", duration="duration_s")
def gain_error_page(*, runs: int, seed: int, chunk=None, scheduler=None, data_source=None, tables=None,
                    duration_s: float | None = None, speed_mps: float | None = None) -> GainErrorPage:
    """Compute the gain-error Monte Carlo section.

    Two studies with the same seed: the primary one after a zero-order
    calibration on 3 s of rest (the paper's GAC baselines; MoRPI does not use
    the accelerometer bias), and one with the full datasheet turn-on biases.
    Gain scenarios: 5 % and 10 % (the paper) and the spread of per-run training
    gains (from the dataset when the field gain training is available,
    otherwise an assumed value, stated on the page). Then the gain-training
    study over k training runs. `tables` (an ``evaluate.TablesResult`` of
    ``data_source.root``) gives the trained gains when already computed;
    `duration_s` and `speed_mps` shape the sine path as in :class:`StudyConfig`.

    Parameters
    ----------
    runs : int
        Monte Carlo runs per study.
    seed : int or numpy.random.Generator
        Study seed, as in :func:`run_study`.
    chunk, scheduler
        As in :func:`run_study`.
    data_source : results.DataSource, optional
        The dataset whose per-run training gains give the spread scenario
        (None: the assumed spread and mismatch).
    tables : evaluate.TablesResult, optional
        Already computed tables of ``data_source.root``.
    duration_s : float, optional
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
    seed = study_seed(seed)
    check_runs(runs, seed, chunk)
    spread, mismatch, spread_note = _field_gain_spread(data_source, tables)
    assumed = spread is None
    if assumed:
        spread, mismatch = ASSUMED_SPREAD, ASSUMED_MISMATCH
    gains = (GainError("dG = 5 %", 0.05), GainError("dG = 10 %", 0.10),
             GainError("training spread", mismatch, spread))
    cal = StudyConfig(gains=gains, calibration="GAC", duration_s=duration_s, speed_mps=speed_mps)
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
                         synthetic=bool(getattr(data_source, "synthetic", False)))


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
