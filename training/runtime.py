"""Process settings that make training fast on a CPU: torch threads and the memory allocator."""

from __future__ import annotations

import ctypes
import os
import sys
import warnings

# glibc's mallopt parameters (malloc.h).
M_TRIM_THRESHOLD = -1
M_MMAP_THRESHOLD = -3
# Every update allocates and frees the same few-megabyte tensors. glibc serves blocks above its
# mmap threshold (128 KiB, then adapted) with fresh mmap calls, and returns freed memory at the top
# of the heap past its trim threshold, so each update pays page faults for memory it just gave
# back. Raising both keeps that memory in the heap for reuse.
ALLOCATOR_THRESHOLD_BYTES = 256 * 1024 * 1024


def tune_allocator() -> bool:
    """Raise glibc's mmap and trim thresholds for this process; False where glibc is not the
    allocator (then nothing changes). The same as MALLOC_MMAP_THRESHOLD_ and MALLOC_TRIM_THRESHOLD_
    in the environment, without needing them set before the process starts."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL("libc.so.6")
        return bool(libc.mallopt(M_MMAP_THRESHOLD, ALLOCATOR_THRESHOLD_BYTES)
                    and libc.mallopt(M_TRIM_THRESHOLD, ALLOCATOR_THRESHOLD_BYTES))
    except (OSError, AttributeError):
        return False


def available_cores() -> int:
    """Cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def check_threads(threads: int, processes: int = 1) -> str | None:
    """A warning when ``threads`` torch threads in each of ``processes`` processes exceed the cores:
    OpenMP's threads then spin against each other (one run here was 8 times slower with 2 threads
    on 2 busy cores than with 1). Issues it and returns its text; None when they fit."""
    cores = available_cores()
    if threads * processes <= cores:
        return None
    text = (f"{threads} torch threads x {processes} processes exceed the {cores} cores: OpenMP threads will "
            "wait on each other and training slows many times; give each run --threads 1 or fewer runs")
    warnings.warn(text, RuntimeWarning, stacklevel=2)
    return text


def torchrl_logs_to_stderr() -> None:
    """Send TorchRL's log lines to stderr: it logs to stdout, which this package keeps for results
    (``--json``)."""
    import logging

    for handler in logging.getLogger("torchrl").handlers:
        if isinstance(handler, logging.StreamHandler) and handler.stream is sys.stdout:
            handler.setStream(sys.stderr)
