"""The process pools of every command that flies or trains in several processes (benchmark,
sweep, classical tuning, several seeds, the environment benchmark).

A worker is a fresh interpreter (the ``spawn`` start method), never a fork: a process forked after
torch has started its OpenMP threads inherits a thread pool whose threads do not exist, and the
first parallel torch operation in the child then waits for them forever. Each worker runs one
torch thread (the thread variables are set before it starts, so before it imports torch): the
workers share the machine's cores, and OpenMP threads beyond them only wait on each other.

Ctrl-C reaches the whole process group; the workers ignore it (from their start) and the parent, on its
``KeyboardInterrupt`` (or any error), cancels the work not started and terminates its workers
before the exception goes on, so that a stopped command ends in its own one line, not in a
traceback from each worker. A worker also ends when its parent does, however it ends (on Linux,
``prctl``'s parent-death signal; SIGKILL of the parent included): an orphan would go on flying or
training, holding its run folder, and the same command started again would be refused.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import signal
import sys
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor

# The thread counts of the libraries a worker may load (torch's OpenMP and MKL, numpy's BLAS).
THREAD_VARIABLES = ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS")
STOP_GRACE_S = 5.0  # how long a terminated worker may take to end before it is killed


class _WorkerProcess(multiprocessing.context.SpawnProcess):
    """A spawned worker that never sees Ctrl-C: the parent blocks SIGINT for the moment it starts
    the new interpreter, which inherits the blocked signal; the worker ignores it before it
    unblocks it (``_start_worker``), so a Ctrl-C during its imports is held, then dropped, instead
    of printing a traceback of its own. In the parent a Ctrl-C that came meanwhile is held too and
    delivered when it unblocks, never lost."""

    def start(self) -> None:
        previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        try:
            super().start()
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, previous)


class _WorkerContext(multiprocessing.context.SpawnContext):
    Process = _WorkerProcess


PR_SET_PDEATHSIG = 1  # linux/prctl.h


def _end_with_parent() -> None:
    """SIGTERM to this worker when the process that started it ends (Linux; elsewhere the parent's
    own clean-up, ``stop_workers``, is all), and an end now where it has ended already."""
    if sys.platform.startswith("linux"):
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGTERM)
    parent = multiprocessing.parent_process()
    if parent is not None and os.getppid() != parent.pid:  # the parent ended before the line above
        os._exit(1)


def _start_worker() -> None:
    """Runs first in every worker: ended with its parent (``_end_with_parent``), Ctrl-C ignored,
    then no longer blocked (``_WorkerProcess``), and one torch thread (where a module the worker
    unpickled has loaded torch already; the variables cover a later import)."""
    _end_with_parent()
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    torch = sys.modules.get("torch")
    if torch is not None:
        torch.set_num_threads(1)


@contextlib.contextmanager
def _one_thread_environment() -> Iterator[None]:
    """The thread variables at 1 while workers start (a spawned worker takes the parent's
    environment when it starts), then as they were."""
    before = {name: os.environ.get(name) for name in THREAD_VARIABLES}
    os.environ.update({name: "1" for name in THREAD_VARIABLES})
    try:
        yield
    finally:
        for name, value in before.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


def stop_workers(pool: ProcessPoolExecutor, grace_s: float = STOP_GRACE_S) -> None:
    """Cancel what has not started and terminate (SIGTERM) the workers now, without waiting for
    their work; a worker still alive ``grace_s`` seconds later is killed."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        if process.is_alive():
            process.terminate()
    for process in processes:
        process.join(timeout=grace_s)
        if process.is_alive():
            process.kill()


def pool_size(requested: int, jobs: int | None = None) -> int:
    """The processes a pool of ``requested`` workers starts for ``jobs`` pieces of work: never more
    than the work (a worker without work is only a start-up cost) nor than the cores this process
    may run on (one torch thread each: more only wait on each other); at least 1."""
    if requested < 1:
        raise ValueError(f"a process pool needs at least 1 worker, got {requested}")
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        cores = os.cpu_count() or 1
    return max(1, min(requested, cores, requested if jobs is None else jobs))


@contextlib.contextmanager
def process_pool(workers: int, grace_s: float = STOP_GRACE_S, jobs: int | None = None) -> Iterator[ProcessPoolExecutor]:
    """A pool of ``pool_size(workers, jobs)`` fresh processes of one torch thread each, for a
    ``with`` block. On a normal exit it waits for its work; on any exception (Ctrl-C's
    ``KeyboardInterrupt`` included) it stops its workers first (``stop_workers``, giving each
    ``grace_s`` seconds to end: longer for work that saves itself on SIGTERM) and the exception
    goes on."""
    workers = pool_size(workers, jobs)
    with _one_thread_environment():
        # Workers start as work is submitted, so the variables stay set while the pool lives.
        pool = ProcessPoolExecutor(max_workers=workers, mp_context=_WorkerContext(), initializer=_start_worker)
        try:
            yield pool
        except BaseException:
            stop_workers(pool, grace_s)
            raise
        pool.shutdown(wait=True)


@contextlib.contextmanager
def optional_pool(workers: int) -> Iterator[ProcessPoolExecutor | None]:
    """``process_pool(workers)`` for more than one worker; None (work in this process) for one."""
    if workers <= 1:
        yield None
        return
    with process_pool(workers) as pool:
        yield pool


__all__ = ["THREAD_VARIABLES", "optional_pool", "pool_size", "process_pool", "stop_workers"]
