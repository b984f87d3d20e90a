"""The ``morpi`` command: thin subcommands over the library.

Each subcommand parses its arguments, calls one library function and writes
into ``reports/`` (or the folder given by ``--out``). Outputs are checked
before anything is computed (a folder is replaced only when it is new, empty
or an earlier output of the same kind holding nothing its marker does not
list; a ``--json`` file only when morpi wrote it, or with ``--force``), built
in staging places and swapped in together only when complete. Errors a user
can cause are printed on one line (``morpi: error: ...``). Exit status: 0
success, 1 bad input data, 2 bad arguments or parameters (or an output folder
that is not morpi's), 130 interrupted (SIGINT), 143 terminated (SIGTERM).
Commands that read the recordings stop when one they need is bad or missing,
unless ``--partial``.
"""
from __future__ import annotations

import argparse
import math
import re
import signal
import sys
import threading
from pathlib import Path

from .errors import MissingDataError, MorpiError, OutputError

__all__ = ["main", "build_parser"]

REPORT_SECTIONS = ("tables", "aided", "assessment", "curves", "montecarlo", "drift")


class _Number:
    """The type of a numeric option: a whole number or a finite real within ``[lo, hi]``.

    Refuses, with one line that states the accepted range, whatever is not a
    number of that kind, NaN, an infinity and a value outside the range (an
    integer of any length is refused from its text, not converted). `above`,
    when given, words the refusal of a value above `hi`, up to 1000 times `hi`
    (an estimate of its cost); the range is stated after it.
    """

    def __init__(self, whole: bool, lo, hi, unit: str = "", above=None):
        self.whole, self.lo, self.hi, self.unit, self.above = whole, lo, hi, unit, above

    @property
    def accepted(self) -> str:
        """The accepted values, as the refusals state them."""
        unit = f" {self.unit}" if self.unit else ""
        if self.whole:
            return f"a whole number, at least {self.lo:d} and at most {self.hi:d}{unit}"
        return f"a number, at least {self.lo:g} and at most {self.hi:g}{unit}"

    def __call__(self, text: str):
        shown = _shown(text)
        value = _whole(text) if self.whole else _real(text)
        if value is None:
            raise argparse.ArgumentTypeError(f"{shown} is not {'a whole number' if self.whole else 'a number'}; "
                                             f"expected {self.accepted}")
        if self.lo <= value <= self.hi:
            return value
        if self.above is not None and self.hi < value <= 1000 * self.hi:
            raise argparse.ArgumentTypeError(f"{self.above(value, shown)}; expected {self.accepted}")
        raise argparse.ArgumentTypeError(f"{shown} is outside the accepted range; expected {self.accepted}")


def _shown(text: str) -> str:
    """An argument as a refusal quotes it: in full up to 24 characters, else its start and its length."""
    text = " ".join(str(text).split())
    return repr(text) if len(text) <= 24 else f"{text[:12]!r}... ({len(text)} characters)"


def _whole(text: str):
    """The whole number `text` writes in decimal digits (an optional sign), else None.

    A number of more than 30 digits is returned as an infinity of its sign: it is
    beyond every bound here, and Python refuses to convert more than 4300 digits.
    """
    t = str(text).strip()
    if not re.fullmatch(r"[+-]?[0-9]+", t):
        return None
    if len(t.lstrip("+-").lstrip("0")) > 30:
        return -math.inf if t.startswith("-") else math.inf
    return int(t)


def _real(text: str):
    """The number `text` writes (an infinity beyond the float range, NaN as NaN), else None."""
    try:
        return float(text)
    except (ValueError, OverflowError):
        return None


#: Largest ``--runs`` of a Monte Carlo page: its per-run results take memory
#: (``montecarlo.RUN_BYTES``, 0.63 kB a run: 0.63 GB for the million).
MAX_RUNS = 1_000_000

#: Largest ``curves --times`` [s]. Measured cost of the curves section
#: per second of the last evaluation time (T = 100 s and 400 s on a 2-core
#: machine): 17 ms and 1.4 MB of peak memory over a 0.22 GB base; 1000 s need
#: about 20 s and 1.6 GB.
MAX_CURVE_TIME = 1000.0
CURVE_SECONDS, CURVE_BYTES, CURVE_BASE_BYTES = 17e-3, 1.4e6, 0.22e9

#: Largest ``assess --times`` [s]. The closed forms cost nothing to evaluate, but they are
#: small-angle expansions of the INS error, meaningful for seconds to minutes (the paper's
#: figure shows 15 s); an hour is far beyond that and keeps every value finite and plottable.
MAX_ASSESS_TIME = 3600.0

