"""Write the manifest of the MoRPI dataset, ``data/morpi.toml``, from the project's ``data/routes.json``.

Usage (from the project root)::

    PYTHONPATH=. python3 analysis/morpi_manifest.py [--out data/morpi.toml] [--check]

One ``[[recording]]`` per folder of the layout (``<phone>/<route>[/<split>]``), its CSV
files by a glob relative to the dataset root, in this order: the phones S8, then S6, each
one's folders by route, then split, so that the groups with train recordings come in the
order of the paper's short-route table (:func:`morpi_filters.evaluate.short_route_sets`). Each folder's group is ``<phone>/<route>``,
its split the folder's (``"none"`` without one), its motion the route's kind, its rest
detected (``"auto"``), its train group the paper's for routes evaluated with another route's gains,
its IMU the phone's (:data:`PHONE_IMUS`), its number of runs in the
public dataset (``imu.count``, which ``morpi check --data`` compares with the files found), its truth
the route's distance, end point and centre line (:attr:`morpi_filters.dataset.Route.polyline`).
The recordings' latitude is the experiment site's
(:data:`SITE_LATITUDE_DEG`), so the calibrations take normal gravity there
(:func:`morpi_filters.calibration.normal_gravity`); its ``[evaluation]`` settings are
the tables' (runs held out of their own group, the INS over the motion window) and the aided study's (a
filter per MoRPI method). No recording is read.

``--check`` writes nothing and exits 1 when the file differs from what would be written.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from morpi_filters import dataset as ds
from morpi_filters.resources import morpi_manifest
from morpi_filters.units import LSM6DSL, MPU6500

#: Latitude of the experiment site, University of Haifa [deg N]: the recordings' normal gravity.
SITE_LATITUDE_DEG = 32.8
#: The phones in the manifest's order.
PHONES = ("s8", "s6")
#: Each phone's IMU (the paper's table of sensors: the Galaxy S6 carries the MPU-6500, the S8 the LSM6DSL),
#: by the name a manifest gives it.
PHONE_IMUS = {"s6": MPU6500.name, "s8": LSM6DSL.name}


def _folders() -> list:
    """(phone, route, split or None, number of runs) of every layout folder, in the manifest's order."""
    out = []
    for key, runs in ds.layout().items():
        parts = key.split("/")
        out.append((parts[0], parts[1], parts[2] if len(parts) == 3 else None, runs))
    return sorted(out, key=lambda k: (PHONES.index(k[0]), k[1], k[2] or ""))


def _train_groups() -> dict:
    """(phone, route) -> the group whose train runs set its gains, for the routes the paper evaluates with
    another route's gains (the long and the L routes: :func:`morpi_filters.evaluate.cell_specs`)."""
    from morpi_filters.evaluate import cell_specs

    return {(s.phone, s.route): f"{s.train[0]}/{s.train[1]}" for s in cell_specs()
            if s.train is not None and s.train != (s.phone, s.route)}


def _number(x: float) -> str:
    return repr(float(x))


def manifest_text() -> str:
    """The manifest, as TOML text."""
    lines = [
        "# The MoRPI dataset (github.com/ansfl/MoRPI) as a dataset manifest: its files relative to the dataset",
        "# root (the folder holding s6 and s8). Written by analysis/morpi_manifest.py from data/routes.json.",
        "format_version = 1",
        'name = "MoRPI"',
        'description = "Two phones (Galaxy S6 and S8) on a mobile robot: straight and periodic routes, indoor and '
        'outdoor; truth: the routes\' end points."',
        f"latitude_deg = {_number(SITE_LATITUDE_DEG)}",
        "",
        "# as the paper's tables: each train run is held out of its own group, the INS integrates the motion,",
        "# and the aided filter runs on the steps of each MoRPI method",
        "[evaluation]",
        'held_out = "recording"',
        'ins_span = "motion"',
        'aided_methods = "each"',
        "",
        "[defaults]",
        'rest = "auto"',
    ]
    trains = _train_groups()
    for phone, route_name, split, runs in _folders():
        r = ds.route(route_name)
        folder = "/".join(p for p in (phone, route_name, split) if p)
        poly = ", ".join(f"[{_number(x)}, {_number(y)}]" for x, y in r.polyline)
        end = ", ".join(_number(v) for v in r.end_point_m)
        lines += [
            "",
            "[[recording]]",
            f'group = "{phone}/{route_name}"',
            f'split = "{split or "none"}"',
            f'motion = "{"periodic" if r.kind == "periodic" else "straight"}"',
            *([f'train_group = "{trains[phone, route_name]}"'] if (phone, route_name) in trains else []),
            f'imu = {{ file = "{folder}/*.csv", spec = "{PHONE_IMUS[phone]}", count = {runs} }}',
            f'truth = {{ kind = "route", distance_m = {_number(r.distance_m)}, end_point_m = [{end}], '
            f"polyline_m = [{poly}] }}",
        ]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("data") / morpi_manifest().name)
    ap.add_argument("--check", action="store_true", help="compare with the file instead of writing it")
    args = ap.parse_args(argv)
    text = manifest_text()
    if args.check:
        same = args.out.is_file() and args.out.read_text() == text
        print(f"{args.out}: {'up to date' if same else 'differs from what analysis/morpi_manifest.py writes'}")
        return 0 if same else 1
    args.out.write_text(text)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
