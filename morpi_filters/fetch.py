"""Download the public MoRPI field dataset and verify it against committed checksums.

``morpi data fetch [--out DIR] [--url URL]`` calls :func:`fetch_dataset`: it
downloads an archive of the public repository ansfl/MoRPI [1]_ (by default
the zip archive of its default branch), unpacks only the recordings (the CSV
files under the repository's ``data/`` folder, without the archive's top
folder) into ``DIR/data``, and checks every file against the SHA-256 sums in
``data/dataset_checksums.txt``, a small file this project owns (paths and
hashes only, made by :func:`compute_checksums` from a verified copy).

What a dataset is
-----------------
:func:`dataset_identity` names a dataset by its content, not by where it
lies, for the reports: its number of recordings, whether they are exactly the
published ones (every file and hash of ``data/dataset_checksums.txt``), and a
fingerprint of their bytes; a synthetic dataset is named as such, with its
seed. Two copies of the same recordings at different paths, or on different
machines, get the same identity.

All or nothing
--------------
The archive is downloaded to a temporary file and unpacked into a staging
folder beside the destination; only when every file is present, no file is
extra and every hash matches is the staging folder renamed into place. Any
failure (HTTP error, refused connection, time-out, truncated or corrupt
archive, checksum mismatch, missing or extra file, a member that would land
outside the destination: absolute path, ``..``, link) raises one
:class:`FetchError` line (an :class:`OutputError` for a destination in the
way) and removes everything it wrote. A destination that
already holds a verified dataset is left untouched.

Archives are ``.zip`` or ``.tar.gz`` (recognised by their first bytes, not
their names), read with :mod:`zipfile` and :mod:`tarfile`; HTTP goes through
:mod:`urllib`. No other dependency.

References
----------
.. [1] A. Etzion and I. Klein, MoRPI dataset, https://github.com/ansfl/MoRPI
   (folder ``data/``).
"""
from __future__ import annotations

import contextlib
import functools
import hashlib
import http.client
import io
import json
import os
import shutil
import socket
import stat
import tarfile
import urllib.error
import urllib.request
import zipfile
import zlib
from dataclasses import dataclass
from pathlib import Path, PurePosixPath
from typing import Callable, Mapping

from .dataset import PROJECT_DATA
from .deprecation import renamed_keywords
from .errors import FetchError, MorpiError, OutputError, ParameterError
from .outputs import new_stage_dir, swap_in

__all__ = [
    "DEFAULT_URL", "CHECKSUMS_FILE", "sha256_file", "compute_checksums", "write_checksums", "load_checksums",
    "verify_tree", "fetch_dataset", "DatasetIdentity", "dataset_identity",
]

#: Zip archive of the default branch of the public repository.
DEFAULT_URL = "https://github.com/ansfl/MoRPI/archive/HEAD.zip"
#: The committed SHA-256 sums of the 143 recordings (``<sha256>  <relative path>`` per line).
CHECKSUMS_FILE = PROJECT_DATA / "dataset_checksums.txt"
#: Folder of the repository (inside the archive's top folder) that holds the recordings.
ARCHIVE_DATA_DIR = "data"

_CHUNK = 1 << 20
_HEADER = (
    "# SHA-256 of each recording of the MoRPI field dataset (public repository ansfl/MoRPI, folder data/),\n"
    "# relative to that folder. Format of `sha256sum`: <hash>  <path>. Regenerate with\n"
    "# morpi_filters.fetch.write_checksums(CHECKSUMS_FILE, compute_checksums(DATA_ROOT)).\n"
)


# ----------------------------------------------------------------------------- checksums

def _sha256_stream(read, write=None) -> str:
    """sha256 hex digest of the bytes `read(n)` yields until empty; each block also goes to `write`."""
    h = hashlib.sha256()
    for block in iter(lambda: read(_CHUNK), b""):
        h.update(block)
        if write is not None:
            write(block)
    return h.hexdigest()


