"""The analysis process behind ``POST /analyze``: one worker, one upload at a time.

A separate process, so seconds of numerical work never take the GIL from control loops.  An
upload whose client went away (its timeout, a closed page) is stopped at the analysis's next
fit evaluation (``bench.checkpoint``): before, it held the only worker to its end -- 80 s for
a j1 record with a saturating torque constant -- and every upload after it waited.
"""
from __future__ import annotations

import itertools
import multiprocessing
from concurrent.futures import Future, ProcessPoolExecutor

# abandoned job ids the worker checks (a ring: an upload is abandoned while it runs or waits,
# and more than this many waiting at once would already be a queue of minutes)
SLOTS = 16

_abandoned = None        # in the worker: the shared ring


def _init(abandoned) -> None:
    from api.lifeline import analysis_worker_init
    global _abandoned
    _abandoned = abandoned
    analysis_worker_init()


def analyze_upload(job: int, raw: bytes, name: str, options: dict, effects, diagnose: bool,
                   plots: bool = False, residuals: bool = False) -> dict:
    """In the analysis process: read, identify, diagnose; InputError travels back pickled,
    and ``bench.checkpoint.Stopped`` once the job is abandoned.  ``plots``: the report's
    plots too, as PNG data: URIs under ``plots`` (the technician's page shows them);
    ``residuals``: ``bench analyze --residuals``'s CSV as text under ``residuals_csv``."""
    import json

    from bench.analysis import analyze_record
    from bench.checkpoint import stoppable
    from bench.readers import read_record
    with stoppable(lambda: job in _abandoned[:]):
        rec = read_record(raw, name=name, **options)
        result = analyze_record(rec, inertia=options.get("inertia"), add=effects, diagnose_effects=diagnose,
                                name=name)
    doc = json.loads(json.dumps(result.report(), default=float))   # plain JSON types only
    if plots:
        from bench.report_html import plots_as_data
        doc["plots"] = plots_as_data(result)
    if residuals:       # the very file the command line writes: one writer, one format
        import tempfile
        from pathlib import Path
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "residuals.csv"
            result.write_residuals(path)
            doc["residuals_csv"] = path.read_text()
    return doc


class AnalysisWorker:
    def __init__(self) -> None:
        ctx = multiprocessing.get_context("spawn")
        self._abandoned = ctx.RawArray("q", SLOTS)        # 0: an empty slot; jobs count from 1
        self._jobs = itertools.count(1)
        self._ring = itertools.cycle(range(SLOTS))
        self.pool = ProcessPoolExecutor(max_workers=1, mp_context=ctx, initializer=_init,
                                        initargs=(self._abandoned,))

    def submit(self, *args) -> tuple[int, Future]:
        job = next(self._jobs)
        return job, self.pool.submit(analyze_upload, job, *args)

    def abandon(self, job: int, fut: Future) -> None:
        """Nobody waits for ``job`` any more: drop it if it has not started, else stop it."""
        if not fut.cancel():
            self._abandoned[next(self._ring)] = job

    def shutdown(self) -> None:
        self.pool.shutdown(wait=False, cancel_futures=True)
