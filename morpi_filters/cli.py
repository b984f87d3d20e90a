"""The ``morpi`` command: thin subcommands over the library.

Each subcommand parses its arguments, calls one library function and writes
into ``reports/`` (or the folder given by ``--out``). A report section is built
in a staging folder and swapped in only when complete. Errors a user can cause
are printed on one line (``morpi: error: ...``) with exit status 2.
"""
from __future__ import annotations

import argparse
import shutil
import sys
from pathlib import Path

from .errors import MorpiError

__all__ = ["main", "build_parser"]

REPORT_SECTIONS = ("tables", "assessment", "curves", "montecarlo", "drift")


def _int_at_least(name, lowest):
    def parse(text):
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name}: {text!r} is not a whole number") from None
        if v < lowest:
            raise argparse.ArgumentTypeError(f"{name}: {v} must be at least {lowest}")
        return v
    return parse


def _positive_int(name):
    return _int_at_least(name, 1)


def _nonneg_int(name):
    return _int_at_least(name, 0)


def _time(text):
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--times: {text!r} is not a number of seconds") from None
    if not (v >= 0 and v < float("inf")):
        raise argparse.ArgumentTypeError(f"--times: {text} must be a finite time >= 0 s")
    return v


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``morpi`` (exposed for tests and docs)."""
    p = argparse.ArgumentParser(
        prog="morpi",
        description="MoRPI error models side by side: symbolic closed form, error-state filter, "
                    "Monte Carlo simulation and the field recordings.")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    def data_arg(sp):
        sp.add_argument("--data", metavar="DIR",
                        help="field dataset root (MoRPI layout); default: $MORPI_DATA")

    def out_args(sp, section):
        sp.add_argument("--out", metavar="DIR", type=Path, default=Path("reports") / section,
                        help=f"output folder (default: reports/{section})")
        sp.add_argument("--json", metavar="FILE", type=Path, help="also write the JSON result here")

    s = sub.add_parser("check", help="validate every recording under a dataset folder")
    data_arg(s)

    s = sub.add_parser("tables", help="every table of the paper on the recordings, ours beside the paper's")
    data_arg(s)
    out_args(s, "tables")

    s = sub.add_parser("assess", help="analytical assessment: closed-form 3D/2D INS vs MoRPI-A error")
    s.add_argument("--params", metavar="FILE", type=Path,
                   help="parameter file (JSON); default: data/assessment_params.json")
    s.add_argument("--times", metavar="T", type=_time, nargs="+", help="evaluation times [s]")
    out_args(s, "assessment")

    s = sub.add_parser("curves", help="closed form, filter sigma, Monte Carlo and field errors on one axis")
    s.add_argument("--params", metavar="FILE", type=Path, help="parameter file (JSON, values read as 1 sigma)")
    s.add_argument("--times", metavar="T", type=_time, nargs="+", help="evaluation times [s]")
    data_arg(s)
    out_args(s, "curves")

    s = sub.add_parser("simulate", help="write a synthetic dataset in the field dataset's layout and format")
    s.add_argument("--out", metavar="DIR", type=Path, required=True, help="destination folder")
    s.add_argument("--seed", type=_nonneg_int("--seed"), default=0, help="random seed (default 0)")
    s.add_argument("--runs-per-folder", metavar="N", type=_positive_int("--runs-per-folder"),
                   help="runs in every folder (default: as many as the field dataset)")

    s = sub.add_parser("montecarlo", help="Monte Carlo gain-error study")
    s.add_argument("--runs", metavar="N", type=_positive_int("--runs"), default=2000)
    s.add_argument("--seed", type=_nonneg_int("--seed"), default=0)
    s.add_argument("--chunk", metavar="K", type=_positive_int("--chunk"), default=None,
                   help="runs per batch (results do not depend on it)")
    s.add_argument("--scheduler", metavar="ADDRESS", help="run on a Dask cluster at this address")
    data_arg(s)
    out_args(s, "montecarlo")

    s = sub.add_parser("drift", help="closed-form vs nonlinear strapdown drift")
    s.add_argument("--scheduler", metavar="ADDRESS", help="run on a Dask cluster at this address")
    out_args(s, "drift")

    s = sub.add_parser("data", help="the field dataset: fetch and verify")
    dsub = s.add_subparsers(dest="data_command", metavar="ACTION")
    dsub.required = True
    f = dsub.add_parser("fetch", help="download the public dataset archive and verify every file")
    f.add_argument("--dest", metavar="DIR", type=Path, default=Path("morpi-data"),
                   help="destination folder (default: ./morpi-data)")
    f.add_argument("--url", metavar="URL", help="archive URL (default: the public repository's archive)")

    s = sub.add_parser("report", help="the main job: every section into reports/, with index.md")
    data_arg(s)
    s.add_argument("--out", metavar="DIR", type=Path, default=Path("reports"), help="report folder")
    s.add_argument("--seed", type=_nonneg_int("--seed"), default=0, help="seed of the synthetic dataset and studies")
    s.add_argument("--runs", metavar="N", type=_positive_int("--runs"), default=2000,
                   help="Monte Carlo runs (default 2000)")
    return p


# ----------------------------------------------------------------------------- sections

def _section(name, out: Path, args, source=None):
    """Build one report section into folder `out` and return its summary."""
    if name == "tables":
        from .evaluate import report_tables
        return report_tables(out, source)
    if name == "assessment":
        from .assessment import report_assessment
        return report_assessment(out, params_path=getattr(args, "params", None), times=getattr(args, "times", None))
    if name == "curves":
        from .curves import report_curves
        return report_curves(out, params_path=getattr(args, "params", None), times=getattr(args, "times", None),
                             source=source)
    if name == "montecarlo":
        from .montecarlo import report_montecarlo
        return report_montecarlo(out, runs=args.runs, seed=args.seed, chunk=getattr(args, "chunk", None),
                                 scheduler=getattr(args, "scheduler", None), source=source)
    if name == "drift":
        from .montecarlo import report_drift
        return report_drift(out, scheduler=getattr(args, "scheduler", None))
    raise ValueError(name)


def _field_source(args, required=True):
    from .dataset import resolve_data_root
    from .reporting import DataSource

    root = resolve_data_root(getattr(args, "data", None), required=required)
    return DataSource(root) if root is not None else None


def _run_section(name, args, source=None):
    from .reporting import staged_dir, write_text

    with staged_dir(args.out) as stage:
        summary = _section(name, stage, args, source)
    if args.json is not None:
        result = Path(args.out) / "result.json"
        if not result.is_file():
            raise MorpiError(f"--json: section {name} wrote no result.json")
        write_text(args.json, result.read_text())
    page = Path(args.out) / summary.page
    print(f"{summary.title}: {page}")
    return 0


def _cmd_check(args):
    from .dataset import check_tree, resolve_data_root

    root = resolve_data_root(args.data)
    problems, n_ok = check_tree(root)
    for line in problems:
        print(line)
    print(f"{n_ok} recording(s) OK, {len(problems)} problem(s) under {root}")
    return 1 if problems else 0


def _cmd_simulate(args):
    from .synthetic import write_dataset

    root = write_dataset(args.out, seed=args.seed, runs_per_folder=args.runs_per_folder)
    print(f"synthetic dataset: {root}")
    return 0


def _cmd_data(args):
    from .fetch import fetch_dataset

    root = fetch_dataset(args.dest, url=args.url)
    print(f"field dataset verified at {root}; use --data {root} or set MORPI_DATA={root}")
    return 0


def _report_source(args):
    """The field dataset if configured, else the seeded synthetic one."""
    from .reporting import DataSource

    src = _field_source(args, required=False)
    if src is not None:
        return src
    from .synthetic import ensure_synthetic_dataset

    root = ensure_synthetic_dataset(Path(".morpi-cache") / f"synthetic-seed{args.seed}", seed=args.seed)
    return DataSource(root, synthetic=True, seed=args.seed)


def _cmd_report(args):
    from .reporting import staged_dir, write_text

    source = _report_source(args)
    summaries = []
    with staged_dir(args.out) as stage:
        for name in REPORT_SECTIONS:
            sec_args = argparse.Namespace(**vars(args))
            sec_args.chunk = None
            sec_args.scheduler = None
            print(f"[{name}] ...", flush=True)
            summaries.append(_section(name, stage / name, sec_args, source))
        write_text(stage / "index.md", _index(summaries, source))
        _keep_other_outputs(Path(args.out), stage)
    print(f"report: {Path(args.out) / 'index.md'}")
    return 0


def _keep_other_outputs(old: Path, stage: Path) -> None:
    """Carry over what the report does not write (e.g. analysis/ figures) into the new report."""
    if not old.is_dir():
        return
    for entry in old.iterdir():
        dest = stage / entry.name
        if dest.exists() or entry.name.startswith("."):
            continue
        if entry.is_dir():
            shutil.copytree(entry, dest)
        else:
            shutil.copy2(entry, dest)


def _index(summaries, source) -> str:
    lines = ["# morpi_filters report", ""]
    if source is not None and source.synthetic:
        from .reporting import SYNTHETIC_BANNER
        lines += [SYNTHETIC_BANNER, ""]
    elif source is not None:
        lines += [f"Field dataset: `{source.root}`.", ""]
    for s in summaries:
        lines += [f"## [{s.title}]({s.name}/{s.page})", ""]
        if s.synthetic:
            lines += ["*Computed on synthetic data.*", ""]
        if s.summary:
            lines += [s.summary.strip(), ""]
        for fig in s.figures:
            lines += [f"![{s.title}: {fig}]({s.name}/{fig})", ""]
    return "\n".join(lines)


def main(argv=None) -> int:
    """Entry point of the ``morpi`` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        if args.command == "check":
            return _cmd_check(args)
        if args.command == "simulate":
            return _cmd_simulate(args)
        if args.command == "data":
            return _cmd_data(args)
        if args.command == "report":
            return _cmd_report(args)
        if args.command == "tables":
            return _run_section("tables", args, _field_source(args))
        if args.command == "curves":
            return _run_section("curves", args, _field_source(args, required=False))
        if args.command == "montecarlo":
            return _run_section("montecarlo", args, _field_source(args, required=False))
        section = {"assess": "assessment", "drift": "drift"}[args.command]
        return _run_section(section, args)
    except MorpiError as exc:
        print(f"morpi: error: {exc}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        print("morpi: interrupted; previous outputs left in place", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