#: Longest ``montecarlo`` run [s] (``--duration-s``, or the time ``--speed-mps`` alone gives the
#: 6.3 m path): the memory of the study grows with the samples of a run.
MAX_MC_SECONDS = 600.0

#: Time budget of ``morpi montecarlo`` [s]: a longer estimate is refused unless ``--allow-long``;
#: an estimate of more than :data:`MC_ANNOUNCE_SECONDS` is printed when the command starts.
MC_BUDGET_SECONDS = 2 * 3600.0
MC_ANNOUNCE_SECONDS = 60.0
#: Memory bound of ``morpi montecarlo`` [bytes], not lifted by ``--allow-long``: twice the most its
#: options take with the default chunk (1,000,000 runs of 600 s at 10 m/s, about 2 GB); only a large
#: ``--chunk`` goes beyond it.
MC_MEMORY_BYTES = 4e9

#: Largest seed (``--seed``): the seeds of numpy's generators drawn from a Generator are below 2^63.
MAX_SEED = 2**63 - 1

#: Largest ``simulate --runs-per-folder``: four times the field dataset's largest folder (24 runs);
#: 1100 recordings, about 2 min and 0.4 GB of CSV on a 2-core machine (110 took 13 s and 37 MB).
MAX_RUNS_PER_FOLDER = 100

#: Slowest ``montecarlo --speed-mps`` and fastest [m/s]: the paper's robot cruises at about 0.45 m/s.
MC_SPEED_RANGE = (0.01, 10.0)

#: Shortest ``montecarlo --duration-s`` [s]: the path's two 1 s speed ramps.
MIN_MC_SECONDS = 2.0


def _duration(seconds):
    from .parallel import format_duration

    return format_duration(seconds)


#: Most threads a command takes (``--workers``): far above the cores of a workstation, and a bound on
#: the threads an absurd value would start.
MAX_WORKERS = 256


def _workers_arg(sp):
    sp.add_argument("--workers", metavar="N", type=_Number(True, 1, MAX_WORKERS, "threads"), default=None,
                    help="threads that run the aided filter (default: the cores this process may use; "
                         "the results do not depend on it)")


def _runs_estimate(v, shown):
    from .montecarlo import page_cost

    cost = page_cost(int(min(v, 2**62)))
    return (f"{shown} runs would take about {_duration(cost.seconds)} and {cost.bytes / 1e9:.1f} GB of memory "
            f"(the default 15 s path)")


def _runs():
    return _Number(True, 1, MAX_RUNS, "runs", above=_runs_estimate)


def _curve_estimate(v, shown):
    gb = (CURVE_BASE_BYTES + v * CURVE_BYTES) / 1e9
    return (f"{shown} s would take about {_duration(v * CURVE_SECONDS)} and {gb:.3g} GB of memory "
            f"({CURVE_BYTES / 1e6:g} MB per second of the last time)")


def _seed():
    return _Number(True, 0, MAX_SEED)


def _path(option):
    def parse(text):
        if text == "":
            raise argparse.ArgumentTypeError(f"{option}: empty path")
        return Path(text)
    return parse


