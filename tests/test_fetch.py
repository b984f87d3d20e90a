"""`morpi data fetch`: archives served from a local HTTP server (127.0.0.1 only, never the network).

Each archive is built in tmp_path from a tiny synthetic tree in the MoRPI layout
(``<top>/data/<phone>/<route>/.../<n>.csv`` plus files that are not data), with
a matching checksum file passed through ``checksums=``.
"""
from __future__ import annotations

import functools
import hashlib
import http.server
import io
import socket
import tarfile
import threading
import zipfile
from pathlib import Path

import numpy as np
import pytest

from morpi_filters import fetch
from morpi_filters.cli import main
from morpi_filters.dataset import load_catalogue
from morpi_filters.errors import MorpiError
from morpi_filters.fetch import (CHECKSUMS_FILE, compute_checksums, fetch_dataset, load_checksums, verify_tree,
                                 write_checksums)

TOP = "MoRPI-main"
DATA_FILES = ("s8/line_dataset/1.csv", "s8/short_distance/train/3.csv", "s6/L_line/2.csv")


def csv_bytes(seed: int) -> bytes:
    rng = np.random.default_rng(seed)
    n = 120
    t = 5.0 + np.cumsum(rng.uniform(0.0095, 0.012, n))
    f = np.array([0.0, 0.0, 9.8]) + 0.01 * rng.standard_normal((n, 3))
    w = 0.001 * rng.standard_normal((n, 3))
    rows = ["time,f_x,f_y,f_z,g_x,g_y,g_z"] + [",".join(repr(float(v)) for v in r)
                                                for r in np.column_stack([t, f, w])]
    return ("\n".join(rows) + "\n").encode()


@pytest.fixture
def tree():
    """Archive member name -> bytes: data files plus non-data files that must be skipped."""
    members = {f"{TOP}/data/{rel}": csv_bytes(i) for i, rel in enumerate(DATA_FILES)}
    members[f"{TOP}/README.md"] = b"# MoRPI\n"
    members[f"{TOP}/figures/scheme.jpg"] = b"\xff\xd8\xff not really a jpeg"
    members[f"{TOP}/data/notes.txt"] = b"not a recording\n"
    return members


@pytest.fixture
def sums(tree):
    return {name.split("/data/", 1)[1]: hashlib.sha256(b).hexdigest()
            for name, b in tree.items() if "/data/" in name and name.endswith(".csv")}


def make_zip(path: Path, members: dict, links=()) -> Path:
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as zf:
        zf.writestr(f"{TOP}/", b"")
        for name, data in members.items():
            zf.writestr(name, data)
        for name, target in links:
            info = zipfile.ZipInfo(name)
            info.external_attr = (0o120777 << 16)
            zf.writestr(info, target)
    return path


def make_targz(path: Path, members: dict, links=()) -> Path:
    with tarfile.open(path, "w:gz") as tf:
        d = tarfile.TarInfo(TOP)
        d.type = tarfile.DIRTYPE
        tf.addfile(d)
        for name, data in members.items():
            info = tarfile.TarInfo(name)
            info.size = len(data)
            tf.addfile(info, io.BytesIO(data))
        for name, target in links:
            info = tarfile.TarInfo(name)
            info.type = tarfile.SYMTYPE
            info.linkname = target
            tf.addfile(info)
    return path


class _Quiet(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):
        pass


@pytest.fixture
def server(tmp_path):
    """A static HTTP server on 127.0.0.1 (port chosen by the OS) serving tmp_path/srv."""
    root = tmp_path / "srv"
    root.mkdir()
    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), functools.partial(_Quiet, directory=str(root)))
    th = threading.Thread(target=httpd.serve_forever, kwargs=dict(poll_interval=0.02), daemon=True)
    th.start()
    yield root, f"http://127.0.0.1:{httpd.server_address[1]}"
    httpd.shutdown()
    httpd.server_close()


def leftovers(parent: Path) -> list[str]:
    return sorted(p.name for p in parent.iterdir() if p.name.startswith(".staging"))


def quiet(msgs):
    return msgs.append


# ----------------------------------------------------------------------------- good archives

@pytest.mark.parametrize("maker, name", [(make_zip, "x.zip"), (make_targz, "x.tar.gz")])
def test_good_archive_is_unpacked_and_verified(server, tmp_path, tree, sums, maker, name):
    srv, base = server
    maker(srv / name, tree)
    dest = tmp_path / "out" / "morpi-data"
    msgs = []
    root = fetch_dataset(dest, url=f"{base}/{name}", checksums=sums, progress=quiet(msgs))
    assert root == dest / "data"
    got = sorted(p.relative_to(root).as_posix() for p in root.rglob("*") if p.is_file())
    assert got == sorted(DATA_FILES)                       # only the CSVs under data/
    assert sorted(p.name for p in dest.iterdir()) == ["data"]
    for rel in DATA_FILES:
        assert (root / rel).read_bytes() == tree[f"{TOP}/data/{rel}"]
    assert leftovers(dest.parent) == []
    assert len(load_catalogue(root)) == 3                    # the result is a usable dataset root
    # A second call finds the verified dataset and leaves it alone.
    mtime = (root / DATA_FILES[0]).stat().st_mtime_ns
    msgs.clear()
    assert fetch_dataset(dest, url=f"{base}/missing.zip", checksums=sums, progress=quiet(msgs)) == root
    assert "already holds the verified dataset" in msgs[0]
    assert (root / DATA_FILES[0]).stat().st_mtime_ns == mtime


