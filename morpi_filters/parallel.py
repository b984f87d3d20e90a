"""Running a study's chunks: locally on threads or on a Dask cluster, with a progress line.

A study splits its runs into ranges ``(a, b)`` (:func:`chunk_ranges`) and a
pure function ``fn(payload, a, b)`` computes one range;
:func:`execute` returns the results in range order whatever the engine, so
a seeded study gives the same numbers on one thread, many threads or a
cluster.
"""
from __future__ import annotations

import contextlib
import gc
import sys
import time as _time

from .errors import ParameterError

__all__ = ["Progress", "available_cores", "chunk_ranges", "execute", "format_duration", "heap_frozen"]


def format_duration(seconds: float) -> str:
    """A duration as a person reads it: seconds up to 2 minutes, minutes up to 2 hours, then hours.

    Parameters
    ----------
    seconds : float
        The duration [s], >= 0.

    Returns
    -------
    str
        Rounded to whole seconds or minutes, hours to two significant digits; from
        two days on, the days too, and from a thousand days on, days only.

    Examples
    --------
    >>> format_duration(42.4), format_duration(600), format_duration(7200), format_duration(16.5 * 3600)
    ('42 s', '10 min', '2 h', '16 h')
    >>> format_duration(9 * 86400), format_duration(1e9)
    ('216 h (9.0 days)', '1.2e+04 days')
    """
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.0f} min"
    hours, days = seconds / 3600, seconds / 86400
    if hours < 48:
        return f"{hours:.2g} h"
    return f"{hours:.0f} h ({days:.1f} days)" if days < 1000 else f"{days:.2g} days"


class Progress:
    """A one-line progress indicator on stderr (rewritten in place on a terminal).

    On a terminal the line is rewritten after every update; elsewhere (a log
    file, a pipe) one line is printed each time another tenth of the runs is
    done. Until the end, the line ends with the time left, estimated from the
    rate of the runs finished so far (``about 3 min left``); the last one with
    the time taken (``in 12.3 s``).

    Parameters
    ----------
    total : int
        Number of runs of the whole study.
    label : str
        Text at the start of the line (the study's name).
    enabled : bool
        When False, updates only count and nothing is written.
    clock : callable, optional
        Seconds from a fixed origin, read at the start and at each update
        (default :func:`time.perf_counter`).

    Examples
    --------
    A clock that reads 0 s at the start and 2 s more at each update:

    >>> import contextlib, io, itertools
    >>> err = io.StringIO()
    >>> with contextlib.redirect_stderr(err):
    ...     p = Progress(200, "drift", enabled=True, clock=itertools.count(0.0, 2.0).__next__)
    ...     for _ in range(4):
    ...         p.update(50)
    >>> p.done
    200
    >>> print(err.getvalue(), end="")
    drift: 50/200 runs (25 %), about 6 s left
    drift: 100/200 runs (50 %), about 4 s left
    drift: 150/200 runs (75 %), about 2 s left
    drift: 200/200 runs (100 %) in 8.0 s
    """

    def __init__(self, total: int, label: str, enabled: bool, clock=None):
        self.total, self.label, self.enabled = total, label, enabled
        self.clock = _time.perf_counter if clock is None else clock
        self.done = 0
        self.t0 = self.clock()
        self.tty = enabled and hasattr(sys.stderr, "isatty") and sys.stderr.isatty()
        self.last_tenth = -1
        self.width = 0

    def update(self, k: int) -> None:
        """Count `k` more runs done and refresh the line.

        Parameters
        ----------
        k : int
            Runs finished since the last update.

        Returns
        -------
        None

        Examples
        --------
        >>> p = Progress(10, "gain error", enabled=False)
        >>> p.update(3); p.update(4)
        >>> p.done
        7
        """
        self.done += k
        if not self.enabled:
            return
        frac = self.done / self.total
        if not self.tty:
            tenth = int(10 * frac)
            if tenth <= self.last_tenth:
                return
            self.last_tenth = tenth
        line = f"{self.label}: {self.done}/{self.total} runs ({100 * frac:.0f} %)"
        elapsed = self.clock() - self.t0
        if self.done >= self.total:
            line += f" in {elapsed:.1f} s"
        elif self.done > 0:
            line += f", about {format_duration(elapsed / self.done * (self.total - self.done))} left"
        if self.tty:
            # padded to the width of the longest line so far: a shorter line leaves nothing behind
            self.width = max(self.width, len(line))
            sys.stderr.write(f"\r{line:<{self.width}}" + ("\n" if self.done >= self.total else ""))
            sys.stderr.flush()
        else:
            print(line, file=sys.stderr)


# ----------------------------------------------------------------------------- the collector

_FREEZING = False


@contextlib.contextmanager
def heap_frozen():
    """Run a block with the objects that exist before it in the collector's permanent generation.

    Full collections then walk only what the block allocates, not the
    imported modules (numba, scipy, pandas and matplotlib bring a few hundred
    thousand objects); the frozen objects return to the oldest generation
    afterwards, when the outermost such block ends. A block inside another
    freezes what was allocated since (modules imported on first use, the data
    loaded). A heap someone else froze is left as it is. Cycles among the
    frozen objects wait for their return.

    Yields
    ------
    None
        The block runs with the heap frozen.

    Examples
    --------
    >>> import gc
    >>> with heap_frozen():
    ...     inside = gc.get_freeze_count() > 0
    >>> inside, gc.get_freeze_count()
    (True, 0)
    """
    global _FREEZING
    if _FREEZING:
        gc.freeze()
        yield
        return
    if gc.get_freeze_count():                                   # (the count walks the frozen objects)
        yield
        return
    gc.freeze()
    _FREEZING = True
    try:
        yield
    finally:
        _FREEZING = False
        gc.unfreeze()


