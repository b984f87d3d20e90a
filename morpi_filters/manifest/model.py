"""The :class:`Dataset` and the entry points: :func:`load_dataset`, :func:`index_dataset`, :func:`check_dataset`."""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..dataset import MEMS_SPEC, Recording, check_recording
from ..errors import DataError, MorpiError, ParameterError
from .read import DatasetRecording, RouteTruth, TruthTrack, check_labels, check_physics, load_entry
from .settings import Settings
from .schema import (DEFAULTS, GLOB_CHARS, IMU_CHECKS, LABEL_CHECKS, BadValue, Context, ParsedManifest, check_latitude,
                     check_text, read_manifest, unknown_key, value_of)


@dataclass(frozen=True, eq=False)
class Dataset:
    """Recordings described by a manifest (or built in memory), converted and checked.

    Attributes
    ----------
    name : str
        The dataset's name.
    recordings : tuple of DatasetRecording
        In the manifest's order; ids unique.
    source : str
        The manifest file, or ``"<memory>"``.
    description : str
        Free text.
    latitude_deg : float or None
        The recordings' latitude [deg]: the calibrations and the 3D INS take
        the normal gravity there
        (:func:`morpi_filters.calibration.normal_gravity`); None: standard
        gravity :data:`morpi_filters.units.G0`.
    settings : Settings
        How the dataset is evaluated (the manifest's ``[evaluation]``).

    Examples
    --------
    >>> t = np.arange(300) / 100.0
    >>> still = {"time": t, "f": np.tile([0.0, 0.0, 9.81], (300, 1)), "omega": np.zeros((300, 3)),
    ...          "truth": RouteTruth(distance_m=1.0, end_point_m=np.array([1.0, 0.0]))}
    >>> ds = Dataset.from_arrays("bench", [dict(still, id="a", group="g1"), dict(still, id="b", split="train")])
    >>> [r.id for r in ds.recordings], sorted(ds.groups()), ds["b"].split
    (['a', 'b'], ['all', 'g1'], 'train')
    """

    name: str
    recordings: tuple
    source: str = "<memory>"
    description: str = ""
    latitude_deg: float | None = None
    settings: Settings = Settings()

    def __post_init__(self):
        object.__setattr__(self, "recordings", tuple(self.recordings))
        if self.latitude_deg is not None:
            try:
                object.__setattr__(self, "latitude_deg", check_latitude(self.latitude_deg))
            except BadValue as bad:
                raise ParameterError(f"{self.source}: latitude_deg: {bad}") from None
        if not isinstance(self.settings, Settings):
            raise ParameterError(f"{self.source}: settings: {type(self.settings).__name__}, expected a Settings")
        seen = set()
        for r in self.recordings:
            if r.id in seen:
                raise ParameterError(f"{self.source}: recording id {r.id!r} appears twice, expected unique ids")
            seen.add(r.id)
        _check_train_groups(self.source, self.recordings)      # a group's recordings agree on it

    def __getitem__(self, rec_id: str) -> DatasetRecording:
        for r in self.recordings:
            if r.id == rec_id:
                return r
        raise KeyError(rec_id)

    def __len__(self) -> int:
        return len(self.recordings)

    def groups(self) -> dict:
        """The recordings by group.

        Returns
        -------
        dict of str -> tuple of DatasetRecording
            In the order groups first appear.
        """
        out: dict = {}
        for r in self.recordings:
            out.setdefault(r.group, []).append(r)
        return {k: tuple(v) for k, v in out.items()}

    @classmethod
    def from_arrays(cls, name: str, recordings, *, description: str = "", latitude_deg: float | None = None,
                    settings: Settings | None = None) -> "Dataset":
        """A dataset from arrays in memory, with the checks of a manifest's recordings.

        Parameters
        ----------
        name : str
            The dataset's name.
        recordings : iterable of dict
            One mapping per recording with ``id``, ``time`` [s], ``f``
            [m/s^2] and ``omega`` [rad/s] in body axes x forward, y left,
            z up, ``truth`` (a :class:`RouteTruth` or :class:`TruthTrack`,
            the track on the same clock as ``time``), and optionally
            ``split``, ``group``, ``motion``, ``rest``, ``initial``,
            ``train_group`` and ``notes`` with the meanings and defaults of
            the manifest keys.
        description : str, optional
            Free text.
        latitude_deg : float, optional
            The recordings' latitude [deg] (the manifest key ``latitude_deg``);
            default: standard gravity.
        settings : Settings, optional
            How the dataset is evaluated (the manifest's ``[evaluation]``);
            default: the defaults of :class:`Settings`.

        Returns
        -------
        Dataset
            ``source`` ``"<memory>"``.

        Raises
        ------
        ParameterError
            An unknown or missing key, a bad value, a duplicate id, or a
            reading that does not show gravity up the z axis.
        DataError
            Arrays beyond the loader's limits (time not increasing, gaps,
            full scales), a dead channel, or a truth track shorter than the
            recording.
        """
        try:
            name = check_text(name)
        except BadValue as bad:
            raise ParameterError(f"<memory>: name: {bad}") from None
        out = []
        known = ("id", "time", "f", "omega", "truth") + tuple(DEFAULTS)
        for k, item in enumerate(recordings):
            where = f"<memory>: recordings[{k}]"
            unknown = [key for key in item if key not in known]
            if unknown:
                raise ParameterError(f"{where}: {unknown_key(unknown[0], known)}")
            missing = [key for key in ("id", "time", "f", "omega", "truth") if key not in item]
            if missing:
                raise ParameterError(f"{where}: missing {', '.join(missing)}")
            labels = {}
            for key, default in DEFAULTS.items():
                try:
                    labels[key] = LABEL_CHECKS[key](item.get(key, default))
                except BadValue as bad:
                    raise ParameterError(f"{where}.{key}: {bad}") from None
            try:
                rec_id = check_text(item["id"])
            except BadValue as bad:
                raise ParameterError(f"{where}.id: {bad}") from None
            truth = item["truth"]
            if not isinstance(truth, (RouteTruth, TruthTrack)):
                raise ParameterError(f"{where}.truth: {type(truth).__name__}, expected a RouteTruth or TruthTrack")
            rec = Recording(time=np.asarray(item["time"], dtype=float), f=np.asarray(item["f"], dtype=float),
                            omega=np.asarray(item["omega"], dtype=float), source=f"<memory>:{rec_id}",
                            split=None if labels["split"] == "none" else labels["split"], label=rec_id)
            check_recording(rec)
            ctx = Context(where, {})
            check_labels(ctx, rec, truth, labels)
            check_physics(ctx, rec, labels["rest"], {"accel_unit": "m/s^2", "gyro_unit": "rad/s", "axes": "FLU"},
                          MEMS_SPEC)
            out.append(DatasetRecording(id=rec_id, recording=rec, truth=truth, **labels))
        _check_train_groups("<memory>", out, {r.group for r in out if r.split == "train"})
        return cls(name=name, recordings=tuple(out), description=description, latitude_deg=latitude_deg,
                   settings=Settings() if settings is None else settings)


