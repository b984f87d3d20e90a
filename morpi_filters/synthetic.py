"""A synthetic dataset in the field dataset's layout and CSV format.

:func:`write_dataset` writes the field dataset's folder layout and CSV
format with seeded synthetic recordings; :func:`ensure_synthetic_dataset`
caches one and verifies it on reuse. Realism choices (all in
:data:`REALISTIC_BIAS_FRACTION` and :data:`DATASET_OPTIONS`): turn-on
biases at a fraction of the datasheet 1 sigma (the field rest periods show
gyro offsets far below the datasheet's 3 and 6 deg/s), mounting tilt,
vibration while moving, bias instability, and run-to-run spread of speed,
period length and amplitude (a person drove the robot). Both phones
share the trajectory of each long-route run, as in the field.

Known difference from the field files: the field S6 L-route recordings
read about 10 deg nose-down at the start and about 7 deg at the end,
while the route's ground truth (15 deg over the first 5 m, level after)
gives 15 deg and 0 deg here.
"""
from __future__ import annotations

import json
import math
import zlib
from pathlib import Path

import numpy as np

from . import dataset, units
from .deprecation import with_aliases
from .errors import ParameterError
from .fetch import sha256_file
from .simulate import L_ROUTE_SPEED, imu, paper_speed, route_trajectory

__all__ = ["write_dataset", "ensure_synthetic_dataset", "GENERATOR_VERSION", "REALISTIC_BIAS_FRACTION", "PHONE_CLOCKS",
           "DATASET_OPTIONS"]

#: Version of the synthetic-dataset generator; a cached dataset with another version is rebuilt.
#: Bump it whenever the written files change for the same seed.
GENERATOR_VERSION = "4"

#: Turn-on biases drawn in the synthetic dataset, as a fraction of the datasheet 1 sigma
#: (accelerometer, gyro). The rest periods of the field recordings show per-axis gyro offsets of
#: about 0.3-1.8 deg/s on the S8 and 0.3-0.6 deg/s on the S6, far below the datasheet's 3 and
#: 6 deg/s, so drawing at the full datasheet sigma would make every synthetic run much worse
#: than the field runs.
REALISTIC_BIAS_FRACTION = {"s6": (0.25, 0.1), "s8": (0.25, 0.3)}
#: Each phone's clock, as :func:`morpi_filters.simulate.sample_times` draws it: the Galaxy S6's stamps
#: wander between about 100 and 50 Hz, the S8's stay near 100 Hz with a little jitter.
PHONE_CLOCKS = {"s6": "two-rate", "s8": "jittered"}

#: Other realism settings of the synthetic dataset (see :func:`imu`):
#:
#: - ``misalignment``: 1-sigma mounting misalignment [rad]; the field rest periods show
#:   1-4 deg of phone tilt.
#: - ``vibration``: rms of the motion vibration (accelerometer [m/s^2], gyro [rad/s]).
#: - ``bias_instability``, ``correlation_time``: Gauss-Markov bias (accelerometer [m/s^2],
#:   gyro [rad/s]) and its correlation time [s]: the part a rest-period calibration cannot
#:   remove, so a calibrated INS drifts by decimetres to metres over a straight recording.
#:   The synthetic calibrated INS still drifts several times less than the paper's INS table
#:   (real phones on a moving robot have more error sources than this model).
#: - ``amplitude_factor``: scales the routes' ``amplitude_m``. The field recordings' z-rate
#:   peaks (median 0.72 rad/s with 1 m periods, 0.99 rad/s with 1.5 m periods, S8) and
#:   lateral specific-force peaks are 0.4-0.5 of those of a sine with the full amplitude at
#:   the same pace: the robot's lateral excursion was about half the stated amplitude (as if
#:   0.1 m were peak to peak).
#: - ``speed_spread``, ``period_spread``, ``amplitude_spread``: run-to-run spread (1 sigma,
#:   relative) of the driven speed, period length and amplitude (a person drove the robot).
DATASET_OPTIONS = {
    "misalignment": 1.5 * units.DEG,
    "vibration": (0.12, 0.02),
    "bias_instability": (0.03, 0.0015),
    "correlation_time": 30.0,
    "amplitude_factor": 0.5,
    "speed_spread": 0.12,
    "period_spread": 0.05,
    "amplitude_spread": 0.12,
}


