"""The MoRPI dataset's folders: the root, the catalogue of its recordings and their loading (``morpi check
--data`` reads the root through the shipped manifest instead: :func:`morpi_filters.field.check_recordings`)."""
from __future__ import annotations

import functools
import os
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from ..errors import DataError, MissingDataError
from .loader import load_csv
from .plausibility import check_plausible
from .recording import Recording
from .truth import Route, routes

#: Environment variable naming the dataset root.
DATA_ENV = "MORPI_DATA"


@functools.lru_cache(maxsize=1)
def _manifest_imus() -> dict:
    """Folder (``<phone>/<route>[/<split>]``) -> the IMU the shipped MoRPI manifest names for its files."""
    import tomllib

    from ..resources import morpi_manifest
    from ..units import IMUS

    doc = tomllib.loads(morpi_manifest().read_text(encoding="utf-8"))
    return {str(PurePosixPath(r["imu"]["file"]).parent): IMUS[r["imu"]["spec"]]
            for r in doc.get("recording", ()) if isinstance(r.get("imu", {}).get("spec"), str)}


def _phones() -> tuple:
    """The phone folders of the MoRPI layout: the first folder of each file the shipped manifest lists."""
    return tuple(sorted({f.split("/", 1)[0] for f in _manifest_imus()}))


def folder_imu(folder):
    """The IMU of the recordings under a folder of the MoRPI layout, as the shipped MoRPI manifest names it.

    Which phone carries which IMU is the manifest's to say (``data/morpi.toml``); the catalogue of
    ``morpi check --data`` and the synthetic MoRPI dataset read it here.

    Parameters
    ----------
    folder : str
        ``<phone>[/<route>[/<split>]]``, relative to the dataset root.

    Returns
    -------
    units.SensorSpec or None
        The one IMU the manifest names for every file under `folder`; None when it lists none there (or
        more than one).

    Examples
    --------
    >>> folder_imu("s6").name, folder_imu("s8/short_distance/test").name
    ('MPU-6500', 'LSM6DSL')
    >>> folder_imu("pixel") is None
    True
    """
    folder = str(PurePosixPath(folder))
    found = {id(s): s for f, s in _manifest_imus().items() if f == folder or f.startswith(folder + "/")}
    return next(iter(found.values())) if len(found) == 1 else None


def _imu_of(phone, route, split):
    """:func:`folder_imu` of the folder ``<phone>/<route>[/<split>]``."""
    return folder_imu("/".join(p for p in (phone, route, split) if p))

_HOW_TO_GET = (
    "get the field recordings with `morpi data fetch --out DIR` (or clone the public "
    "repository ansfl/MoRPI and use its data/ folder), then pass --data DIR or set "
    f"{DATA_ENV}=DIR"
)


@dataclass(frozen=True)
class CatalogueEntry:
    """A recording's place in the dataset layout, before it is read.

    Attributes
    ----------
    path : Path
        The CSV file.
    relpath : str
        Its POSIX path below the dataset root.
    phone, route : str
        Labels read from the folders.
    split : str or None
        ``"train"``, ``"test"``, or None for a folder without a split.
    """

    path: Path
    relpath: str
    phone: str
    route: str
    split: str | None

    def load(self) -> Recording:
        """Read and validate the file, with the entry's labels.

        Returns
        -------
        Recording
            :func:`load_csv` of ``path`` with ``phone``, ``route`` and ``split``
            set, checked by :func:`check_plausible`.

        Raises
        ------
        DataError
            Every error of :func:`load_csv` and :func:`check_plausible`.

        Examples
        --------
        >>> import pathlib, tempfile, numpy as np
        >>> from morpi_filters.dataset import write_csv
        >>> root = pathlib.Path(tempfile.mkdtemp())
        >>> (root / "s6" / "L_line").mkdir(parents=True)
        >>> t = np.arange(100) * 0.01
        >>> write_csv(root / "s6" / "L_line" / "1.csv",
        ...           Recording(time=t, f=np.tile([0.0, 0.0, 9.8], (100, 1)), omega=np.zeros((100, 3))))
        >>> rec = catalogue(root)[0].load()
        >>> rec.name, rec.n
        ('s6/L_line/1.csv', 100)
        """
        return check_plausible(load_csv(self.path, phone=self.phone, route=self.route, split=self.split,
                                        imu=_imu_of(self.phone, self.route, self.split)))