def sha256_file(path) -> str:
    """sha256 hex digest of a file's bytes (the format of ``sha256sum``).

    The file is read in blocks of 1 MiB, so its size does not matter.

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    str
        64 lowercase hex digits.

    Examples
    --------
    The FIPS 180-2 test vector of "abc":

    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "abc.txt")
    >>> with open(path, "wb") as fh:
    ...     _ = fh.write(b"abc")
    >>> sha256_file(path)
    'ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad'
    """
    with open(path, "rb") as fh:
        return _sha256_stream(fh.read)


def compute_checksums(root) -> dict[str, str]:
    """SHA-256 of every CSV file under a dataset root.

    Parameters
    ----------
    root : str or Path
        Dataset root in the MoRPI layout (``s8/line_dataset/1.csv``, ...).

    Returns
    -------
    dict of str -> str
        Relative POSIX path -> lowercase hex digest, sorted by path. Files other
        than ``*.csv`` are not listed.

    Raises
    ------
    ParameterError
        When `root` is not a directory.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> root = pathlib.Path(tempfile.mkdtemp())
    >>> (root / "s8" / "line_dataset").mkdir(parents=True)
    >>> _ = (root / "s8" / "line_dataset" / "1.csv").write_bytes(b"abc")
    >>> _ = (root / "README.md").write_text("not a recording")
    >>> compute_checksums(root)
    {'s8/line_dataset/1.csv': 'ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad'}
    """
    root = Path(root)
    if not root.is_dir():
        raise ParameterError(f"{root}: not a directory, expected a dataset root")
    out = {p.relative_to(root).as_posix(): sha256_file(p) for p in root.rglob("*.csv") if p.is_file()}
    return dict(sorted(out.items()))


def write_checksums(path, checksums: Mapping[str, str]) -> Path:
    """Write checksums in ``sha256sum`` format with a short header (atomically).

    Parameters
    ----------
    path : str or Path
        The file to write (:data:`CHECKSUMS_FILE` for the committed one).
    checksums : mapping of str -> str
        Relative path -> hex digest; written sorted by path.

    Returns
    -------
    Path
        The file written.

    Examples
    --------
    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "sums.txt")
    >>> sums = {"s6/L_line/2.csv": "b" * 64, "s6/L_line/1.csv": "a" * 64}
    >>> load_checksums(write_checksums(path, sums)) == sums
    True
    >>> [line[:8] + " ... " + line[66:].strip() for line in open(path) if not line.startswith("#")]
    ['aaaaaaaa ... s6/L_line/1.csv', 'bbbbbbbb ... s6/L_line/2.csv']
    """
    from .outputs import write_text

    body = "".join(f"{h}  {rel}\n" for rel, h in sorted(checksums.items()))
    return write_text(path, _HEADER + body)


def load_checksums(path=None) -> dict[str, str]:
    """Read a checksum file written by :func:`write_checksums`.

    Blank lines and lines starting with ``#`` are skipped; digits are read
    case-insensitively.

    Parameters
    ----------
    path : str or Path, optional
        Default :data:`CHECKSUMS_FILE`.

    Returns
    -------
    dict of str -> str
        Relative path -> lowercase hex digest, in the file's order.

    Raises
    ------
    ParameterError
        Naming the file and line of a malformed entry, an unsafe path or a
        repeated path, or when the file is missing or empty.

    Examples
    --------
    The committed file lists the 143 field recordings:

    >>> sums = load_checksums()
    >>> len(sums), "s8/line_dataset/1.csv" in sums
    (143, True)
    """
    path = Path(CHECKSUMS_FILE if path is None else path)
    try:
        lines = path.read_text().splitlines()
    except OSError as exc:
        raise ParameterError(f"{path}: cannot read checksum file ({exc.strerror})") from None
    out: dict[str, str] = {}
    for i, line in enumerate(lines, start=1):
        if not line.strip() or line.startswith("#"):
            continue
        parts = line.split(None, 1)
        digest = parts[0].lower() if parts else ""
        rel = parts[1].strip() if len(parts) == 2 else ""
        if len(digest) != 64 or any(c not in "0123456789abcdef" for c in digest) or not rel:
            raise ParameterError(f"{path}: line {i}: expected '<64 hex digits>  <relative path>'")
        if _unsafe(rel):
            raise ParameterError(f"{path}: line {i}: path {rel!r} is not a plain relative path")
        if rel in out:
            raise ParameterError(f"{path}: line {i}: {rel} listed twice")
        out[rel] = digest
    if not out:
        raise ParameterError(f"{path}: no checksums, expected one '<sha256>  <path>' line per recording")
    return out