def test_empty_destination_folder_is_used(server, tmp_path, tree, sums):
    srv, base = server
    make_zip(srv / "x.zip", tree)
    dest = tmp_path / "d"
    dest.mkdir()
    root = fetch_dataset(dest, url=f"{base}/x.zip", checksums=sums, progress=quiet([]))
    assert verify_tree(root, sums) == []


# ----------------------------------------------------------------------------- failures

def assert_clean_failure(dest: Path, call, match: str):
    before = sorted(p.name for p in dest.parent.iterdir()) if dest.parent.exists() else None
    with pytest.raises(MorpiError, match=match) as info:
        call()
    assert "\n" not in str(info.value)
    assert not dest.exists()
    assert leftovers(dest.parent) == []
    if before is not None:
        assert sorted(p.name for p in dest.parent.iterdir()) == before


def test_http_404(server, tmp_path, sums):
    _, base = server
    dest = tmp_path / "d"
    assert_clean_failure(dest, lambda: fetch_dataset(dest, url=f"{base}/nope.zip", checksums=sums,
                                                     progress=quiet([])), r"HTTP 404")


def test_connection_refused(tmp_path, sums):
    with socket.socket() as s:          # a port that was free a moment ago and has no listener now
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    dest = tmp_path / "d"
    assert_clean_failure(dest, lambda: fetch_dataset(dest, url=f"http://127.0.0.1:{port}/x.zip", checksums=sums,
                                                     progress=quiet([]), timeout=5), r"download failed")


def test_timeout(tmp_path, sums):
    with socket.socket() as s:          # accepts connections (backlog) but never answers
        s.bind(("127.0.0.1", 0))
        s.listen(1)
        port = s.getsockname()[1]
        dest = tmp_path / "d"
        assert_clean_failure(dest, lambda: fetch_dataset(dest, url=f"http://127.0.0.1:{port}/x.zip",
                                                         checksums=sums, progress=quiet([]), timeout=0.5),
                             r"no answer within 0.5 s")


class _ShortBody(http.server.BaseHTTPRequestHandler):
    """Announces 100000 bytes and sends 1000, then closes the connection."""

    def do_GET(self):
        self.send_response(200)
        self.send_header("Content-Length", "100000")
        self.end_headers()
        self.wfile.write(b"PK\x03\x04" + bytes(996))
        self.wfile.flush()
        self.close_connection = True

    def log_message(self, *args):
        pass


def test_transfer_cut_short(tmp_path, sums):
    httpd = http.server.HTTPServer(("127.0.0.1", 0), _ShortBody)
    th = threading.Thread(target=httpd.serve_forever, kwargs=dict(poll_interval=0.02), daemon=True)
    th.start()
    try:
        dest = tmp_path / "d"
        assert_clean_failure(dest, lambda: fetch_dataset(dest, url=f"http://127.0.0.1:{httpd.server_address[1]}/x.zip",
                                                         checksums=sums, progress=quiet([]), timeout=5),
                             r"download truncated")
    finally:
        httpd.shutdown()
        httpd.server_close()