def _check_train_groups(source: str, recordings, trained=None) -> None:
    """A group's recordings agree on their ``train_group``, and (with `trained`, the groups that have or declare
    train recordings) each names one of those."""
    said: dict = {}
    for r in recordings:
        if trained is not None and r.train_group is not None and r.train_group not in trained:
            raise ParameterError(f"{source}: recording {r.id!r}: train_group: {r.train_group!r} has no train "
                                 "recording, expected a group with recordings of split = 'train' "
                                 f"({', '.join(repr(g) for g in sorted(trained)) or 'none in this dataset'})")
        first = said.setdefault(r.group, r)
        if first.train_group != r.train_group:
            raise ParameterError(f"{source}: recording {r.id!r}: train_group: {r.train_group!r}, but recording "
                                 f"{first.id!r} of the same group {r.group!r} says {first.train_group!r}, expected "
                                 "one train group per group")


# --------------------------------------------------------------------------- entry points

def load_dataset(path, *, root=None) -> Dataset:
    """Read a manifest and every recording it describes, converted and checked.

    Parameters
    ----------
    path : str or Path
        The manifest (TOML, format version 1; ``docs/manifest.md``).
    root : str or Path, optional
        The folder relative file names start at; default: the manifest's
        folder. One manifest describes every copy of a dataset this way (the
        package's MoRPI manifest, :func:`morpi_filters.resources.morpi_manifest`).

    Returns
    -------
    Dataset
        Every recording in the package's frame and units with its labels
        and truth, in the manifest's order.

    Raises
    ------
    ParameterError
        The first problem of the manifest (one line naming the file, the
        recording and the key), or of a reading that looks declared wrong
        (gravity not up the z axis at about 1 g, implausible rates).
    DataError
        The first file that does not load (naming the manifest, the key,
        the file and the line), a dead channel (naming ``imu.file``), or a
        truth track shorter than its recording.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from morpi_filters.units import G0
    >>> root = pathlib.Path(tempfile.mkdtemp())
    >>> rows = "\\n".join(f"{k * 10}, 0, 0, 1, 0, 0, 0" for k in range(200))
    >>> _ = (root / "run1.csv").write_text("# logger v2\\nt_ms, ax, ay, az, gx, gy, gz\\n" + rows + "\\n")
    >>> _ = (root / "dataset.toml").write_text('''
    ... format_version = 1
    ... name = "bench"
    ... [defaults.imu]
    ... skip_rows = 1
    ... time_unit = "ms"
    ... accel_unit = "g"
    ... columns = { time = "t_ms", f_x = "ax", f_y = "ay", f_z = "az", g_x = "gx", g_y = "gy", g_z = "gz" }
    ... [[recording]]
    ... id = "run1"
    ... imu.file = "run1.csv"
    ... truth = { kind = "route", distance_m = 1.0, end_point_m = [1.0, 0.0] }
    ... ''')
    >>> ds = load_dataset(root / "dataset.toml")
    >>> rec = ds["run1"].recording
    >>> ds.name, rec.n, float(rec.time[1]), rec.f[0].tolist() == [0.0, 0.0, G0]     # 1 g is G0 m/s^2
    ('bench', 200, 0.01, True)
    """
    manifest = read_manifest(path, root)
    out = []
    for ctx, values, problem in manifest.entries:
        if problem is not None:
            raise problem
        out.append(load_entry(ctx, values))
    if not out:
        raise _no_match(manifest)
    _check_train_groups(str(manifest.path), out, _declared_train_groups(manifest))
    return Dataset(name=manifest.name, recordings=tuple(out), source=str(manifest.path),
                   description=manifest.description, latitude_deg=manifest.latitude_deg,
                   settings=manifest.settings)