def _resolve_checksums(checksums) -> dict[str, str]:
    if checksums is None:
        return load_checksums(CHECKSUMS_FILE)
    if isinstance(checksums, (str, os.PathLike)):
        return load_checksums(checksums)
    return {str(k): str(v).lower() for k, v in checksums.items()}


def verify_tree(root, checksums=None) -> list[str]:
    """Compare a dataset folder with checksums.

    Parameters
    ----------
    root : str or Path
        Folder holding the recordings (``root/s8/line_dataset/1.csv``).
    checksums : mapping or path, optional
        Relative path -> SHA-256 (a mapping, or a file in the format of
        :func:`write_checksums`); default the committed :data:`CHECKSUMS_FILE`.

    Returns
    -------
    list of str
        Problems (missing file, unexpected file, mismatch), one line per kind
        with a count and an example; empty when the folder's CSV files are
        exactly the expected ones with the expected contents (other files, such
        as a README, are not recordings and are not compared; a linked CSV never
        matches).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> root = pathlib.Path(tempfile.mkdtemp())
    >>> (root / "s6" / "L_line").mkdir(parents=True)
    >>> _ = (root / "s6" / "L_line" / "1.csv").write_bytes(b"abc")
    >>> sums = compute_checksums(root)
    >>> verify_tree(root, sums)
    []
    >>> _ = (root / "s6" / "L_line" / "1.csv").write_bytes(b"abd")
    >>> verify_tree(root, sums)
    ['checksum mismatch in 1 file(s), e.g. s6/L_line/1.csv']
    """
    expected = _resolve_checksums(checksums)
    root = Path(root)
    if not root.is_dir():
        return [f"{root}: not a directory"]
    found = {p.relative_to(root).as_posix(): p for p in root.rglob("*.csv") if p.is_file() or p.is_symlink()}
    return _compare(expected, {rel: (None if p.is_symlink() else sha256_file(p)) for rel, p in found.items()})


def _compare(expected: Mapping[str, str], got: Mapping[str, str | None]) -> list[str]:
    problems = []
    missing = sorted(set(expected) - set(got))
    extra = sorted(set(got) - set(expected))
    if missing:
        problems.append(f"{len(missing)} file(s) missing, e.g. {missing[0]}")
    if extra:
        problems.append(f"{len(extra)} unexpected file(s), e.g. {extra[0]}")
    bad = sorted(rel for rel in set(expected) & set(got) if got[rel] != expected[rel])
    if bad:
        problems.append(f"checksum mismatch in {len(bad)} file(s), e.g. {bad[0]}")
    return problems


# ----------------------------------------------------------------------------- what a dataset is

#: How the pages name the committed checksum list (the same file in a checkout and in the wheel).
CHECKSUMS_SHOWN = f"data/{CHECKSUMS_FILE.name}"