_MANIFEST = "manifest.json"
# keys of a run in the manifest renamed in 0.2 (old -> new), written beside the new ones for one release
_RUN_INFO_ALIASES = {"speed_m_s": "speed_mps", "period_m": "p2p_m"}
#: The kind of output a synthetic dataset folder's marker records.
DATASET_KIND = "dataset"


def _seed_for(seed: int, *labels) -> np.random.SeedSequence:
    """A child seed keyed by labels (stable, independent of the order files are written)."""
    key = tuple(zlib.crc32(str(x).encode()) for x in labels)
    return np.random.SeedSequence(entropy=int(seed), spawn_key=key)


def _synthetic_run(seed: int, folder: str, run: int) -> tuple[dataset.Recording, dict]:
    """Simulate run `run` (1-based) of a dataset folder such as ``s8/short_distance/train``."""
    parts = folder.split("/")
    phone, route_name = parts[0], parts[1]
    split = parts[2] if len(parts) > 2 else None
    r = dataset.route(route_name)
    spec = dataset.folder_imu(folder)                                   # the phone's IMU, as the MoRPI manifest names it
    # both phones recorded the long route at once in the field: share its trajectory draws
    traj_key = ("long_distance", split, run) if route_name == "long_distance" else (folder, run)
    trng = np.random.default_rng(_seed_for(seed, "trajectory", *traj_key))
    irng = np.random.default_rng(_seed_for(seed, "imu", folder, run))
    o = DATASET_OPTIONS
    jitter = trng.standard_normal(4)
    if len(r.segments_m) == 2:
        base = L_ROUTE_SPEED
    elif r.kind == "periodic":
        base = paper_speed(r.p2p_m)
    else:
        base = paper_speed()
    speed = base * math.exp(o["speed_spread"] * jitter[0])
    kw = dict(speed_mps=speed, rest_s=tuple(trng.uniform(3.0, 4.5, 2)), t0=float(trng.uniform(0.3, 0.5)))
    if r.kind == "periodic":
        kw["p2p_m"] = r.p2p_m * (1.0 + o["period_spread"] * float(np.clip(jitter[1], -2.5, 2.5)))
        kw["amplitude_m"] = (r.amplitude_m * o["amplitude_factor"]
                           * (1.0 + o["amplitude_spread"] * float(np.clip(jitter[2], -2.5, 2.5))))
    traj = route_trajectory(route_name, **kw)
    data = imu(traj, spec, irng, sampling=PHONE_CLOCKS[phone], bias_scale=REALISTIC_BIAS_FRACTION[phone],
               misalignment=o["misalignment"], vibration=o["vibration"], bias_instability=o["bias_instability"],
               correlation_time=o["correlation_time"])
    rel = f"{folder}/{run}.csv"
    rec = data.recording(source=rel, phone=phone, route=route_name, split=split)
    info = dict(speed_mps=speed, p2p_m=kw.get("p2p_m"), amplitude_m=kw.get("amplitude_m"),
                distance_m=traj.distance, start_time=traj.start_time, stop_time=traj.stop_time)
    info = with_aliases(info, _RUN_INFO_ALIASES)
    return rec, info


_README = """# Synthetic MoRPI dataset

Seeded synthetic recordings in the layout and CSV format of the MoRPI field
dataset (`time,f_x,f_y,f_z,g_x,g_y,g_z`; s, m/s^2, rad/s, phone axes, z up),
written by `morpi simulate` (morpi_filters.simulate, generator version {version},
seed {seed}). Routes follow `data/routes.json`; the S6 files have irregular
time stamps like the field S6 files. Turn-on biases are drawn at a fraction of
the datasheet 1 sigma (accelerometer, gyro): S6 {s6}, S8 {s8}. `manifest.json`
lists every file's sha256 and the per-run speed, period and amplitude.
"""