def _no_match(manifest: ParsedManifest) -> ParameterError:
    return ParameterError(f"{manifest.path}: recording: the glob imu.file patterns match no file under "
                          f"{manifest.base}, expected at least one recording")


@dataclass(frozen=True, eq=False)
class IndexedRecording:
    """A manifest recording before its files are read: its labels and its IMU file (:func:`index_dataset`).

    Attributes
    ----------
    id, split, group, motion, rest, initial
        As in :class:`DatasetRecording`.
    file : Path
        The IMU file (not yet checked to exist).
    """

    id: str
    split: str
    group: str
    motion: str
    rest: object
    initial: str
    file: Path
    _ctx: object = field(default=None, repr=False)
    _values: dict = field(default=None, repr=False)

    def load(self) -> DatasetRecording:
        """Read, convert and check the recording as :func:`load_dataset` does.

        Returns
        -------
        DatasetRecording

        Raises
        ------
        ParameterError, DataError
            As :func:`load_dataset`, for this recording.
        """
        return load_entry(self._ctx, self._values)


@dataclass(frozen=True, eq=False)
class DatasetIndex:
    """A manifest's recordings, labelled, none read yet (:func:`index_dataset`).

    Attributes
    ----------
    name, description, latitude_deg
        As in :class:`Dataset`.
    source : str
        The manifest file.
    root : Path
        The folder its relative file names start at.
    recordings : tuple of IndexedRecording
        In the manifest's order (the files of a glob in the order of their
        folders and numbers).
    declared : tuple of (str, str, str)
        ``(group, split, motion)`` of every ``[[recording]]`` table in order,
        a glob table's once, whether or not it matches a file.
    """

    name: str
    source: str
    root: Path
    recordings: tuple
    description: str = ""
    latitude_deg: float | None = None
    declared: tuple = ()