@dataclass(frozen=True)
class DatasetIdentity:
    """A dataset named by its content, the same wherever it lies (see :func:`dataset_identity`).

    Attributes
    ----------
    kind : str
        ``"field"`` (recordings given as they are) or ``"synthetic"``
        (written by :func:`morpi_filters.synthetic.write_dataset`).
    recordings : int
        Number of CSV files under the root.
    published : bool
        True when the CSV files are exactly those of :data:`CHECKSUMS_FILE`
        with their hashes (the public MoRPI recordings); False for any other
        set and for synthetic data.
    fingerprint : str or None
        Field data: sha256 of the dataset's checksum list, one ``<sha256>
        <relative path>`` line per CSV file sorted by path (the format of
        :func:`write_checksums` without its comment lines), so the published
        set's fingerprint is that of the body of :data:`CHECKSUMS_FILE`.
        None for synthetic data, whose bytes follow the machine's arithmetic.
    seed : int or None
        Seed of a synthetic dataset, when known.
    differences : tuple of str
        Field data that is not the published set: how it differs from
        :data:`CHECKSUMS_FILE` (missing, unexpected and changed files, each
        with a count and an example).
    """

    kind: str
    recordings: int
    published: bool = False
    fingerprint: str | None = None
    seed: int | None = None
    differences: tuple = ()

    @property
    def text(self) -> str:
        """One line for the pages, without the dataset's location.

        Returns
        -------
        str
            For example ``MoRPI field dataset (143 recordings matching
            data/dataset_checksums.txt, fingerprint 0123456789abcdef)`` or
            ``seeded synthetic recordings (seed 0, 143 recordings)``.

        Examples
        --------
        >>> DatasetIdentity("synthetic", 3, seed=7).text
        'seeded synthetic recordings (seed 7, 3 recordings)'
        >>> DatasetIdentity("field", 1, fingerprint="ab" * 32, differences=("2 file(s) missing, e.g. s6/L_line/1.csv",)).text
        'field recordings (1 recording, not the published MoRPI set: 2 file(s) missing, e.g. s6/L_line/1.csv; fingerprint abababababababab)'
        """
        n = f"{self.recordings} recording{'' if self.recordings == 1 else 's'}"
        if self.kind == "synthetic":
            return f"seeded synthetic recordings (seed {self.seed}, {n})" if self.seed is not None \
                else f"synthetic recordings ({n})"
        fp = (self.fingerprint or "")[:16]
        if self.published:
            return f"MoRPI field dataset ({n} matching {CHECKSUMS_SHOWN}, fingerprint {fp})"
        return (f"field recordings ({n}, not the published MoRPI set: "
                f"{'; '.join(self.differences)}; fingerprint {fp})")

    def as_json(self) -> dict:
        """The identity as JSON values (what a report's ``result.json`` holds).

        Returns
        -------
        dict
            ``description`` (:attr:`text`), ``kind``, ``recordings``,
            ``published``, ``fingerprint``, ``seed`` and ``differences``.

        Examples
        --------
        >>> DatasetIdentity("synthetic", 3, seed=7).as_json()["description"]
        'seeded synthetic recordings (seed 7, 3 recordings)'
        """
        return {"description": self.text, "kind": self.kind, "recordings": self.recordings,
                "published": self.published, "fingerprint": self.fingerprint, "seed": self.seed,
                "differences": list(self.differences)}


def _synthetic_seed(root: Path):
    """(True, seed) when `root` holds the manifest of a dataset written by ``morpi simulate``, else (False, None)."""
    try:
        m = json.loads((root / "manifest.json").read_text())
    except (OSError, ValueError):
        return False, None
    if not isinstance(m, dict) or m.get("generator") != "morpi_filters.simulate":
        return False, None
    seed = m.get("seed")
    return True, (seed if isinstance(seed, int) and not isinstance(seed, bool) else None)


def dataset_identity(root, *, synthetic: bool = False, seed: int | None = None) -> DatasetIdentity:
    """What the dataset under `root` is, independent of the path it is given by.

    Field recordings are hashed (:func:`compute_checksums`) and compared with
    :data:`CHECKSUMS_FILE`; a dataset flagged `synthetic`, or holding the
    manifest of :func:`morpi_filters.synthetic.write_dataset`, is named as
    synthetic with its seed. The answer is kept for the process while no CSV
    file under `root` changes its size or modification time, so the pages of
    one report hash the recordings once.

    Parameters
    ----------
    root : str or Path
        The dataset root.
    synthetic : bool, optional
        The caller knows the recordings are synthetic.
    seed : int, optional
        Their seed (default: the manifest's).

    Returns
    -------
    DatasetIdentity

    Raises
    ------
    ParameterError
        When `root` is not a directory.

    Examples
    --------
    >>> import pathlib, shutil, tempfile
    >>> a = pathlib.Path(tempfile.mkdtemp()) / "here"
    >>> (a / "s6" / "L_line").mkdir(parents=True)
    >>> _ = (a / "s6" / "L_line" / "1.csv").write_bytes(b"abc")
    >>> b = shutil.copytree(a, pathlib.Path(tempfile.mkdtemp()) / "there")
    >>> dataset_identity(a) == dataset_identity(b), dataset_identity(a).published
    (True, False)
    >>> dataset_identity(a, synthetic=True, seed=3).text
    'seeded synthetic recordings (seed 3, 1 recording)'
    """
    root = Path(root)
    if not root.is_dir():
        raise ParameterError(f"{root}: not a directory, expected a dataset root")
    stamp = []
    for p in root.rglob("*.csv"):
        with contextlib.suppress(OSError):
            st = p.stat()
            stamp.append((p.relative_to(root).as_posix(), st.st_size, st.st_mtime_ns))
    man = root / "manifest.json"
    with contextlib.suppress(OSError):
        st = man.stat()
        stamp.append((man.name, st.st_size, st.st_mtime_ns))
    return _identity(str(root.resolve()), bool(synthetic), seed, tuple(sorted(stamp)))