class _Parser(argparse.ArgumentParser):
    """``morpi``'s parsers: an error is one line, and ``-1e308``, ``-inf`` or ``-nan`` is a value.

    argparse takes an argument that starts with ``-`` for an option unless it
    reads as a plain negative number (``-1``, ``-.5``), so a negative value in
    exponent notation, or a negative infinity, would not reach the option's
    check; here it does, and is refused there with the option's range.
    """

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = re.compile(r"^-(\d|\.\d|inf|nan)", re.IGNORECASE)

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {' '.join(message.split())} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``morpi`` (exposed for tests and docs).

    One subcommand per section (``tables``, ``aided``, ``assess``,
    ``curves``, ``montecarlo``, ``drift``) plus ``check``, ``simulate``,
    ``data fetch`` and ``report``; each option's type checks its value and
    its limit (run counts, times, durations, speeds) while parsing.

    Returns
    -------
    argparse.ArgumentParser
        A new parser; a subcommand is required.

    Examples
    --------
    >>> args = build_parser().parse_args(["montecarlo", "--runs", "100", "--speed-mps", "0.5"])
    >>> args.command, args.runs, args.seed, args.speed_mps, args.duration_s, args.out.as_posix()
    ('montecarlo', 100, 0, 0.5, None, 'reports/montecarlo')
    """
    p = _Parser(
        prog="morpi",
        description="MoRPI error models side by side: symbolic closed form, error-state filter, "
                    "Monte Carlo simulation and the field recordings.")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    def data_arg(sp):
        sp.add_argument("--data", metavar="DIR",
                        help="field dataset root (MoRPI layout); default: $MORPI_DATA")

    def partial_arg(sp):
        sp.add_argument("--partial", action="store_true",
                        help="go on without bad or missing recordings (the page lists them); "
                             "default: stop with exit status 1 naming them")

    def out_args(sp, section):
        sp.add_argument("--out", metavar="DIR", type=_path("--out"), default=Path("reports") / section,
                        help=f"output folder (default: reports/{section}); replaced only if new, empty or "
                             "this section's earlier output, holding nothing morpi did not write")
        sp.add_argument("--json", metavar="FILE", type=_path("--json"),
                        help="also write the JSON result here (an existing file only if morpi wrote it)")
        sp.add_argument("--force", action="store_true", help="let --json overwrite a file morpi did not write")

    s = sub.add_parser("check", help="validate every recording of the MoRPI dataset at --data DIR (through the "
                                     "manifest the package ships), or of a dataset manifest")
    data_arg(s)
    s.add_argument("--dataset", metavar="FILE", type=_path("--dataset"),
                   help="a dataset manifest (TOML, docs/manifest.md): load and check every recording it describes")

    s = sub.add_parser("evaluate", help="the methods on every recording of a dataset manifest, against its truth")
    which = s.add_mutually_exclusive_group(required=True)
    which.add_argument("--dataset", metavar="FILE", type=_path("--dataset"),
                       help="a dataset manifest (TOML, docs/manifest.md)")
    which.add_argument("--data", metavar="DIR",
                       help="the MoRPI field dataset at DIR, read through the manifest the package ships "
                            "(morpi_filters/data/morpi.toml)")
    s.add_argument("--out", metavar="DIR", type=_path("--out"), default=None,
                   help="write README.md, result.json and every estimated path (tracks/<id>/<method>_<calibration>"
                        ".csv) here; replaced only if new, empty or an earlier evaluation")
    s.add_argument("--json", metavar="FILE", type=_path("--json"),
                   help="also write the JSON result here (an existing file only if morpi wrote it)")
    s.add_argument("--force", action="store_true", help="let --json overwrite a file morpi did not write")
    s.add_argument("--workers", metavar="N", type=_Number(True, 1, MAX_WORKERS, "threads"), default=None,
                   help="threads that evaluate the recordings and tune the aided filter, and with 2 or more "
                        "a second process that writes track files (default: the cores the process may use; "
                        "the results do not depend on it)")

    s = sub.add_parser("tables", help="every table of the paper on the recordings, ours beside the paper's")
    data_arg(s)
    partial_arg(s)
    out_args(s, "tables")

    s = sub.add_parser("aided", help="the MoRPI-aided filter on every MoRPI cell: forward, smoothed, ablation, "
                                     "consistency")
    data_arg(s)
    _workers_arg(s)
    out_args(s, "aided")

    s = sub.add_parser("assess", help="analytical assessment: closed-form 3D/2D INS vs MoRPI-A error")
    s.add_argument("--params", metavar="FILE", type=Path,
                   help="parameter file (JSON); default: data/assessment_params.json")
    s.add_argument("--times", metavar="T", type=_Number(False, 0.0, MAX_ASSESS_TIME, "s"), nargs="+",
                   help=f"evaluation times [s], at most {MAX_ASSESS_TIME:g}")
    out_args(s, "assessment")

    s = sub.add_parser("curves", help="closed form, filter sigma, Monte Carlo and field errors on one axis")
    s.add_argument("--params", metavar="FILE", type=Path, help="parameter file (JSON, values read as 1 sigma)")
    s.add_argument("--times", metavar="T", type=_Number(False, 0.0, MAX_CURVE_TIME, "s", above=_curve_estimate),
                   nargs="+",
                   help=f"evaluation times [s], at most {MAX_CURVE_TIME:g}")
    s.add_argument("--seed", type=_seed(), default=None,
                   help="seed of the Monte Carlo draws (default morpi_filters.curves.MC_SEED)")
    data_arg(s)
    partial_arg(s)
    out_args(s, "curves")

    s = sub.add_parser("simulate", help="write a synthetic dataset in the field dataset's layout and format")
    s.add_argument("--out", metavar="DIR", type=_path("--out"), required=True,
                   help="destination folder (new, empty, or an earlier synthetic dataset)")
    s.add_argument("--seed", type=_seed(), default=0, help="random seed (default 0)")
    s.add_argument("--runs-per-folder", metavar="N", type=_Number(True, 1, MAX_RUNS_PER_FOLDER, "runs"),
                   help=f"runs in every folder (default: as many as the field dataset; at most "
                        f"{MAX_RUNS_PER_FOLDER})")
    s.add_argument("--layout", metavar="NAME",
                   help="write instead a small simulated dataset in another robot's layout, with its manifest "
                        "(dataset.toml): a name of morpi_filters.foreign.LAYOUTS, such as robot (npy at 120 Hz, "
                        "FRD axes, g and deg/s, a NED truth track)")

    s = sub.add_parser("montecarlo", help="Monte Carlo gain-error study")
    s.add_argument("--runs", metavar="N", type=_runs(), default=2000,
                   help=f"Monte Carlo runs (default 2000, at most {MAX_RUNS})")
    s.add_argument("--seed", type=_seed(), default=0)
    s.add_argument("--chunk", metavar="K", type=_Number(True, 1, MAX_RUNS, "runs"), default=None,
                   help="runs per batch (results do not depend on it)")
    s.add_argument("--scheduler", metavar="ADDRESS", help="run on a Dask cluster at this address")
    duration = _Number(False, MIN_MC_SECONDS, MAX_MC_SECONDS, "s")
    s.add_argument("--duration-s", metavar="S", type=duration, default=None,
                   help=f"time of the sine path from start to stop [s] (default 15 s for 6.3 m; at most "
                        f"{MAX_MC_SECONDS:g} s)")
    s.add_argument("--duration", dest="duration_s", type=duration, help=argparse.SUPPRESS)   # name before 0.2
    s.add_argument("--speed-mps", metavar="V", type=_Number(False, *MC_SPEED_RANGE, "m/s"), default=None,
                   help="cruise speed [m/s] (default the paper's for 1 m periods)")
    s.add_argument("--speed", dest="speed_mps", type=_Number(False, *MC_SPEED_RANGE, "m/s"),
                   help=argparse.SUPPRESS)                                                   # name before 0.2
    s.add_argument("--allow-long", action="store_true",
                   help=f"run even when the estimated time is over {_duration(MC_BUDGET_SECONDS)} (the estimate "
                        f"is printed when it is over {_duration(MC_ANNOUNCE_SECONDS)})")
    data_arg(s)
    partial_arg(s)
    out_args(s, "montecarlo")

    s = sub.add_parser("drift", help="closed-form vs nonlinear strapdown drift")
    s.add_argument("--seed", type=_seed(), default=None,
                   help="seed of the bias draws (default morpi_filters.montecarlo.DRIFT_SEED)")
    s.add_argument("--scheduler", metavar="ADDRESS", help="run on a Dask cluster at this address")
    out_args(s, "drift")

    s = sub.add_parser("data", help="the field dataset: fetch and verify")
    dsub = s.add_subparsers(dest="data_command", metavar="ACTION")
    dsub.required = True
    f = dsub.add_parser("fetch", help="download the public dataset archive and verify every file")
    f.add_argument("--out", metavar="DIR", type=_path("--out"), default=Path("morpi-data"),
                   help="destination folder (default: ./morpi-data)")
    f.add_argument("--dest", dest="out", type=_path("--dest"), help=argparse.SUPPRESS)       # name before 0.2
    f.add_argument("--url", metavar="URL", help="archive URL (default: the public repository's archive)")

    s = sub.add_parser("report", help="the main job: every section into reports/ (reports/synthetic/ without "
                                      "field data), with index.md")
    data_arg(s)
    partial_arg(s)
    s.add_argument("--out", metavar="DIR", type=_path("--out"), default=None,
                   help="report folder (default: reports/ with field data, reports/synthetic/ without)")
    s.add_argument("--seed", type=_seed(), default=0,
                   help="seed of the synthetic dataset and the Monte Carlo study (default 0; the curves and drift "
                        "sections draw with their commands' default seeds)")
    s.add_argument("--runs", metavar="N", type=_runs(), default=2000,
                   help=f"Monte Carlo runs (default 2000, at most {MAX_RUNS})")
    _workers_arg(s)
    return p


# ----------------------------------------------------------------------------- sections

def _own_seed(name, args, default: int) -> int:
    """The seed of section `name`: its own command's ``--seed`` when given, else `default` (the study's)."""
    seed = getattr(args, "seed", None) if getattr(args, "command", None) == name else None
    return default if seed is None else seed


def _study(name, args, source=None, tables=None):
    """Run the study of one report section and return its frozen result.

    `tables` is the field evaluation of ``source.root`` when ``morpi report``
    has computed it once for every section.
    """
    if name == "tables":
        from .evaluate import tables_study
        return tables_study(source.root if source is not None else None, partial=getattr(args, "partial", False),
                            result=tables)
    if name == "aided":
        from .dataset import missing_data_message
        from .field_aided import aided_study
        if source is None or source.root is None:
            raise MissingDataError(f"aided: no dataset configured; {missing_data_message()}")
        return aided_study(source.root, result=tables, workers=getattr(args, "workers", None))
    if name == "assessment":
        from .assessment import assessment_study
        return assessment_study(params_path=getattr(args, "params", None), times=getattr(args, "times", None))
    if name == "curves":
        from .curves import curves_study
        from .curves import MC_SEED
        return curves_study(params_path=getattr(args, "params", None), times=getattr(args, "times", None),
                            data_source=source, tables=tables, seed=_own_seed(name, args, MC_SEED))
    if name == "montecarlo":
        from .montecarlo import gain_error_page
        return gain_error_page(runs=args.runs, seed=args.seed, chunk=getattr(args, "chunk", None),
                               scheduler=getattr(args, "scheduler", None), data_source=source, tables=tables,
                               duration_s=getattr(args, "duration_s", None), speed_mps=getattr(args, "speed_mps", None))
    if name == "drift":
        from .montecarlo import DRIFT_SEED, drift_page
        return drift_page(seed=_own_seed(name, args, DRIFT_SEED), scheduler=getattr(args, "scheduler", None))
    raise ValueError(name)


def _write(name, out: Path, study, source=None):
    """Write one report section's files from its study into folder `out`; its summary."""
    if name == "tables":
        from .report.tables import report_tables
        return report_tables(out, study, source)
    if name == "aided":
        from .report.aided import report_aided
        return report_aided(out, study, source)
    if name == "assessment":
        from .report.assessment import report_assessment
        return report_assessment(out, study)
    if name == "curves":
        from .report.curves import report_curves
        return report_curves(out, study, source)
    if name == "montecarlo":
        from .report.montecarlo import report_montecarlo
        return report_montecarlo(out, study, source)
    if name == "drift":
        from .report.montecarlo import report_drift
        return report_drift(out, study)
    raise ValueError(name)