def index_dataset(path, *, root=None) -> DatasetIndex:
    """A manifest's recordings with their labels and files, without reading a file.

    What :func:`load_dataset` reads, one recording at a time
    (:meth:`IndexedRecording.load`): a caller that reads a few recordings,
    or keeps going past one that does not load, starts here. A glob that
    matches no file gives no recording (no error).

    Parameters
    ----------
    path : str or Path
        The manifest.
    root : str or Path, optional
        As for :func:`load_dataset`.

    Returns
    -------
    DatasetIndex

    Raises
    ------
    ParameterError
        The first problem of the manifest's keys and labels (one line naming
        the file, the recording and the key).

    Examples
    --------
    >>> from morpi_filters.resources import morpi_manifest
    >>> import pathlib, tempfile
    >>> root = pathlib.Path(tempfile.mkdtemp())
    >>> for rel in ("s8/short_distance/train/10.csv", "s8/short_distance/train/2.csv", "s6/L_line/1.csv"):
    ...     (root / rel).parent.mkdir(parents=True, exist_ok=True)
    ...     (root / rel).touch()
    >>> index = index_dataset(morpi_manifest(), root=root)
    >>> [(r.id, r.group, r.split, r.motion) for r in index.recordings]    # doctest: +NORMALIZE_WHITESPACE
    [('s8/short_distance/train/2.csv', 's8/short_distance', 'train', 'periodic'),
     ('s8/short_distance/train/10.csv', 's8/short_distance', 'train', 'periodic'),
     ('s6/L_line/1.csv', 's6/L_line', 'none', 'straight')]
    """
    manifest = read_manifest(path, root)
    out, declared = [], {}
    for ctx, values in manifest.empty:
        labels = [value_of(ctx, values, "", k, LABEL_CHECKS, default=DEFAULTS[k]) for k in ("group", "split", "motion")]
        declared[ctx.table] = tuple(labels)
    for ctx, values, problem in manifest.entries:
        if problem is not None:
            raise problem
        rec_id = value_of(ctx, values, "", "id", {"id": check_text}, required=True)
        labels = {k: value_of(ctx, values, "", k, LABEL_CHECKS, default=d) for k, d in DEFAULTS.items()}
        imu = values.get("imu")
        if not isinstance(imu, dict) or "file" not in imu:
            raise ctx.bad("imu", "missing, expected a table with at least imu.file")
        name = Path(value_of(ctx, imu, "imu", "file", IMU_CHECKS, required=True)).expanduser()
        out.append(IndexedRecording(id=rec_id, file=name if name.is_absolute() else ctx.base / name,
                                    _ctx=ctx, _values=values, **{k: labels[k] for k in
                                                                 ("split", "group", "motion", "rest", "initial")}))
        declared[ctx.table] = (labels["group"], labels["split"], labels["motion"])
    order = sorted(declared)
    return DatasetIndex(name=manifest.name, source=str(manifest.path), root=manifest.base, recordings=tuple(out),
                        description=manifest.description, latitude_deg=manifest.latitude_deg,
                        declared=tuple(declared[k] for k in order))


def check_dataset(path, *, root=None, counts=None, usable=None) -> tuple[list, int]:
    """Load every recording of a manifest in turn and collect the problems, one per recording.

    Only the files the manifest names (and its glob patterns match) are read;
    nothing else under the root is listed. A glob table with ``imu.count``
    is one more problem when its pattern matches another number of files
    (:func:`count_problems`).

    Parameters
    ----------
    path : str or Path
        The manifest.
    root : str or Path, optional
        As for :func:`load_dataset`.
    counts : dict of str -> int, optional
        See :func:`count_problems`.
    usable : callable, optional
        A further check of each recording that loads: ``usable(dataset_recording)``
        returns a one-line problem (a :class:`~morpi_filters.errors.DataError`
        then) or None.

    Returns
    -------
    problems : list of MorpiError
        The first problem of each recording that does not load
        (:class:`ParameterError` for the manifest, :class:`DataError` for
        the data), then the glob tables' counts, each a one-line message.
    n_ok : int
        Number of recordings that loaded cleanly (and passed `usable`).

    Raises
    ------
    ParameterError
        A manifest that cannot be read at all (not TOML, a format version
        other than 1, an unknown top-level key, a bad [defaults] table).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> root = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (root / "dataset.toml").write_text('''
    ... format_version = 1
    ... name = "bench"
    ... [[recording]]
    ... id = "run1"
    ... imu = { file = "run1.csv", axes = "FRU" }
    ... truth = { kind = "route", distance_m = 1.0, end_point_m = [1.0, 0.0] }
    ... ''')
    >>> problems, n_ok = check_dataset(root / "dataset.toml")
    >>> n_ok, [str(p).replace(str(root), "ROOT") for p in problems]
    (0, ["ROOT/dataset.toml: [[recording]] 1 (id 'run1'): imu.file: ROOT/run1.csv: no such file (...)"])
    """
    manifest = read_manifest(path, root)
    problems, n_ok = [], 0
    for ctx, values, problem in manifest.entries:
        if problem is None:
            try:
                item = load_entry(ctx, values)
                line = None if usable is None else usable(item)
                if line is None:
                    n_ok += 1
                    continue
                problem = DataError(line)
            except MorpiError as exc:
                problem = exc
        problems.append(problem)
    if not manifest.entries:
        expected = _expected(manifest, counts)
        problems.append(_no_match(manifest) if not expected else DataError(
            f"{manifest.base}: no recordings: no file matches the imu.file patterns of {manifest.path}, expected "
            f"{sum(expected.values())} recording(s) (imu.count)"))
        return problems, n_ok
    labelled = []
    for ctx, values, problem in manifest.entries:
        if problem is None:
            try:
                labelled.append(_Labels(ctx.id, *(value_of(ctx, values, "", k, LABEL_CHECKS, default=DEFAULTS[k])
                                                  for k in ("group", "split", "train_group"))))
            except MorpiError:
                pass                            # already a problem of its recording
    try:
        _check_train_groups(str(manifest.path), labelled, _declared_train_groups(manifest))
    except ParameterError as exc:
        problems.append(exc)
    return problems + _count_problems(manifest, counts), n_ok