@functools.lru_cache(maxsize=16)
def _identity(root: str, synthetic: bool, seed, stamp) -> DatasetIdentity:
    """:func:`dataset_identity` of a resolved root; `stamp` (the files' sizes and times) keys the cache."""
    root = Path(root)
    made, made_seed = _synthetic_seed(root)
    if synthetic or made:
        n = sum(1 for p in root.rglob("*.csv") if p.is_file())
        return DatasetIdentity("synthetic", n, seed=seed if seed is not None else made_seed)
    sums = compute_checksums(root)
    body = "".join(f"{h}  {rel}\n" for rel, h in sums.items())
    differences = tuple(_compare(load_checksums(CHECKSUMS_FILE), sums))
    return DatasetIdentity("field", len(sums), published=not differences,
                           fingerprint=_sha256_stream(io.BytesIO(body.encode()).read), differences=differences)


# ----------------------------------------------------------------------------- archive members

def _unsafe(name: str) -> bool:
    """True for a member path that could land outside the destination."""
    if not name or "\\" in name or "\x00" in name or name.startswith("/") or (len(name) > 1 and name[1] == ":"):
        return True
    return any(part == ".." for part in name.split("/"))


def _data_relpath(name: str) -> str | None:
    """Path below ``<top>/data/`` of an archive member, or None for members outside it."""
    parts = PurePosixPath(name).parts
    if len(parts) < 3 or parts[1] != ARCHIVE_DATA_DIR:
        return None
    return "/".join(parts[2:])


class _Archive:
    """Iterate (name, kind, opener) over the members of a zip or tar.gz file."""

    def __init__(self, path: Path, url: str):
        self.path, self.url = path, url
        with open(path, "rb") as fh:
            magic = fh.read(4)
        if magic[:2] == b"\x1f\x8b":
            self.kind = "tar.gz"
        elif magic[:4] in (b"PK\x03\x04", b"PK\x05\x06"):
            self.kind = "zip"
        else:
            raise FetchError(f"{url}: not a .zip or .tar.gz archive (first bytes {magic!r})")

    def members(self):
        if self.kind == "zip":
            with zipfile.ZipFile(self.path) as zf:
                for info in zf.infolist():
                    mode = info.external_attr >> 16
                    if info.is_dir():
                        kind = "dir"
                    elif stat.S_ISLNK(mode):
                        kind = "link"
                    elif stat.S_IFMT(mode) not in (0, stat.S_IFREG):   # 0: no type bits (plain writers)
                        kind = "special"
                    else:
                        kind = "file"
                    yield info.filename, kind, (lambda info=info: zf.open(info))
        else:
            with tarfile.open(self.path, "r:gz") as tf:
                for m in tf:
                    kind = ("dir" if m.isdir() else "file" if m.isreg() else
                            "link" if (m.issym() or m.islnk()) else "special")
                    yield m.name, kind, (lambda m=m: tf.extractfile(m))


# ----------------------------------------------------------------------------- fetch