@pytest.mark.parametrize("maker, name", [(make_zip, "x.zip"), (make_targz, "x.tar.gz")])
def test_truncated_archive(server, tmp_path, tree, sums, maker, name):
    srv, base = server
    full = maker(tmp_path / name, tree).read_bytes()
    (srv / name).write_bytes(full[: len(full) * 2 // 3])
    dest = tmp_path / "d"
    assert_clean_failure(dest, lambda: fetch_dataset(dest, url=f"{base}/{name}", checksums=sums,
                                                     progress=quiet([])), r"truncated or corrupt")


def test_not_an_archive(server, tmp_path, sums):
    srv, base = server
    (srv / "x.zip").write_text("<html>rate limited</html>")
    dest = tmp_path / "d"
    assert_clean_failure(dest, lambda: fetch_dataset(dest, url=f"{base}/x.zip", checksums=sums,
                                                     progress=quiet([])), r"not a \.zip or \.tar\.gz archive")


def test_corrupt_member(server, tmp_path, tree, sums):
    srv, base = server
    data = bytearray(make_zip(tmp_path / "x.zip", {k: v * 50 for k, v in tree.items()}).read_bytes())
    i = data.find(b"PK\x03\x04", 100)       # damage the compressed bytes of a later member
    data[i + 60:i + 80] = bytes(20)
    (srv / "x.zip").write_bytes(bytes(data))
    dest = tmp_path / "d"
    assert_clean_failure(dest, lambda: fetch_dataset(dest, url=f"{base}/x.zip", checksums=sums,
                                                     progress=quiet([])), r"truncated or corrupt zip")


@pytest.mark.parametrize("change, match", [("mismatch", "checksum mismatch in 1 file"),
                                           ("missing", "1 file\\(s\\) missing"),
                                           ("extra", "1 unexpected file")])
def test_checksum_problems(server, tmp_path, tree, sums, change, match):
    srv, base = server
    sums = dict(sums)
    if change == "mismatch":
        sums[DATA_FILES[1]] = "0" * 64
    elif change == "missing":
        sums["s6/L_line/99.csv"] = "0" * 64
    else:
        del sums[DATA_FILES[2]]
    make_targz(srv / "x.tar.gz", tree)
    dest = tmp_path / "d"
    assert_clean_failure(dest, lambda: fetch_dataset(dest, url=f"{base}/x.tar.gz", checksums=sums,
                                                     progress=quiet([])), match)


@pytest.mark.parametrize("maker", [make_zip, make_targz])
@pytest.mark.parametrize("evil", [f"{TOP}/data/../../evil.csv", "/tmp/evil.csv", f"{TOP}/data/s8/..\\..\\x.csv"])
def test_member_escaping_destination(server, tmp_path, tree, sums, maker, evil):
    srv, base = server
    maker(srv / "x.arc", {**tree, evil: b"time\n"})
    dest = tmp_path / "d"
    assert_clean_failure(dest, lambda: fetch_dataset(dest, url=f"{base}/x.arc", checksums=sums,
                                                     progress=quiet([])), r"escape the destination")
    assert not (tmp_path / "evil.csv").exists()


@pytest.mark.parametrize("maker", [make_zip, make_targz])
def test_symlink_member(server, tmp_path, tree, sums, maker):
    srv, base = server
    maker(srv / "x.arc", tree, links=[(f"{TOP}/data/s8/line_dataset/5.csv", "/etc/passwd")])
    dest = tmp_path / "d"
    assert_clean_failure(dest, lambda: fetch_dataset(dest, url=f"{base}/x.arc", checksums=sums,
                                                     progress=quiet([])), r"is a link")


def test_existing_unverified_destination_is_left_alone(server, tmp_path, tree, sums):
    srv, base = server
    make_zip(srv / "x.zip", tree)
    dest = tmp_path / "d"
    (dest / "data").mkdir(parents=True)
    (dest / "data" / "mine.txt").write_text("keep me")
    with pytest.raises(MorpiError, match="not empty and not a verified dataset"):
        fetch_dataset(dest, url=f"{base}/x.zip", checksums=sums, progress=quiet([]))
    assert (dest / "data" / "mine.txt").read_text() == "keep me"
    assert leftovers(tmp_path) == []


def test_checksum_file_round_trip_and_errors(tmp_path, sums):
    p = write_checksums(tmp_path / "c.txt", sums)
    assert load_checksums(p) == sums
    bad = tmp_path / "bad.txt"
    bad.write_text("# header\nabc  s8/x.csv\n")
    with pytest.raises(MorpiError, match=r"bad.txt: line 2"):
        load_checksums(bad)
    bad.write_text(f"{'a' * 64}  ../x.csv\n")
    with pytest.raises(MorpiError, match=r"line 1: path '../x.csv'"):
        load_checksums(bad)


# ----------------------------------------------------------------------------- committed file

@pytest.mark.field
def test_committed_checksums_match_the_field_dataset(field_root):
    committed = load_checksums(CHECKSUMS_FILE)
    assert len(committed) == 143
    assert compute_checksums(field_root) == committed     # a stale file fails here
    assert verify_tree(field_root) == []


# ----------------------------------------------------------------------------- CLI

def test_cli_fetch_exit_codes(server, tmp_path, tree, sums, monkeypatch, capsys):
    srv, base = server
    make_zip(srv / "x.zip", tree)
    sums_file = write_checksums(tmp_path / "sums.txt", sums)
    monkeypatch.setattr(fetch, "CHECKSUMS_FILE", sums_file)
    dest = tmp_path / "D"
    assert main(["data", "fetch", "--out", str(dest), "--url", f"{base}/x.zip"]) == 0
    out = capsys.readouterr().out
    assert f"verified at {dest / 'data'}" in out
    bad = tmp_path / "E"
    assert main(["data", "fetch", "--out", str(bad), "--url", f"{base}/y.zip"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("morpi: error: ") and "HTTP 404" in err
    assert not bad.exists() and leftovers(tmp_path) == []
