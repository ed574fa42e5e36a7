"""Whole shots: plan per-frame jobs from frame patterns, then run them here, in local processes or on Dask.

The command line, the Blender add-on and pipeline scripts run a shot the same way::

    from vfxstereo import shot, tasks

    jobs = shot.plan_jobs({"views": ["cam0.####.exr", "cam1.####.exr"]}, {"stack": "stack.####.exr"},
                          frames="1001-1100", chunk=(10, 2))      # frames 1021-1030: chunk 2 of size 10
    report = shot.run_jobs(jobs, tasks.SolveTask(preset="wta"), scheduler="local", workers=2)
    report.failed                                                 # [] when every frame was written

Planning (:func:`plan_jobs`) expands the patterns into one :class:`Job` per frame, with concrete paths,
checks that inputs exist and output folders can be written, and leaves out frames whose outputs all exist
(unless ``overwrite``), so an interrupted shot resumes where it stopped. Running (:func:`run_jobs`)
validates the first frame with the task's ``check`` before anything runs, then runs every job:

==================  =====================================================================================
how                 what
==================  =====================================================================================
one file            no pattern: the task runs here; its error propagates (the CLI: one line, exit 2)
serial              a sequence, ``workers=1``: frame after frame here, a progress bar per solver stage
``workers=N``       a pool of N local processes (spawned, not forked); a bar of frames done
``scheduler=...``   a Dask distributed cluster: ``"local"`` starts a LocalCluster of ``workers``
                    processes, anything else is a scheduler address (``tcp://host:8786``); every task
                    reads its own inputs and writes its own outputs, so workers need the same paths
                    (shared storage) and vfxstereo installed; for an address, paths are made absolute
                    before submitting (so the stacks name their plates by absolute paths)
==================  =====================================================================================

In a sequence a failed frame does not stop the others: it is tried again up to ``retries`` more times
(after the frames queued before it), reported on the log each time, and listed in the returned
:class:`ShotReport`. Outputs are written atomically by the tasks (:mod:`vfxstereo.io.atomic`), so a frame
that fails or is interrupted leaves no partial file and clobbers nothing.

Farm chunks (OpenCue, Deadline, Flamenco, array jobs): ``chunk=(size, index)`` keeps the ``index``-th run of
``size`` frames (counting from 0) of the frame list, so N farm tasks each run ``--chunk-size S
--chunk-index I`` on the same ``--frames`` and together cover the shot.
"""

from __future__ import annotations

import contextlib
import logging
import os
import sys
import time
import traceback
import uuid
from collections import deque
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

from vfxstereo.errors import VfxStereoError
from vfxstereo.progress import Progress
from vfxstereo.tasks import check_input, check_output

log = logging.getLogger("vfxstereo")

Task = Callable[..., None]
"""A per-frame task: ``task(job, progress)`` does the frame (see :mod:`vfxstereo.tasks`)."""


# --------------------------------------------------------------------------------------------------------
# Progress on stderr


class ProgressBars:
    """A progress callback (``stage, done, total``) shown as one tqdm bar per stage on stderr.

    On a terminal each stage gets a bar; when stderr is not a terminal (logs, CI) each finished stage is one
    log line with its time instead, so logs stay readable.
    """

    def __init__(self, *, enabled: bool = True, prefix: str = ""):
        self.enabled = enabled
        self.prefix = prefix
        self.tty = sys.stderr.isatty()
        self._bar = None
        self._stage = None
        self._t0 = time.perf_counter()

    def __call__(self, stage: str, done: int, total: int) -> None:
        """Show that ``done`` of ``total`` steps of ``stage`` are finished."""
        if not self.enabled or stage == "passes":
            return
        if stage != self._stage:
            self.close()
            self._stage = stage
            self._t0 = time.perf_counter()
            if self.tty:
                from tqdm import tqdm

                self._bar = tqdm(total=total, desc=f"{self.prefix}{stage}", file=sys.stderr, leave=False,
                                 dynamic_ncols=True, mininterval=0.2)
        if self._bar is not None:
            self._bar.n = done
            self._bar.refresh()
        if done >= total:
            log.debug("%s%s: %d steps in %.2f s", self.prefix, stage, total, time.perf_counter() - self._t0)
            self.close()

    def close(self) -> None:
        """Close the bar of the current stage."""
        if self._bar is not None:
            self._bar.close()
        self._bar = None
        self._stage = None


# --------------------------------------------------------------------------------------------------------
# Planning


@dataclass
class Job:
    """One command on one frame: concrete input and output paths (``frame`` is None for a single file)."""

    frame: int | None
    inputs: dict[str, str | list[str] | None]
    outputs: dict[str, str | None]

    def absolute(self) -> Job:
        """The same job with every path made absolute (for workers whose working folder is not ours)."""
        return Job(self.frame, {k: _map_paths(v, os.path.abspath) for k, v in self.inputs.items()},
                   {k: _map_paths(v, os.path.abspath) for k, v in self.outputs.items()})