@renamed_keywords(dest="out")
def fetch_dataset(out, *, url: str | None = None, checksums=None, timeout: float = 60.0,
                  progress: Callable[[str], None] | None = None) -> Path:
    """Download, unpack and verify the field dataset; all or nothing.

    Parameters
    ----------
    out : str or Path
        Destination folder; the recordings land in ``out/data``. It must
        not exist, be empty, or already hold the verified dataset.
    url : str, optional
        Archive URL (``http(s)://`` or ``file://``); default
        :data:`DEFAULT_URL`.
    checksums : mapping or path, optional
        Relative path -> SHA-256 of every expected recording; default the
        committed :data:`CHECKSUMS_FILE`.
    timeout : float, optional
        Seconds to wait for the server at each step (default 60).
    progress : callable, optional
        Receives one-line progress messages; default: printed to stdout
        (stderr is left to the one-line error).

    Returns
    -------
    Path
        The dataset root ``out/data`` (pass it as ``--data``).

    Raises
    ------
    FetchError
        One line naming the URL, for a failed download or an archive that is
        unsafe, corrupt or does not match the checksums. Nothing is left
        behind: `out` is either untouched or absent, and no staging or
        temporary file remains.
    OutputError
        One line naming the destination, when it is in the way or cannot be
        written; nothing is left behind either.

    Examples
    --------
    Offline, from a ``file://`` archive laid out as the repository's
    (``<top>/data/...``), checked against its own checksums:

    >>> import hashlib, pathlib, tempfile, zipfile
    >>> work = pathlib.Path(tempfile.mkdtemp())
    >>> with zipfile.ZipFile(work / "repo.zip", "w") as zf:
    ...     zf.writestr("MoRPI-main/README.md", "a repository")
    ...     zf.writestr("MoRPI-main/data/s6/L_line/1.csv", "abc")
    >>> sums = {"s6/L_line/1.csv": hashlib.sha256(b"abc").hexdigest()}
    >>> root = fetch_dataset(work / "dest", url=(work / "repo.zip").as_uri(), checksums=sums,
    ...                      progress=lambda msg: None)
    >>> root == work / "dest" / "data", sorted(p.name for p in root.rglob("*"))
    (True, ['1.csv', 'L_line', 's6'])
    >>> sums["s6/L_line/1.csv"] = "0" * 64
    >>> fetch_dataset(work / "other", url=(work / "repo.zip").as_uri(), checksums=sums,
    ...               progress=lambda msg: None)
    Traceback (most recent call last):
    ...
    morpi_filters.errors.FetchError: file://...: archive does not match the dataset checksums: checksum mismatch in 1 file(s), e.g. s6/L_line/1.csv
    >>> (work / "other").exists()
    False
    """
    say = progress or (lambda msg: print(msg, flush=True))
    url = DEFAULT_URL if url is None else url
    expected = _resolve_checksums(checksums)
    dest = Path(out).expanduser()
    root = dest / ARCHIVE_DATA_DIR
    if dest.exists() or dest.is_symlink():
        if not dest.is_dir() or dest.is_symlink():
            raise OutputError(f"{dest}: exists and is not a folder, expected a new or empty destination folder")
        if root.is_dir() and not verify_tree(root, expected):
            say(f"{root}: already holds the verified dataset ({len(expected)} files); nothing to do")
            return root
        if any(dest.iterdir()):
            raise OutputError(f"{dest}: not empty and not a verified dataset; remove it or choose another --out")
    try:
        dest.parent.mkdir(parents=True, exist_ok=True)
        stage = new_stage_dir(dest)
    except OSError as exc:
        raise OutputError(f"{dest}: cannot create a staging folder beside it ({exc.strerror or exc})") from None
    try:
        archive = stage / "download"
        say(f"downloading {url}")
        _download(url, archive, timeout)
        tree = stage / "tree"
        got = _unpack(archive, tree / ARCHIVE_DATA_DIR, url)
        archive.unlink()
        problems = _compare(expected, got)
        if problems:
            raise FetchError(f"{url}: archive does not match the dataset checksums: {'; '.join(problems)}")
        if dest.is_dir():
            dest.rmdir()   # empty (checked above); fails loudly if something appeared meanwhile
        swap_in(tree, dest)
    except MorpiError:
        shutil.rmtree(stage, ignore_errors=True)
        raise
    except OSError as exc:
        shutil.rmtree(stage, ignore_errors=True)
        raise OutputError(f"{dest}: cannot write the dataset ({exc.strerror or exc})") from None
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise
    shutil.rmtree(stage, ignore_errors=True)
    say(f"{root}: {len(got)} recordings verified")
    return root