def _section(name, out: Path, args, source=None, tables=None):
    """Build one report section into folder `out`: run its study, write its files; its summary.

    The section runs with the heap frozen (:func:`morpi_filters.parallel.heap_frozen`): the collector's
    full collections, which sympy's import and the figures trigger, walk only what the section allocates.
    """
    from .parallel import heap_frozen

    with heap_frozen():
        return _write(name, out, _study(name, args, source, tables), source)


def _field_source(args, required=True):
    from .dataset import resolve_data_root
    from .results import DataSource

    root = resolve_data_root(getattr(args, "data", None), required=required)
    return DataSource(root) if root is not None else None


def _require_recordings(source, args):
    """`source`, after stopping (DataError) when recordings under it are bad or missing, unless --partial."""
    from .field import check_recordings

    if source is None or source.root is None or getattr(args, "partial", False):
        return source
    _stop_on_problems(source.root, check_recordings(source.root)[0])
    return source


def _stop_on_problems(root, problems):
    """Raise DataError naming the first of `problems` (lines of recording problems under `root`), if any."""
    from .errors import DataError

    if problems:
        shown = "; ".join(problems[:5]) + (f"; and {len(problems) - 5} more" if len(problems) > 5 else "")
        raise DataError(f"{root}: {len(problems)} recording problem(s): {shown} "
                        "(run `morpi check` for the full list, or pass --partial to go on without them)")


