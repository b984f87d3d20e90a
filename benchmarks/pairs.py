"""Paired timing: two pieces of work run in alternation, the ratio taken per pair.

A machine's speed drifts while a benchmark runs (other processes, frequency
scaling, caches). Timing A five times and then B five times lets that drift
land on one side only; running them A B A B ... and dividing each A by the B
next to it cancels most of it. Every benchmark script of the project reports
its ratios through :func:`paired` (work done in this process) or
:func:`paired_commands` (whole commands, as a user runs them), as
min / median / max over the pairs. In process, each call's result is freed
and the garbage collected between the timed windows, so that neither side
pays for releasing the other's work.
"""
from __future__ import annotations

import gc
import os
import subprocess
import sys
import time
from dataclasses import dataclass

import numpy as np

__all__ = ["PairedRatio", "paired", "paired_commands", "paired_reported", "python_command", "run_command",
           "run_reporting", "run_peak"]


@dataclass(frozen=True)
class PairedRatio:
    """Timings of two pieces of work measured in alternation.

    Attributes
    ----------
    name : str
        What is measured, e.g. ``"tables / pandas parse"``.
    a_s, b_s : ndarray, shape (pairs,)
        Seconds of each run of A and of B, in the order they ran.
    target : float or None
        The ratio A / B the project aims at (at most), or None.
    """

    name: str
    a_s: np.ndarray
    b_s: np.ndarray
    target: float | None = None

    @property
    def ratios(self) -> np.ndarray:
        """A / B of each pair."""
        return self.a_s / self.b_s

    @property
    def summary(self) -> tuple[float, float, float]:
        """(min, median, max) of the per-pair ratios."""
        r = self.ratios
        return float(r.min()), float(np.median(r)), float(r.max())

    @property
    def meets_target(self) -> bool | None:
        """Whether the median ratio is at or under the target (None without one)."""
        return None if self.target is None else self.summary[1] <= self.target

    def row(self) -> dict:
        """The comparison as plain data (for ``run_all.py``'s table)."""
        lo, med, hi = self.summary
        return {"name": self.name, "min": lo, "median": med, "max": hi, "pairs": int(len(self.a_s)),
                "a_s": float(np.median(self.a_s)), "b_s": float(np.median(self.b_s)),
                "target": self.target, "met": self.meets_target}

    def line(self) -> str:
        """One printable line: name, ratios, medians of A and B, target."""
        lo, med, hi = self.summary
        tgt = "" if self.target is None else f"  target <= {self.target:g}x: {'met' if self.meets_target else 'NOT met'}"
        return (f"{self.name}: {med:.2f}x (min {lo:.2f}, max {hi:.2f}; {len(self.a_s)} pairs; "
                f"A {np.median(self.a_s):.3f} s, B {np.median(self.b_s):.3f} s){tgt}")


def paired(name, a, b, *, pairs: int = 5, warmup: int = 1, target: float | None = None,
           self_timed: bool = False) -> PairedRatio:
    """Time the callables `a` and `b` in alternation and return their ratios.

    Parameters
    ----------
    name : str
        Label of the comparison.
    a, b : callable
        Zero-argument callables doing the two pieces of work.
    pairs : int
        Counted pairs (at least 5 for a min / median / max that means something).
    warmup : int
        Uncounted pairs run first (imports, caches, page faults).
    target : float, optional
        The ratio A / B aimed at.
    self_timed : bool
        The callables return their own duration in seconds (e.g. measured inside
        a child process), which is used instead of the wall time of the call.
    """
    if pairs < 1 or warmup < 0:
        raise ValueError("pairs must be >= 1 and warmup >= 0")
    ta, tb = [], []
    for k in range(warmup + pairs):
        # alternate which side goes first, so neither always runs on a warm cache
        order = ((a, ta), (b, tb)) if k % 2 == 0 else ((b, tb), (a, ta))
        for fn, acc in order:
            t0 = time.perf_counter()
            out = fn()
            dt = float(out) if self_timed else time.perf_counter() - t0
            # release the result and collect the garbage outside the timed window: otherwise the next
            # call (often the other side's) pays for freeing this one's work
            del out
            gc.collect()
            if k >= warmup:
                acc.append(dt)
    return PairedRatio(name, np.array(ta), np.array(tb), target)