def resolve_data_root(data=None, *, required: bool = True) -> Path | None:
    """Find the dataset root: `data` if given, else ``$MORPI_DATA``.

    A folder without ``s6``/``s8`` whose ``data/`` has them (the root of an
    ansfl/MoRPI clone) stands for that ``data/`` folder.

    Parameters
    ----------
    data : str or Path, optional
        The folder given by the user (``--data``); a leading ``~`` is expanded.
        When None, the environment variable :data:`DATA_ENV` is read.
    required : bool, optional
        Raise when neither is set (default True); otherwise return None.

    Returns
    -------
    Path or None
        The dataset root; None when nothing is configured and not `required`.

    Raises
    ------
    MissingDataError
        When `required` and neither is set, or the folder does not exist.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> clone = pathlib.Path(tempfile.mkdtemp())
    >>> (clone / "data" / "s8").mkdir(parents=True)
    >>> resolve_data_root(clone) == clone / "data"
    True
    >>> resolve_data_root(clone / "nowhere")
    Traceback (most recent call last):
    ...
    morpi_filters.errors.MissingDataError: --data=...nowhere: not a directory; get the field recordings ...
    """
    source = "--data"
    if data is None:
        data = os.environ.get(DATA_ENV) or None
        source = DATA_ENV
    if data is None:
        if required:
            raise MissingDataError(f"no dataset configured: {_HOW_TO_GET}")
        return None
    root = Path(data).expanduser()
    if not root.is_dir():
        raise MissingDataError(f"{source}={data}: not a directory; {_HOW_TO_GET}")
    if not any((root / p).is_dir() for p in _phones()) and any((root / "data" / p).is_dir() for p in _phones()):
        root = root / "data"   # the root of an ansfl/MoRPI clone: its recordings are under data/
    return root


def missing_data_message() -> str:
    """How to get the field recordings, in one sentence.

    Returns
    -------
    str
        The sentence (it names ``morpi data fetch``, ``--data`` and
        :data:`DATA_ENV`).

    Examples
    --------
    >>> "morpi data fetch" in missing_data_message()
    True
    """
    return _HOW_TO_GET


def _split_parts(rel: Path) -> tuple[str, str, str | None] | None:
    parts = rel.parts
    if len(parts) < 3 or parts[0] not in _phones():
        return None
    phone, route_name = parts[0], parts[1]
    split = parts[2] if len(parts) == 4 and parts[2] in ("train", "test") else None
    if len(parts) not in (3, 4) or (len(parts) == 4 and split is None):
        return None
    return phone, route_name, split


def catalogue(root) -> list[CatalogueEntry]:
    """List the recordings under a dataset root, in a stable order.

    Files outside the MoRPI layout (``<phone>/<route>[/<split>]/<n>.csv``)
    and routes without ground truth are left out. Nothing is read but the
    folder names.

    Parameters
    ----------
    root : str or Path
        The dataset root (the folder holding ``s6`` and ``s8``).

    Returns
    -------
    list of CatalogueEntry
        Sorted by phone, route, split, then file number (``2.csv`` before
        ``10.csv``).

    Raises
    ------
    DataError
        `root` is not a directory.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> root = pathlib.Path(tempfile.mkdtemp())
    >>> for rel in ("s8/L_shape/test/10.csv", "s8/L_shape/test/2.csv", "s6/L_line/1.csv", "notes/x.csv"):
    ...     (root / rel).parent.mkdir(parents=True, exist_ok=True)
    ...     (root / rel).touch()
    >>> [(e.relpath, e.split) for e in catalogue(root)]
    [('s6/L_line/1.csv', None), ('s8/L_shape/test/2.csv', 'test'), ('s8/L_shape/test/10.csv', 'test')]
    """
    root = Path(root)
    if not root.is_dir():
        raise DataError(f"{root}: not a directory; expected a dataset root (the folder holding s6 and s8)")
    known = routes()
    out = []
    for path in root.rglob("*.csv"):
        rel = path.relative_to(root)
        parts = _split_parts(rel)
        if parts is None or parts[1] not in known:
            continue
        out.append(CatalogueEntry(path=path, relpath=rel.as_posix(), phone=parts[0], route=parts[1], split=parts[2]))
    out.sort(key=lambda e: (e.phone, e.route, e.split or "", _natural_key(e.path.stem)))
    return out