def _clean_stale(*folders) -> None:
    """Remove what killed runs left in these folders; name on one line what cannot be removed."""
    from .outputs import remove_stale

    failed, seen = [], set()
    for folder in folders:
        key = Path(folder).absolute()
        if key not in seen:
            seen.add(key)
            failed += remove_stale(folder)
    if failed:
        print("morpi: cannot remove leftovers of an interrupted run: " + ", ".join(map(str, failed)),
              file=sys.stderr)


def _run_section(name, args, source_of=None):
    """One report section into ``--out`` (and ``--json``): outputs checked first, swapped in together."""
    from .outputs import Outputs, check_output_dir, check_output_file, stamp_json

    out = check_output_dir(args.out, kind=name)
    if args.json is not None:
        check_output_file(args.json, force=args.force, folder=out)
    _clean_stale(out.parent, *([args.json.parent] if args.json is not None else []))
    source = source_of(args) if source_of is not None else None
    with Outputs(f"morpi {args.command}") as outputs:
        stage = outputs.folder(out, name)
        summary = _section(name, stage, args, source)
        result = stage / "result.json"
        if result.is_file():
            stamp_json(result, f"morpi {args.command}", name)
        if args.json is not None:
            if not result.is_file():
                raise OutputError(f"--json: section {name} wrote no result.json")
            outputs.file(args.json, force=args.force).write_text(result.read_text())
    page = out / summary.page
    print(f"{summary.title}: {page}")
    return 0