def _map_paths(value, fn):
    if value is None:
        return None
    if isinstance(value, list):
        return [_map_paths(v, fn) for v in value]
    return fn(value)


def chunk_frames(frames: list[int], size: int, index: int) -> list[int]:
    """The ``index``-th run of ``size`` frames of ``frames`` (``index`` counts from 0).

    Parameters
    ----------
    frames : list of int
        The whole shot's frames, in order.
    size : int
        Frames per chunk (a farm's "chunk size" or "frames per task"), at least 1.
    index : int
        Which chunk, ``0 .. ceil(len(frames) / size) - 1``.

    Raises
    ------
    VfxStereoError
        A size below 1, or an index outside the chunks.
    """
    if size < 1:
        raise VfxStereoError(f"--chunk-size must be at least 1, got {size}")
    n_chunks = -(-len(frames) // size)
    if not 0 <= index < n_chunks:
        raise VfxStereoError(f"--chunk-index {index} is outside the {n_chunks} chunks (0..{n_chunks - 1}) of "
                             f"{len(frames)} frames in chunks of {size}")
    return frames[index * size:(index + 1) * size]


def _flat(values) -> list[str]:
    return [v for val in values if val is not None for v in (val if isinstance(val, list) else [val])]


def plan_jobs(inputs: dict, outputs: dict, *, frames: str | None = None, overwrite: bool = False,
              chunk: tuple[int, int] | None = None) -> list[Job]:
    """Expand frame patterns into per-frame jobs.

    Parameters
    ----------
    inputs, outputs : dict
        Name -> path, frame pattern, list of them (inputs) or None (an output not asked for).
    frames : str, optional
        A frame range (:func:`vfxstereo.io.frames.parse_frames`); default: the frames on disk of the first
        input pattern.
    overwrite : bool
        Redo frames whose outputs all exist (by default they are skipped, so a shot resumes).
    chunk : (size, index), optional
        Keep only one farm chunk of the frames (:func:`chunk_frames`).

    Returns
    -------
    list of Job
        One job with ``frame=None`` when no input is a pattern; else one per frame still to do.

    Raises
    ------
    VfxStereoError
        Missing inputs or input frames, output folders that cannot be written, a pattern output for
        single-file inputs or the reverse, a bad frame range or chunk.
    """
    from vfxstereo.io import frames as fr

    flat_inputs = _flat(inputs.values())
    patterns = [v for v in flat_inputs if fr.is_pattern(v)]
    for out in outputs.values():
        check_output(out if out is None or not fr.is_pattern(out) else fr.frame_path(out, 0))
    if not patterns:
        if any(o and fr.is_pattern(o) for o in outputs.values()):
            raise VfxStereoError("an output is a frame pattern but no input is")
        if chunk is not None:
            raise VfxStereoError("--chunk-size/--chunk-index split frame sequences, but no input is a pattern")
        for val in flat_inputs:
            check_input(val)
        return [Job(None, inputs, outputs)]
    for name, out in outputs.items():
        if out is not None and not fr.is_pattern(out):
            raise VfxStereoError(f"inputs are frame patterns, so the output {name} must be one too: {out}")
    frame_list = fr.parse_frames(frames) if frames else fr.find_frames(patterns[0])
    if chunk is not None:
        frame_list = chunk_frames(frame_list, *chunk)
    for pattern in patterns:
        missing = [f for f in frame_list if not Path(fr.frame_path(pattern, f)).is_file()]
        if len(missing) == len(frame_list):
            raise VfxStereoError(f"frame pattern matches no files in the frame range: {pattern}")
        if missing:
            raise VfxStereoError(f"frame {missing[0]} of {pattern} is missing ({len(missing)} missing in all: "
                                 f"{fr.frame_range(missing)})")

    def substitute(value, f):
        return _map_paths(value, lambda v: fr.frame_path(v, f) if fr.is_pattern(v) else v)

    jobs = []
    for f in frame_list:
        outs = {k: substitute(v, f) for k, v in outputs.items()}
        if not overwrite and all(Path(o).exists() for o in outs.values() if o):
            log.info("frame %d: outputs exist, skipped (use --overwrite to redo)", f)
            continue
        jobs.append(Job(f, {k: substitute(v, f) for k, v in inputs.items()}, outs))
    return jobs


# --------------------------------------------------------------------------------------------------------
# Running


@dataclass
class FrameFailure:
    """A frame that failed on every attempt."""

    frame: int
    error: str
    """The last attempt's error, one line."""
    attempts: int
    details: str = ""
    """The last attempt's traceback (empty for VfxStereoError: its message says it all)."""


@dataclass
class ShotReport:
    """What :func:`run_jobs` did: frames written and frames that failed."""

    done: list[int | None] = field(default_factory=list)
    failed: list[FrameFailure] = field(default_factory=list)


def caused_by_interrupt(exc: BaseException) -> bool:
    """True if ``exc`` is, or was caused by, a KeyboardInterrupt.

    numba turns Ctrl-C inside a kernel into a SystemError caused by the KeyboardInterrupt.
    """
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False


class _Ledger:
    """Counts attempts, logs every outcome, moves the frames bar, and builds the report."""

    def __init__(self, retries: int, bar):
        self.retries = max(0, int(retries))
        self.bar = bar
        self.attempts: dict[int, int] = {}
        self.report = ShotReport()

    def done(self, job: Job, seconds: float) -> None:
        log.info("frame %d done in %.1f s", job.frame, seconds)
        self.report.done.append(job.frame)
        self.bar.update(1)

    def failed(self, job: Job, exc: BaseException) -> bool:
        """Record a failed attempt; True if the frame is to be tried again."""
        attempt = self.attempts[job.frame] = self.attempts.get(job.frame, 0) + 1
        message = str(exc) if isinstance(exc, VfxStereoError) else f"{type(exc).__name__}: {exc}"
        details = "" if isinstance(exc, VfxStereoError) else "".join(traceback.format_exception(exc))
        if details:
            log.debug("frame %d, attempt %d:\n%s", job.frame, attempt, details.rstrip())
        if attempt <= self.retries:
            log.warning("frame %d failed (attempt %d of %d), trying again: %s", job.frame, attempt,
                        self.retries + 1, message)
            return True
        log.warning("frame %d failed (attempt %d of %d), giving up: %s", job.frame, attempt, self.retries + 1,
                    message)
        self.report.failed.append(FrameFailure(job.frame, message, attempt, details))
        self.bar.update(1)
        return False


def run_task(task: Task, job: Job) -> float:
    """Run ``task`` on ``job`` without progress reporting; seconds taken (what pool and Dask workers run)."""
    t0 = time.perf_counter()
    task(job, None)
    return time.perf_counter() - t0


def run_jobs(jobs: list[Job], task: Task, *, workers: int = 1, scheduler: str | None = None,
             retries: int = 1, quiet: bool = False, progress: Progress | None = None) -> ShotReport:
    """Run ``task`` on every job: here, in ``workers`` local processes, or on a Dask cluster.

    Parameters
    ----------
    jobs : list of Job
        From :func:`plan_jobs`.
    task : callable
        ``task(job, progress)``, picklable for ``workers > 1`` and ``scheduler`` (see :mod:`vfxstereo.tasks`);
        its ``check(job)``, if it has one, runs on the first job before anything else.
    workers : int
        Local processes (without ``scheduler``), or the LocalCluster's workers (``scheduler="local"``).
    scheduler : str, optional
        ``"local"`` or a Dask scheduler address such as ``"tcp://10.0.0.5:8786"``.
    retries : int
        How many more times a failed frame of a sequence is tried.
    quiet : bool
        No progress bars.
    progress : callable, optional
        Progress callback for frames run in this process (default: tqdm bars on stderr unless ``quiet``).

    Returns
    -------
    ShotReport

    Raises
    ------
    VfxStereoError
        From ``check``, from the task on a single file, or when the Dask scheduler cannot be reached.
    KeyboardInterrupt
        Passed on after cancelling what was not started; finished frames are intact.
    """
    if not jobs:
        log.info("nothing to do: every frame is finished")
        return ShotReport()
    check = getattr(task, "check", None)
    if check is not None:
        check(jobs[0])
    if jobs[0].frame is None:  # one file: no retries, the error is the user's to read
        bars = progress or ProgressBars(enabled=not quiet)
        try:
            task(jobs[0], bars)
        finally:
            if isinstance(bars, ProgressBars):
                bars.close()
        return ShotReport(done=[None])
    from tqdm import tqdm

    parallel = bool(scheduler) or (workers > 1 and len(jobs) > 1)
    with contextlib.ExitStack() as stack:  # closed in reverse: the bar, then the pool or cluster
        if scheduler:
            if scheduler != "local":  # remote workers have working folders of their own
                jobs = [job.absolute() for job in jobs]
            client = stack.enter_context(_dask_client(scheduler, workers))
            submit, wait_first = _dask_submitter(client, task), _dask_wait_first
        elif parallel:
            pool = stack.enter_context(_LocalPool(workers))
            submit, wait_first = (lambda job: pool.submit(run_task, task, job)), _pool_wait_first
        bar = stack.enter_context(tqdm(total=len(jobs), desc="frames", file=sys.stderr,
                                       disable=quiet or not parallel, dynamic_ncols=True))
        ledger = _Ledger(retries, bar)
        if parallel:
            _run_futures(jobs, ledger, submit, wait_first)
        else:
            _run_serial(jobs, task, ledger, quiet=quiet, progress=progress)
    return ledger.report


def _run_serial(jobs: list[Job], task: Task, ledger: _Ledger, *, quiet: bool, progress) -> None:
    queue = deque(jobs)
    total = len(jobs)
    count = 0
    while queue:
        job = queue.popleft()
        count += 1
        bars = progress or ProgressBars(enabled=not quiet, prefix=f"frame {job.frame} ({min(count, total)}/"
                                                                   f"{total}) ")
        t0 = time.perf_counter()
        try:
            task(job, bars)
        except Exception as exc:
            if caused_by_interrupt(exc):
                raise
            if ledger.failed(job, exc):
                queue.append(job)
            continue
        finally:
            if isinstance(bars, ProgressBars):
                bars.close()
        ledger.done(job, time.perf_counter() - t0)


def _run_futures(jobs: list[Job], ledger: _Ledger, submit: Callable, wait_first: Callable) -> None:
    """Submit every job, collect results as they finish, resubmit failed frames while retries are left."""
    pending = {submit(job): job for job in jobs}
    try:
        while pending:
            for fut in wait_first(list(pending)):
                job = pending.pop(fut)
                try:
                    exc = fut.exception()
                except BaseException as lost:  # cancelled by the cluster (scheduler restart, ...)
                    if isinstance(lost, KeyboardInterrupt):
                        raise
                    exc = lost
                if exc is None:
                    ledger.done(job, fut.result())
                elif ledger.failed(job, exc):
                    pending[submit(job)] = job
    except BaseException:
        for fut in pending:
            fut.cancel()
        raise


class _LocalPool:
    """A spawn process pool that is replaced when a worker process dies (BrokenProcessPool)."""

    def __init__(self, workers: int):
        self.workers = workers
        self.pool = None

    def __enter__(self) -> _LocalPool:
        return self

    def __exit__(self, *exc) -> None:
        if self.pool is not None:
            self.pool.shutdown(wait=exc[0] is None, cancel_futures=True)

    def submit(self, fn, *args):
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor
        from concurrent.futures.process import BrokenProcessPool

        for _ in range(2):
            if self.pool is None:
                # spawn, not fork: forking a process whose OpenImageIO/OpenMP threads hold locks can deadlock
                self.pool = ProcessPoolExecutor(max_workers=self.workers,
                                                mp_context=multiprocessing.get_context("spawn"))
            try:
                return self.pool.submit(fn, *args)
            except BrokenProcessPool:
                self.pool.shutdown(wait=False, cancel_futures=True)
                self.pool = None
        raise VfxStereoError("the local process pool keeps breaking; try --jobs 1")


def _pool_wait_first(futures: list) -> set:
    from concurrent.futures import FIRST_COMPLETED, wait

    return wait(futures, return_when=FIRST_COMPLETED).done


@contextlib.contextmanager
def _dask_client(scheduler: str, workers: int) -> Iterator:
    """A Dask client: of a new LocalCluster (``"local"``, ``workers`` processes) or of the scheduler at an address."""
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError:
        raise VfxStereoError("--scheduler needs dask.distributed: pip install 'dask[distributed]'") from None
    with contextlib.ExitStack() as stack:
        if scheduler == "local":
            cluster = stack.enter_context(LocalCluster(n_workers=max(1, workers), threads_per_worker=1,
                                                       processes=True, dashboard_address=None,
                                                       silence_logs=logging.CRITICAL))
            log.info("Dask LocalCluster: %d workers at %s", max(1, workers), cluster.scheduler_address)
            address = cluster
        else:
            address = scheduler
        try:
            client = stack.enter_context(Client(address))
        except (OSError, TimeoutError, ValueError, TypeError) as exc:
            raise VfxStereoError(f"cannot reach the Dask scheduler at {scheduler}: {exc}") from None
        if scheduler != "local":
            n = len(client.scheduler_info().get("workers", {}))
            log.info("Dask scheduler %s: %d workers now", scheduler, n)
            if workers > 1:
                log.warning("--jobs %d does not apply to a scheduler address: its cluster has its own workers",
                            workers)
        yield client


def _dask_submitter(client, task: Task) -> Callable:
    name = type(task).__name__

    def submit(job: Job):
        key = f"vfxstereo-{name}-frame{job.frame}-{uuid.uuid4().hex[:8]}"
        return client.submit(run_task, task, job, key=key, pure=False)

    return submit


def _dask_wait_first(futures: list) -> set:
    from dask.distributed import wait

    return wait(futures, return_when="FIRST_COMPLETED").done