def _natural_key(stem: str):
    return (0, int(stem), "") if stem.isdigit() else (1, 0, stem)


def load_recording(path) -> tuple[Recording, "Route | None"]:
    """Load one recording by path, with its labels and ground truth read from where it lies.

    A file at ``.../<phone>/<route>[/<split>]/<n>.csv`` of the MoRPI layout
    gets its phone, route and split and the route's ground truth; anywhere
    else it loads without labels, with a warning saying so.

    Parameters
    ----------
    path : str or Path
        The CSV file.

    Returns
    -------
    recording : Recording
        The validated recording (:func:`load_csv`, :func:`check_plausible`),
        labelled when in the layout.
    truth : Route or None
        The route's ground truth; None outside the layout.

    Raises
    ------
    DataError
        Every error of :func:`load_csv` and :func:`check_plausible`.

    Warns
    -----
    UserWarning
        When the file is not in the MoRPI layout.

    Examples
    --------
    >>> import tempfile, pathlib, numpy as np
    >>> from morpi_filters.dataset import write_csv
    >>> folder = pathlib.Path(tempfile.mkdtemp()) / "s8" / "short_distance" / "test"
    >>> folder.mkdir(parents=True)
    >>> t = np.arange(200) * 0.01
    >>> write_csv(folder / "1.csv", Recording(time=t, f=np.tile([0, 0, 9.8], (200, 1)),
    ...                                       omega=np.zeros((200, 3)), source="example"))
    >>> rec, truth = load_recording(folder / "1.csv")
    >>> rec.phone, rec.route, rec.split, truth.distance_m
    ('s8', 'short_distance', 'test', 6.3)
    """
    import warnings

    path = Path(path)
    known = routes()
    for depth in (4, 3):
        parts = path.resolve().parts[-depth:]
        labels = _split_parts(Path(*parts)) if len(parts) == depth else None
        if labels is not None and labels[1] in known:
            phone, route_name, split = labels
            rec = load_csv(path, phone=phone, route=route_name, split=split, imu=_imu_of(phone, route_name, split))
            return check_plausible(rec), known[route_name]
    warnings.warn(f"{path}: not in the MoRPI layout (<phone>/<route>[/<split>]/<n>.csv): loaded without "
                  "phone, route, split or ground truth", stacklevel=2)
    return check_plausible(load_csv(path)), None


def load_catalogue(root, *, phone=None, route=None, split=None) -> list[Recording]:
    """Load every recording under `root` that matches the given labels.

    Parameters
    ----------
    root : str or Path
        The dataset root.
    phone, route, split : str, optional
        Keep only recordings with these labels; None matches any. ``split`` is
        ``"train"`` or ``"test"`` (folders without a split never match one).

    Returns
    -------
    list of Recording
        Labelled recordings in the order of :func:`catalogue`.

    Raises
    ------
    DataError
        For the first file that does not load (:func:`CatalogueEntry.load`).

    Examples
    --------
    >>> import pathlib, tempfile, numpy as np
    >>> from morpi_filters.dataset import write_csv
    >>> root = pathlib.Path(tempfile.mkdtemp())
    >>> t = np.arange(100) * 0.01
    >>> rec = Recording(time=t, f=np.tile([0.0, 0.0, 9.8], (100, 1)), omega=np.zeros((100, 3)))
    >>> for rel in ("s8/short_distance/train/1.csv", "s8/short_distance/test/1.csv", "s6/L_line/1.csv"):
    ...     (root / rel).parent.mkdir(parents=True, exist_ok=True)
    ...     write_csv(root / rel, rec)
    >>> [r.name for r in load_catalogue(root, phone="s8", split="test")]
    ['s8/short_distance/test/1.csv']
    >>> len(load_catalogue(root)), len(load_catalogue(root, split="train"))
    (3, 1)
    """
    out = []
    for e in catalogue(root):
        if (phone is None or e.phone == phone) and (route is None or e.route == route) and \
                (split is None or e.split == split):
            out.append(e.load())
    return out