def _montecarlo_cost(args):
    """Refuse (ParameterError) a Monte Carlo page estimated beyond the budget, unless --allow-long.

    Checked before anything is computed; an estimate over a minute is printed when the command starts.
    """
    import os

    from .errors import ParameterError
    from .montecarlo import page_cost

    try:
        cost = page_cost(args.runs, duration_s=args.duration_s, speed_mps=args.speed_mps, chunk=args.chunk,
                         field=bool(args.data or os.environ.get("MORPI_DATA")))
    except MorpiError as exc:           # a path the options cannot shape: name them
        given = ", ".join(f"--{k} {v:g}" for k, v in (("duration-s", args.duration_s), ("speed-mps", args.speed_mps))
                          if v is not None)
        raise ParameterError(f"{given or 'the default path'}: {exc}") from None
    if args.duration_s is None and cost.duration_s > MAX_MC_SECONDS:
        raise ParameterError(f"--speed-mps: {args.speed_mps:g} m/s makes the 6.3 m path last {cost.duration_s:.0f} s; "
                             f"at most {MAX_MC_SECONDS:g} s (give a --duration-s too, or a higher --speed-mps)")
    gb = cost.bytes / 1e9
    what = (f"{cost.runs} runs of {cost.duration_s:g} s, estimated at about {_duration(cost.seconds)} and "
            f"{gb:.3g} GB of memory (as measured on one core of a 2-core machine: montecarlo.page_cost)")
    if cost.bytes > MC_MEMORY_BYTES:
        raise ParameterError(f"montecarlo: {what}; at most {MC_MEMORY_BYTES / 1e9:g} GB: a smaller --chunk or "
                             "fewer --runs")
    if cost.seconds > MC_BUDGET_SECONDS and not args.allow_long:
        raise ParameterError(f"montecarlo: {what}; over the budget of {_duration(MC_BUDGET_SECONDS)}: pass "
                             "--allow-long to run it anyway, or ask for fewer --runs or a shorter --duration-s")
    if cost.seconds > MC_ANNOUNCE_SECONDS:
        print(f"morpi montecarlo: {what}", flush=True)


def _cmd_check(args):
    from .dataset import resolve_data_root
    from .field import check_recordings

    if args.dataset is not None:
        return _check_manifest(args)
    root = resolve_data_root(args.data)
    problems, n_ok, no_rest = check_recordings(root)
    for line in problems:
        print(line)
    for line in no_rest:                        # evaluated under RD only: a warning, not a problem
        print(f"warning: {line}; evaluated under RD only, without GC and GAC")
    print(f"{n_ok} recording(s) OK, {len(problems)} problem(s) under {root}"
          + (f"; {len(no_rest)} OK recording(s) without an initial rest (RD only)" if no_rest else ""))
    return 1 if problems else 0


def _check_manifest(args):
    """``morpi check --dataset FILE``: one line per problem; exit 2 for a manifest problem, 1 for bad data."""
    from .errors import ParameterError
    from .manifest import check_dataset

    if args.data is not None:
        raise ParameterError("--data and --dataset: give one (a dataset folder in the MoRPI layout, or a manifest)")
    problems, n_ok = check_dataset(args.dataset)
    for exc in problems:
        print(exc)
    print(f"{n_ok} recording(s) OK, {len(problems)} problem(s) in {args.dataset}")
    return max((exc.exit_code for exc in problems), default=0)


def _cmd_evaluate(args):
    """``morpi evaluate --dataset FILE`` (or ``--data DIR``: the shipped MoRPI manifest applied to DIR): outputs
    checked, the manifest loaded, the study run, its page written."""
    from .dataset_eval import evaluate
    from .manifest import load_dataset
    from .parallel import Progress
    from .report.dataset_eval import report_dataset_evaluation
    from .outputs import Outputs, check_output_dir, check_output_file, stamp_json, write_json

    out = check_output_dir(args.out, kind="evaluate") if args.out is not None else None
    if args.json is not None:
        check_output_file(args.json, force=args.force, folder=out)
    _clean_stale(*([out.parent] if out is not None else []), *([args.json.parent] if args.json is not None else []))
    if args.dataset is not None:
        dataset = load_dataset(args.dataset)
    else:
        from .dataset import resolve_data_root
        from .resources import morpi_manifest

        dataset = load_dataset(morpi_manifest(), root=resolve_data_root(args.data))
    progress = Progress(len(dataset), "evaluate", enabled=True)
    result = evaluate(dataset, workers=args.workers, progress=progress)
    with Outputs("morpi evaluate") as outputs:
        if out is not None:
            stage = outputs.folder(out, "evaluate")
            report_dataset_evaluation(stage, result, workers=args.workers)
            stamp_json(stage / "result.json", "morpi evaluate", "evaluate")
            text = (stage / "result.json").read_text()
        if args.json is not None:
            target = outputs.file(args.json, force=args.force)
            if out is not None:
                target.write_text(text)
            else:
                write_json(target, result.to_json())
                stamp_json(target, "morpi evaluate", "evaluate")
    tested = {p.group for p in result.paths if p.split == "test"}
    for g in result.groups:
        end = g["end_error_percent"]
        over = ("recording(s); no test split" if result.groups_over != "test" else "test recording(s)"
                if g["group"] in tested else "recording(s) outside the train split")
        print(f"{g['group']}: {g['method']} {g['calibration']}: end error "
              f"{'-' if end is None else f'{end:.3g}'} % (mean over {g['n']} {over})")
    for x in result.left_out:
        print(f"left out: {x['id']}: {x['what']}: {x['why']}")
    if out is not None:
        print(f"Evaluation of {result.name}: {out / 'README.md'}")
    return 0


