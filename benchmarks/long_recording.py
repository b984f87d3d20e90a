"""Loading a one-hour, 100 Hz recording: peak memory, and time against pandas' parse of the same file.

A synthetic recording (360,000 rows, the dataset's CSV format) is written to a
temporary folder. Two paired ratios, in alternation, the ratio taken per pair:

- ours: :func:`morpi_filters.dataset.load_csv` (every check of ``morpi check``);
- floor: ``pandas.read_csv`` of the same file (parse only);

once with each side in its own fresh interpreter (:func:`pairs.paired_commands`:
interpreter start and imports included, pandas on both sides) and once in this
process (the parse alone).

The peak resident memory of a fresh process running ``load_csv`` is read by
``/usr/bin/time -v`` (:func:`pairs.run_peak`). Target: under 100 MB (about 69 MB of
it is the interpreter with numpy and pandas imported, 20 MB the float64 result).
For information, the same with one bad line at the end of the file, which the
line-by-line path names.

Usage: ``PYTHONPATH=. python3 benchmarks/long_recording.py [--pairs N]``
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402
from pairs import paired, paired_commands, python_command, run_peak  # noqa: E402

from morpi_filters import dataset as ds  # noqa: E402

PEAK = "import sys; from morpi_filters import dataset as ds; r = ds.load_csv(sys.argv[1]); assert r.time.size == 360_000"
PEAK_BAD = ("import sys; from morpi_filters import dataset as ds\n"
            "try:\n    ds.load_csv(sys.argv[1])\nexcept ds.DataError as e:\n    assert 'line 360002' in str(e), e\n"
            "else:\n    raise SystemExit('the bad line was not named')")


def measure(pairs: int = 5, quick: bool = False):
    """The peak memory (a row dict) and the paired ratios to pandas of loading a one-hour recording.

    Returns
    -------
    rows : list
        A row dict for the peak memory (``unit`` "MB", target 100) and two
        :class:`pairs.PairedRatio` (fresh processes, in process).
    """
    repo = Path(__file__).resolve().parents[1]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "one_hour.csv"
        n = 360_000
        rng = np.random.default_rng(0)
        t = np.arange(n) * 0.01
        f = np.c_[rng.normal(0, 0.05, (n, 2)), 9.8 + rng.normal(0, 0.05, n)]
        ds.write_csv(path, ds.Recording(time=t, f=f, omega=rng.normal(0, 0.01, (n, 3)), source=str(path)))
        env = {"PYTHONPATH": str(repo), "PATH": "/usr/bin:/bin"}
        _, peak = run_peak([sys.executable, "-c", PEAK, str(path)], env=env)
        rows.append({"name": f"load_csv (morpi check), one hour at 100 Hz ({n} rows, "
                             f"{path.stat().st_size / 1e6:.0f} MB of CSV): peak memory",
                     "min": peak, "median": peak, "max": peak, "unit": "MB", "pairs": 1, "target": 100.0,
                     "met": peak < 100.0})
        bad = Path(tmp) / "one_hour_bad.csv"
        with open(path, "rb") as src, open(bad, "wb") as dst:
            dst.write(src.read())
            dst.write(b"1.0,0,0,9.8,0,0,0\n")      # time goes back on the last line
        _, peak_bad = run_peak([sys.executable, "-c", PEAK_BAD, str(bad)], env=env)
        rows.append({"name": "load_csv of the same file with a bad last line (named by the line-by-line path): "
                             "peak memory (for information)",
                     "min": peak_bad, "median": peak_bad, "max": peak_bad, "unit": "MB", "pairs": 1, "target": None,
                     "met": None})
        import pandas as pd

        ours = [sys.executable, "-c", f"from morpi_filters import dataset as ds; ds.load_csv({str(path)!r})"]
        floor = python_command(f"import pandas; pandas.read_csv({str(path)!r})")
        rows.append(paired_commands("load_csv / pandas.read_csv (one-hour file, fresh processes)", ours, floor,
                                    pairs=pairs, env=env))
        rows.append(paired("load_csv / pandas.read_csv (one-hour file, in process)", lambda: ds.load_csv(path),
                           lambda: pd.read_csv(path), pairs=pairs))
    return rows


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--pairs", type=int, default=5)
    args = p.parse_args(argv)
    for r in measure(args.pairs):
        if isinstance(r, dict):
            tgt = "" if r["target"] is None else f" (target < {r['target']:g} MB)"
            print(f"{r['name']} {r['median']:.0f} MB{tgt}")
        else:
            print(r.line())


if __name__ == "__main__":
    main()