# ----------------------------------------------------------------------------- chunk execution

def available_cores() -> int:
    """The number of CPU cores this process may run on (its affinity where the system tells it).

    Returns
    -------
    int
        At least 1.

    Examples
    --------
    >>> available_cores() >= 1
    True
    """
    import os

    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):           # not every system tells a process's affinity
        return max(1, os.cpu_count() or 1)


def chunk_ranges(runs: int, chunk: int):
    """Split `runs` into consecutive ranges of at most `chunk` runs.

    Parameters
    ----------
    runs : int
        Number of runs.
    chunk : int
        Largest number of runs in a range (> 0).

    Returns
    -------
    list of (int, int)
        Half-open ranges ``(a, b)`` covering ``0 .. runs`` in order; the last
        one may be shorter; empty when `runs` is 0.

    Examples
    --------
    >>> chunk_ranges(10, 4)
    [(0, 4), (4, 8), (8, 10)]
    >>> chunk_ranges(0, 4)
    []
    """
    return [(a, min(a + chunk, runs)) for a in range(0, runs, chunk)]


def execute(fn, payload, ranges, *, workers=1, scheduler=None, progress=None, reduce=None):
    """Run ``fn(payload, a, b)`` for every range, in range order.

    With `reduce`, each result is handed to ``reduce(result)`` in range order
    as soon as it and every earlier one are done, and not kept; without it,
    the list of results is returned. `scheduler` is a Dask scheduler address
    (or a ``distributed.Client``); otherwise `workers` threads run the ranges
    locally (at most two ranges per worker in flight).

    Parameters
    ----------
    fn : callable
        ``fn(payload, a, b)`` computes runs ``a .. b-1``; it must be pure (the
        result may not depend on which thread or machine runs it).
    payload : object
        The data every call shares (sent once to each Dask worker).
    ranges : sequence of (int, int)
        The ranges, e.g. from :func:`chunk_ranges`.
    workers : int, optional
        Local threads (default 1: run in the calling thread).
    scheduler : str or distributed.Client, optional
        Run on this Dask cluster instead of local threads.
    progress : Progress, optional
        Updated with ``b - a`` as each range is handed on.
    reduce : callable, optional
        Receives each result in range order instead of keeping it.

    Returns
    -------
    list or None
        The results of `fn` in range order; None when `reduce` is given.

    Raises
    ------
    ParameterError
        When `scheduler` is given and Dask is not installed or the scheduler
        cannot be reached.

    Examples
    --------
    Four threads give the results in range order:

    >>> def total(payload, a, b):
    ...     return sum(payload[a:b])
    >>> execute(total, list(range(10)), chunk_ranges(10, 3), workers=4)
    [3, 12, 21, 9]
    >>> seen = []
    >>> execute(total, list(range(10)), chunk_ranges(10, 3), workers=2, reduce=seen.append), seen
    (None, [3, 12, 21, 9])
    """
    kept = []
    sink = reduce if reduce is not None else kept.append
    if scheduler is not None:
        _execute_dask(fn, payload, ranges, scheduler, progress, sink)
    elif workers is None or workers <= 1 or len(ranges) == 1:
        for a, b in ranges:
            sink(fn(payload, a, b))
            if progress:
                progress.update(b - a)
    else:
        from concurrent.futures import ThreadPoolExecutor

        with ThreadPoolExecutor(max_workers=int(workers)) as pool:
            # at most 2 chunks per worker in flight, so finished chunks do not pile up
            window = 2 * int(workers)
            futs = {}
            for i, (a, b) in enumerate(ranges):
                futs[i] = pool.submit(fn, payload, a, b)
                j = i - window + 1
                if j >= 0:
                    sink(futs.pop(j).result())
                    if progress:
                        progress.update(ranges[j][1] - ranges[j][0])
            for j in sorted(futs):
                sink(futs.pop(j).result())
                if progress:
                    progress.update(ranges[j][1] - ranges[j][0])
    return kept if reduce is None else None


def _execute_dask(fn, payload, ranges, scheduler, progress, sink):
    try:
        from distributed import Client, as_completed
    except ImportError:  # pragma: no cover - depends on the installation
        raise ParameterError("--scheduler: the Dask path needs dask[distributed] "
                             "(pip install 'morpi_filters[dask]')") from None
    own = not isinstance(scheduler, Client)
    try:
        client = Client(scheduler, timeout="10s") if own else scheduler
    except OSError as exc:
        raise ParameterError(f"--scheduler: cannot reach a Dask scheduler at {scheduler!r} ({exc})") from None
    try:
        [remote] = client.scatter([payload], broadcast=True)
        futs = client.map(fn, [remote] * len(ranges), [a for a, _ in ranges], [b for _, b in ranges],
                          pure=False)
        index = {f.key: i for i, f in enumerate(futs)}
        waiting, nxt = {}, 0
        for f in as_completed(futs):
            i = index[f.key]
            waiting[i] = f.result()
            f.release()
            if progress:
                progress.update(ranges[i][1] - ranges[i][0])
            while nxt in waiting:          # hand results on in range order
                sink(waiting.pop(nxt))
                nxt += 1
    finally:
        if own:
            client.close()