#: What a user without network access (or with a blocked archive URL) can do instead.
OFFLINE_ALTERNATIVES = (
    "alternatives: clone the public repository (git clone https://github.com/ansfl/MoRPI) and pass "
    "--data to the clone, pass --data to an existing copy of the recordings, or run "
    "`morpi simulate --out DIR` for a synthetic dataset in the same layout"
)


def _download(url: str, path: Path, timeout: float) -> None:
    """Stream `url` to `path`; a failed download names the alternatives to downloading."""
    try:
        _stream(url, path, timeout)
    except MorpiError as exc:
        raise FetchError(f"{exc}; {OFFLINE_ALTERNATIVES}") from None


def _stream(url: str, path: Path, timeout: float) -> None:
    """Stream `url` to `path`; a short body (fewer bytes than Content-Length) is an error."""
    try:
        with contextlib.closing(urllib.request.urlopen(url, timeout=timeout)) as resp, open(path, "wb") as out:
            length = resp.headers.get("Content-Length") if hasattr(resp, "headers") else None
            n = 0
            for block in iter(lambda: resp.read(_CHUNK), b""):
                out.write(block)
                n += len(block)
            if length is not None and length.isdigit() and n != int(length):
                raise FetchError(f"{url}: download truncated: {n} of {length} bytes")
    except urllib.error.HTTPError as exc:
        raise FetchError(f"{url}: download failed: HTTP {exc.code} {exc.reason}") from None
    except urllib.error.URLError as exc:
        reason = exc.reason
        if isinstance(reason, (socket.timeout, TimeoutError)):
            raise FetchError(f"{url}: download failed: no answer within {timeout:g} s") from None
        text = getattr(reason, "strerror", None) or str(reason)
        raise FetchError(f"{url}: download failed: {text}") from None
    except (socket.timeout, TimeoutError):
        raise FetchError(f"{url}: download failed: no answer within {timeout:g} s") from None
    except http.client.IncompleteRead as exc:
        raise FetchError(f"{url}: download truncated after {len(exc.partial)} bytes") from None
    except (http.client.HTTPException, ConnectionError) as exc:
        raise FetchError(f"{url}: download failed: {exc.__class__.__name__} {exc}") from None
    except ValueError as exc:
        raise FetchError(f"{url}: not a usable URL ({exc})") from None


def _unpack(archive: Path, out: Path, url: str) -> dict[str, str]:
    """Extract the CSVs under ``<top>/data/`` into `out`; return rel path -> SHA-256."""
    arc = _Archive(archive, url)
    got: dict[str, str] = {}
    top = None
    try:
        for name, kind, opener in arc.members():
            if _unsafe(name.rstrip("/")):
                raise FetchError(f"{url}: member {name!r} would escape the destination; refusing the archive")
            head = name.split("/", 1)[0]
            if top is None:
                top = head
            elif head != top:
                raise FetchError(f"{url}: members under both {top!r} and {head!r}; expected one top folder")
            rel = _data_relpath(name.rstrip("/"))
            if rel is None or kind == "dir":
                continue
            if kind != "file":
                raise FetchError(f"{url}: member {name!r} is a {kind}, not a regular file; refusing the archive")
            if not rel.endswith(".csv"):
                continue
            if rel in got:
                raise FetchError(f"{url}: member {name!r} appears twice")
            target = out / rel
            target.parent.mkdir(parents=True, exist_ok=True)
            src = opener()
            with src, open(target, "xb") as fh:
                got[rel] = _sha256_stream(src.read, fh.write)
    except (zipfile.BadZipFile, zipfile.LargeZipFile, tarfile.TarError, zlib.error, EOFError) as exc:
        raise FetchError(f"{url}: truncated or corrupt {arc.kind} archive ({exc or exc.__class__.__name__})") \
            from None
    if top is None:
        raise FetchError(f"{url}: empty {arc.kind} archive")
    return got