def run_command(argv, *, env=None, cwd=None) -> float:
    """Run a command to completion, output discarded; return its wall time [s].

    Raises
    ------
    RuntimeError
        When the command exits non-zero (a failing command is not a timing).
    """
    t0 = time.perf_counter()
    r = subprocess.run(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env, cwd=cwd)
    dt = time.perf_counter() - t0
    if r.returncode != 0:
        raise RuntimeError(f"{' '.join(map(str, argv))} exited {r.returncode}: {r.stderr.decode()[-500:]}")
    return dt


def paired_commands(name, argv_a, argv_b, *, pairs: int = 5, warmup: int = 1, target: float | None = None,
                    env=None, cwd=None) -> PairedRatio:
    """:func:`paired` for two whole commands (each a list of arguments)."""
    env = dict(os.environ if env is None else env)
    return paired(name, lambda: run_command(argv_a, env=env, cwd=cwd), lambda: run_command(argv_b, env=env, cwd=cwd),
                  pairs=pairs, warmup=warmup, target=target)


def run_reporting(argv, *, env=None, cwd=None) -> float:
    """Run a command that prints its own duration [s] as its last line of output; return it.

    The child measures from its first statement, so the interpreter's start-up,
    common to both sides of a comparison, is left out of both.
    """
    r = subprocess.run(argv, capture_output=True, text=True, env=env, cwd=cwd)
    if r.returncode != 0:
        raise RuntimeError(f"{' '.join(map(str, argv))} exited {r.returncode}: {r.stderr[-500:]}")
    return float(r.stdout.strip().splitlines()[-1])


def paired_reported(name, argv_a, argv_b, *, pairs: int = 5, warmup: int = 1, target: float | None = None,
                    env=None, cwd=None) -> PairedRatio:
    """:func:`paired` for two fresh processes that each print their own duration (:func:`run_reporting`)."""
    env = dict(os.environ if env is None else env)
    return paired(name, lambda: run_reporting(argv_a, env=env, cwd=cwd), lambda: run_reporting(argv_b, env=env, cwd=cwd),
                  pairs=pairs, warmup=warmup, target=target, self_timed=True)


#: A launcher that runs a command and prints its peak resident memory [kB] from ``wait4``, for
#: machines without ``/usr/bin/time``.
_LAUNCHER = ("import os, subprocess, sys; p = subprocess.Popen(sys.argv[1:], stdout=subprocess.DEVNULL); "
             "_, st, ru = os.wait4(p.pid, 0); sys.stderr.write(f'Maximum resident set size (kbytes): {ru.ru_maxrss}\\n'); "
             "sys.exit(os.waitstatus_to_exitcode(st))")


def run_peak(argv, *, env=None, cwd=None) -> tuple[float, float]:
    """Run a command; return its wall time [s] and its peak resident memory [MB].

    The command is started by a small launcher (``/usr/bin/time -v``, else a short
    Python one) that reads the peak from ``wait4``. Started straight from this process,
    the child's ``ru_maxrss`` would include this process's own resident memory (Linux
    keeps the high-water mark across fork and exec), so a large benchmark process
    would inflate the figure.
    """
    launcher = ["/usr/bin/time", "-v"] if os.access("/usr/bin/time", os.X_OK) else [sys.executable, "-c", _LAUNCHER]
    t0 = time.perf_counter()
    r = subprocess.run(launcher + list(map(str, argv)), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env,
                       cwd=cwd)
    dt = time.perf_counter() - t0
    err = r.stderr.decode(errors="replace")
    if r.returncode != 0:
        raise RuntimeError(f"{' '.join(map(str, argv))} exited {r.returncode}: {err[-500:]}")
    kb = [ln.split(":")[-1] for ln in err.splitlines() if "Maximum resident set size (kbytes)" in ln]
    if not kb:
        raise RuntimeError(f"no peak memory reported for {' '.join(map(str, argv))}")
    return dt, int(kb[-1]) / 1024


def python_command(code: str) -> list[str]:
    """The argument list that runs `code` in a fresh interpreter of this Python."""
    return [sys.executable, "-c", code]
