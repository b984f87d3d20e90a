"""Running a study's chunks: locally on threads or on a Dask cluster, with a progress line.

A study splits its runs into ranges ``(a, b)`` (:func:`chunk_ranges`) and a
pure function ``fn(payload, a, b)`` computes one range;
:func:`execute` returns the results in range order whatever the engine, so
a seeded study gives the same numbers on one thread, many threads or a
cluster.
"""
from __future__ import annotations

import sys
import time as _time

from .errors import MorpiError

__all__ = ["Progress", "chunk_ranges", "execute"]


class Progress:
    """A one-line progress indicator on stderr (rewritten in place on a terminal)."""

    def __init__(self, total: int, label: str, enabled: bool):
        self.total, self.label, self.enabled = total, label, enabled
        self.done = 0
        self.t0 = _time.perf_counter()
        self.tty = enabled and hasattr(sys.stderr, "isatty") and sys.stderr.isatty()
        self.last_tenth = -1

    def update(self, k: int) -> None:
        self.done += k
        if not self.enabled:
            return
        frac = self.done / self.total
        if self.tty:
            sys.stderr.write(f"\r{self.label}: {self.done}/{self.total} runs ({100 * frac:3.0f} %)")
            if self.done >= self.total:
                sys.stderr.write(f" in {_time.perf_counter() - self.t0:.1f} s\n")
            sys.stderr.flush()
        else:
            tenth = int(10 * frac)
            if tenth > self.last_tenth:
                self.last_tenth = tenth
                print(f"{self.label}: {self.done}/{self.total} runs ({100 * frac:.0f} %)", file=sys.stderr)


# ----------------------------------------------------------------------------- chunk execution

def chunk_ranges(runs: int, chunk: int):
    return [(a, min(a + chunk, runs)) for a in range(0, runs, chunk)]


def execute(fn, payload, ranges, *, workers=1, scheduler=None, progress=None, reduce=None):
    """Run ``fn(payload, a, b)`` for every range, in range order.

    With `reduce`, each result is handed to ``reduce(result)`` in range order
    as soon as it and every earlier one are done, and not kept (None is
    returned); without it, the list of results is returned. `scheduler` is a
    Dask scheduler address (or a ``distributed.Client``); otherwise `workers`
    threads run the ranges locally.
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
        raise MorpiError("--scheduler: the Dask path needs dask[distributed] "
                         "(pip install 'morpi_filters[dask]')") from None
    own = not isinstance(scheduler, Client)
    try:
        client = Client(scheduler, timeout="10s") if own else scheduler
    except OSError as exc:
        raise MorpiError(f"--scheduler: cannot reach a Dask scheduler at {scheduler!r} ({exc})") from None
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