def _cmd_simulate(args):
    from .synthetic import write_dataset

    if args.layout is not None:
        from .errors import ParameterError
        from .foreign import LAYOUTS, write_foreign_dataset

        if args.layout not in LAYOUTS:
            raise ParameterError(f"--layout: {args.layout!r} is not a layout, expected one of "
                                 f"{', '.join(sorted(LAYOUTS))}")
        if args.runs_per_folder is not None:
            raise ParameterError("--runs-per-folder: not used with --layout (its runs are fixed by the layout)")
        _clean_stale(args.out.parent)
        written = write_foreign_dataset(args.out, LAYOUTS[args.layout], seed=args.seed)
        print(f"simulated dataset ({args.layout}): {written.manifest}")
        return 0
    _clean_stale(args.out.parent)
    root = write_dataset(args.out, seed=args.seed, runs_per_folder=args.runs_per_folder)
    print(f"synthetic dataset: {root}")
    return 0


def _cmd_data(args):
    from .fetch import fetch_dataset

    _clean_stale(Path(args.out).expanduser().parent)
    root = fetch_dataset(args.out, url=args.url)
    print(f"field dataset verified at {root}; use --data {root} or set MORPI_DATA={root}")
    return 0


#: Where ``morpi report`` writes without ``--out``: field data and synthetic data apart,
#: so a run on synthetic data never replaces a field report.
REPORT_DIR, SYNTHETIC_REPORT_DIR = Path("reports"), Path("reports") / "synthetic"
CACHE_DIR = Path(".morpi-cache")


def _report_source(args):
    """The field dataset if configured, else the seeded synthetic one."""
    from .results import DataSource

    src = _field_source(args, required=False)
    if src is not None:
        return src
    from .synthetic import ensure_synthetic_dataset

    root = ensure_synthetic_dataset(CACHE_DIR / f"synthetic-seed{args.seed}", seed=args.seed)
    return DataSource(root, synthetic=True, seed=args.seed)


def _cmd_report(args):
    from .dataset import resolve_data_root
    from .outputs import Outputs, check_output_dir, stamp_json

    field_root = resolve_data_root(args.data, required=False)
    out = args.out if args.out is not None else (REPORT_DIR if field_root is not None else SYNTHETIC_REPORT_DIR)
    check_output_dir(out, kind="report", replace=False, writes=("index.md",))
    for name in REPORT_SECTIONS:
        check_output_dir(out / name, kind=name)
    if field_root is None:
        print(f"morpi report: no field dataset configured (--data DIR or MORPI_DATA), so every section is "
              f"computed on a seeded synthetic dataset (seed {args.seed}) and written to {out}/", flush=True)
    else:
        print(f"morpi report: field dataset {field_root}, report written to {out}/", flush=True)
    _clean_stale(out.parent, out, CACHE_DIR)
    source = _report_source(args)
    tables = None
    if source is not None and source.root is not None:
        # the field evaluation, once for every section that reads the recordings; the recordings are
        # checked from the same loads
        from .evaluate import dataset_problems, evaluate_tables
        from .field import FieldData
        from .parallel import heap_frozen

        with heap_frozen():
            data = FieldData(source.root)
            if not source.synthetic and not getattr(args, "partial", False):
                _stop_on_problems(source.root, dataset_problems(data))
            print("[field evaluation] ...", flush=True)
            tables = evaluate_tables(source.root, data=data)
    summaries = []
    with Outputs("morpi report") as outputs:
        outputs.root(out)
        for name in REPORT_SECTIONS:
            sec_args = argparse.Namespace(**vars(args))
            sec_args.chunk = None
            sec_args.scheduler = None
            stage = outputs.folder(out / name, name)
            print(f"[{name}] ...", flush=True)
            summaries.append(_section(name, stage, sec_args, source, tables))
            if (stage / "result.json").is_file():
                stamp_json(stage / "result.json", "morpi report", name)
        from .report.index import index_page

        outputs.file(out / "index.md").write_text(index_page(summaries, source))
    print(f"report: {out / 'index.md'}")
    return 0