def write_dataset(out, *, seed: int = 0, runs_per_folder: int | None = None) -> Path:
    """Write a synthetic dataset in the field dataset's layout and CSV format.

    Parameters
    ----------
    out : str or Path
        Destination folder. It is built in a staging folder beside it and
        renamed into place when complete; an existing folder is replaced only
        if it is empty or an earlier synthetic dataset holding nothing but the
        files morpi wrote (those its ``.morpi-output`` marker lists, or, for a
        dataset of an earlier version, its manifest), otherwise a
        ParameterError naming what is in the way is raised before anything is
        computed.
    seed : int
        Seed; each file draws from a child seed keyed by its folder and run,
        so the output does not depend on the order files are written.
    runs_per_folder : int, optional
        Runs in every folder (default: as many as the field dataset,
        ``data/routes.json`` "layout").

    Returns
    -------
    Path
        The dataset root (`out`). It holds ``<phone>/<route>[/<split>]/<run>.csv``
        for every folder of the layout, a ``README.md``, ``manifest.json`` (seed,
        generator version, every file's sha256 and each run's speed, period,
        amplitude, distance and motion times) and the ``.morpi-output`` marker.

    Raises
    ------
    ParameterError
        A negative or non-integer `seed`, or a `runs_per_folder` below 1.
    ParameterError
        `out` exists and holds files morpi did not write, or another kind of morpi output.

    Examples
    --------
    One run per folder (about half a second):

    >>> import tempfile
    >>> root = write_dataset(Path(tempfile.mkdtemp()) / "synthetic", seed=1, runs_per_folder=1)
    >>> files = sorted(p.relative_to(root).as_posix() for p in root.rglob("*.csv"))
    >>> len(files) == len(dataset.layout()), files[0]
    (True, 's6/L_line/1.csv')
    >>> dataset.load_csv(root / files[0]).f.shape[1]
    3
    """
    out = Path(out)
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ParameterError(f"seed: expected a non-negative integer, got {seed!r}")
    if runs_per_folder is not None and (isinstance(runs_per_folder, bool) or
                                        not isinstance(runs_per_folder, (int, np.integer)) or runs_per_folder < 1):
        raise ParameterError(f"runs_per_folder: expected a positive integer, got {runs_per_folder!r}")
    from .outputs import MARKER, Outputs, check_output_dir, foreign_entry, remove_stale, write_json
    if not (out / MARKER).is_file() and not (out / _MANIFEST).is_file():
        bad = foreign_entry(out)
        if bad is not None:
            raise ParameterError(f"{out}: not a synthetic dataset (no {_MANIFEST}) and "
                                 + ("not a folder" if bad == out else f"holds {bad.name}, which morpi did not write")
                                 + "; refusing to replace it, expected a new or empty folder")
    claimed = _manifest_files(out)
    check_output_dir(out, kind=DATASET_KIND, claimed=claimed)
    remove_stale(out.parent)
    with Outputs("morpi simulate") as outputs:
        stage = outputs.folder(out, DATASET_KIND, claimed=claimed)
        files, runs_info = {}, {}
        for folder, n_runs in sorted(dataset.layout().items()):
            for run in range(1, (runs_per_folder or n_runs) + 1):
                rec, info = _synthetic_run(int(seed), folder, run)
                rel = f"{folder}/{run}.csv"
                dataset.write_csv(stage / rel, rec)
                files[rel] = sha256_file(stage / rel)
                runs_info[rel] = info
        fr = REALISTIC_BIAS_FRACTION
        (stage / "README.md").write_text(_README.format(version=GENERATOR_VERSION, seed=seed, s6=fr["s6"], s8=fr["s8"]))
        files["README.md"] = sha256_file(stage / "README.md")
        manifest = dict(generator="morpi_filters.simulate", version=GENERATOR_VERSION, seed=int(seed),
                        runs_per_folder=runs_per_folder, files=files, runs=runs_info)
        write_json(stage / _MANIFEST, manifest)
    return out