def _declared_train_groups(manifest: ParsedManifest) -> set:
    """The groups of the manifest's tables with ``split = "train"``, whether or not their files are there."""
    out = set()
    tables = [(ctx, values) for ctx, values, problem in manifest.entries if problem is None] + list(manifest.empty)
    for ctx, values in tables:
        try:
            group, split = (value_of(ctx, values, "", k, LABEL_CHECKS, default=DEFAULTS[k]) for k in ("group", "split"))
        except MorpiError:
            continue
        if split == "train":
            out.add(group)
    return out


@dataclass(frozen=True)
class _Labels:
    """The labels :func:`_check_train_groups` reads, of a recording not loaded."""

    id: str
    group: str
    split: str
    train_group: str | None


def count_problems(path, *, root=None, counts=None) -> list:
    """One line per glob ``imu.file`` of a manifest that matches another number of files than its ``imu.count``.

    Nothing is read but the names of the files the patterns match.

    Parameters
    ----------
    path : str or Path
        The manifest.
    root : str or Path, optional
        As for :func:`load_dataset`.
    counts : dict of str -> int, optional
        The number of files each glob pattern (as written in ``imu.file``)
        should match, in place of every ``imu.count`` of the manifest: a
        pattern it leaves out has no expected count (a copy of a dataset that
        holds fewer runs per folder, listed by whoever wrote it).

    Returns
    -------
    list of DataError
        One per glob table whose pattern matches a number of files other
        than expected, naming the manifest, the table, the pattern and both
        numbers (and the folder, when it is missing); empty when no pattern
        matches anything (:func:`check_dataset` says that once).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> root = pathlib.Path(tempfile.mkdtemp())
    >>> (root / "runs").mkdir()
    >>> _ = (root / "runs" / "1.csv").write_text("")
    >>> _ = (root / "dataset.toml").write_text('''
    ... format_version = 1
    ... name = "bench"
    ... [[recording]]
    ... imu = { file = "runs/*.csv", count = 2 }
    ... truth = { kind = "route", distance_m = 1.0, end_point_m = [1.0, 0.0] }
    ... [[recording]]
    ... imu = { file = "more/*.csv", count = 3 }
    ... truth = { kind = "route", distance_m = 1.0, end_point_m = [1.0, 0.0] }
    ... ''')
    >>> for p in count_problems(root / "dataset.toml"):    # doctest: +NORMALIZE_WHITESPACE
    ...     print(str(p).replace(str(root), "ROOT"))
    ROOT/dataset.toml: [[recording]] 1: imu.file: 'runs/*.csv' matches 1 file(s) under ROOT, expected 2 (imu.count)
    ROOT/dataset.toml: [[recording]] 2: imu.file: 'more/*.csv' matches no file: missing folder ROOT/more,
    expected 3 file(s) (imu.count)
    """
    manifest = read_manifest(path, root)
    return _count_problems(manifest, counts) if manifest.entries else []


def _expected(manifest: ParsedManifest, counts) -> dict:
    """Pattern -> expected number of files: `counts`, else each glob table's ``imu.count``."""
    if counts is not None:
        return {pattern: int(n) for pattern, n in counts.items()}
    return {pattern: n for _, pattern, _, n in manifest.globs if n is not None}


def _count_problems(manifest: ParsedManifest, counts) -> list:
    expected, out = _expected(manifest, counts), []
    for ctx, pattern, found, _ in manifest.globs:
        n = expected.get(pattern)
        if n is None or found == n:
            continue
        lead = _leading(pattern)
        folder = ctx.base / Path(*lead) if lead else None        # an absolute lead replaces the base
        if found == 0 and folder is not None and not folder.is_dir():
            line = f"{pattern!r} matches no file: missing folder {folder}, expected {n} file(s) (imu.count)"
        else:
            line = f"{pattern!r} matches {found or 'no'} file(s) under {ctx.base}, expected {n} (imu.count)"
        out.append(ctx.bad("imu.file", line, DataError))
    return out


def _leading(pattern: str) -> list:
    """The folders of a glob pattern before its first part holding a glob character."""
    parts = Path(pattern).expanduser().parts[:-1]
    out = []
    for p in parts:
        if any(c in p for c in GLOB_CHARS):
            break
        out.append(p)
    return out