class Terminated(KeyboardInterrupt):
    """Raised in the main thread when the process receives SIGTERM.

    A kind of KeyboardInterrupt, so every cleanup that runs on an interrupt
    (staging folders removed, previous outputs kept) runs on SIGTERM too.
    """


def _on_sigterm(signum, frame):
    raise Terminated()


def _quick_exit() -> None:
    """At the exit of a ``morpi`` process, skip the garbage collector's final sweeps.

    When the interpreter shuts down it runs the cyclic garbage collector over
    every object left (with matplotlib loaded, a few hundred thousand: the
    figures' artists, the modules' objects), only to free memory the process
    is about to give back: about 0.1-0.2 s. An exit handler moves every
    object to the collector's permanent generation (``gc.freeze``), which the
    shutdown sweeps leave alone; the other exit handlers still run, and every
    output is written and closed before. Registered once, and only when
    :func:`main` runs as the process's command (``argv`` None), never for a
    call from Python with its own arguments.
    """
    global _QUICK_EXIT
    if not _QUICK_EXIT:
        import atexit
        import gc

        atexit.register(gc.freeze)
        _QUICK_EXIT = True


_QUICK_EXIT = False


def main(argv=None) -> int:
    """Entry point of the ``morpi`` console script.

    Parses `argv`, runs the subcommand and turns what can go wrong into an
    exit status: a :class:`~morpi_filters.errors.MorpiError` is printed as
    one line ``morpi: error: ...`` on stderr and gives its ``exit_code``
    (1 bad data, 2 bad parameters); SIGINT gives 130 and SIGTERM 143 (caught
    while `main` runs in the main thread), with previous outputs left in
    place. Bad command-line syntax exits through argparse (status 2).

    Parameters
    ----------
    argv : list of str, optional
        The arguments after ``morpi``; ``sys.argv[1:]`` when None.

    Returns
    -------
    int
        The exit status: 0 on success.

    Examples
    --------
    ``morpi check`` on a synthetic dataset folder whose manifest lists one
    recording, which is present and valid:

    >>> import json, pathlib, tempfile
    >>> import numpy as np
    >>> from morpi_filters.dataset import Recording, write_csv
    >>> root = pathlib.Path(tempfile.mkdtemp())
    >>> manifest = {"generator": "morpi_filters.simulate", "files": {"s6/L_line/1.csv": ""}}
    >>> _ = (root / "manifest.json").write_text(json.dumps(manifest))
    >>> (root / "s6" / "L_line").mkdir(parents=True)
    >>> t = np.arange(100) * 0.01
    >>> write_csv(root / "s6/L_line/1.csv", Recording(time=t, f=np.tile([0.0, 0.0, 9.8], (100, 1)),
    ...                                                omega=np.zeros((100, 3))))
    >>> main(["check", "--data", str(root)])
    1 recording(s) OK, 0 problem(s) under ...
    0
    >>> main(["check", "--data", str(root / "missing")])     # one line on stderr, status of a MorpiError
    2
    """
    if argv is None:
        _quick_exit()
    parser = build_parser()
    args = parser.parse_args(argv)
    previous = None
    if threading.current_thread() is threading.main_thread():
        previous = signal.signal(signal.SIGTERM, _on_sigterm)
    from .dataset import keep_parsed

    try:
        with keep_parsed():                       # a recording checked first is not parsed again
            return _dispatch(args)
    except MorpiError as exc:
        print(f"morpi: error: {exc}", file=sys.stderr)
        return exc.exit_code
    except Terminated:
        print("morpi: terminated (SIGTERM); previous outputs left in place", file=sys.stderr)
        return 143
    except KeyboardInterrupt:
        print("morpi: interrupted; previous outputs left in place", file=sys.stderr)
        return 130
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def _dispatch(args) -> int:
    if args.command == "check":
        return _cmd_check(args)
    if args.command == "simulate":
        return _cmd_simulate(args)
    if args.command == "evaluate":
        return _cmd_evaluate(args)
    if args.command == "data":
        return _cmd_data(args)
    if args.command == "report":
        return _cmd_report(args)
    if args.command == "tables":
        return _run_section("tables", args, _field_source)
    if args.command == "aided":
        return _run_section("aided", args, lambda a: _require_recordings(_field_source(a), a))
    if args.command == "montecarlo":
        _montecarlo_cost(args)
    if args.command in ("curves", "montecarlo"):
        return _run_section(args.command, args, lambda a: _require_recordings(_field_source(a, required=False), a))
    section = {"assess": "assessment", "drift": "drift"}[args.command]
    return _run_section(section, args)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