def _manifest_files(root: Path) -> tuple:
    """The files an earlier ``write_dataset`` wrote in `root`, by its manifest (empty without one)."""
    try:
        m = json.loads((Path(root) / _MANIFEST).read_text())
    except (OSError, ValueError):
        return ()
    if not isinstance(m, dict) or m.get("generator") != "morpi_filters.simulate":
        return ()
    if not isinstance(m.get("files"), dict):
        return ()
    return (_MANIFEST, *m["files"])


def written_counts(root) -> dict | None:
    """The runs a dataset written by :func:`write_dataset` holds, as ``imu.count`` of the shipped MoRPI manifest.

    A synthetic dataset may hold another number of runs per folder than the
    field dataset (``runs_per_folder``): its ``manifest.json`` lists them,
    and ``morpi check --data`` expects those counts instead of the manifest's
    (:func:`morpi_filters.manifest.check_dataset`, ``counts``).

    Parameters
    ----------
    root : str or Path
        A dataset root.

    Returns
    -------
    dict of str -> int, or None
        ``<folder>/*.csv`` (the pattern of the folder's table) -> the number
        of CSV files listed in it; None when `root` holds no readable
        ``manifest.json`` of this generator.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> root = pathlib.Path(tempfile.mkdtemp())
    >>> written_counts(root) is None
    True
    >>> files = {"s6/L_line/1.csv": "", "s6/L_line/2.csv": "", "s8/line_dataset/1.csv": "", "README.md": ""}
    >>> _ = (root / "manifest.json").write_text(json.dumps({"generator": "morpi_filters.simulate", "files": files}))
    >>> written_counts(root)
    {'s6/L_line/*.csv': 2, 's8/line_dataset/*.csv': 1}
    """
    listed = _manifest_files(Path(root))
    counts: dict = {}
    for rel in listed[1:]:
        if str(rel).endswith(".csv") and "/" in str(rel):
            pattern = str(rel).rsplit("/", 1)[0] + "/*.csv"
            counts[pattern] = counts.get(pattern, 0) + 1
    return counts if listed else None


def _verify(root: Path, seed: int) -> bool:
    try:
        m = json.loads((root / _MANIFEST).read_text())
    except (OSError, ValueError):
        return False
    if m.get("version") != GENERATOR_VERSION or m.get("seed") != seed or m.get("runs_per_folder") is not None:
        return False
    files = m.get("files", {})
    present = {p.relative_to(root).as_posix() for p in root.rglob("*.csv")}
    if present != {k for k in files if k.endswith(".csv")}:
        return False
    return all((root / rel).is_file() and sha256_file(root / rel) == h for rel, h in files.items())


def ensure_synthetic_dataset(cache_dir, *, seed: int = 0) -> Path:
    """The synthetic dataset of `seed` in `cache_dir`, written once and verified on reuse.

    Reuses the folder when its manifest has this seed and generator version,
    it holds the full layout, and every file's sha256 matches; otherwise
    (re)writes it with :func:`write_dataset` and the field dataset's full
    run count per folder. Writing takes seconds, so there is no example here.

    Parameters
    ----------
    cache_dir : str or Path
        Folder of the cached dataset; created or replaced under the rules of
        :func:`write_dataset`.
    seed : int
        Seed of the synthetic recordings.

    Returns
    -------
    Path
        The dataset root (`cache_dir`).
    """
    cache_dir = Path(cache_dir)
    if cache_dir.is_dir() and _verify(cache_dir, int(seed)):
        return cache_dir
    return write_dataset(cache_dir, seed=seed)
