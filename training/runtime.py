"""What the commands share about their process: settings that make training fast on a CPU (torch
threads, the memory allocator), TorchRL's log lines, and the check of an output folder before
any work is done. Nothing here imports torch at module level, so that a command can parse its
arguments (and refuse bad ones) before loading it."""

from __future__ import annotations

import ctypes
import logging
import os
import re
import sys
import tempfile
import warnings
from pathlib import Path

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


# ANSI escape sequences (colours, cursor movement) as TorchRL's log formatter writes them.
_ANSI_ESCAPE = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]")


def strip_ansi(text: str) -> str:
    """``text`` without ANSI escape sequences."""
    return _ANSI_ESCAPE.sub("", text)


def torchrl_logs_to_stderr() -> None:
    """Send TorchRL's log lines to stderr: it logs to stdout, which this package keeps for results
    (``--json``). Where stderr is not a terminal (a log file, a pipe) the lines go without
    TorchRL's colour codes. Imports TorchRL (which sets up its logger on import)."""
    import torchrl  # noqa: F401 - creates the "torchrl" logger and its handler

    for handler in logging.getLogger("torchrl").handlers:
        if not isinstance(handler, logging.StreamHandler):
            continue
        if handler.stream is sys.stdout:
            handler.setStream(sys.stderr)
        if handler.stream is sys.stderr and not _is_terminal(sys.stderr) \
                and not isinstance(handler.formatter, _PlainFormatter):
            handler.setFormatter(_PlainFormatter(handler.formatter))


def _is_terminal(stream) -> bool:
    try:
        return stream.isatty()
    except (AttributeError, ValueError):  # no isatty, or a closed stream
        return False


class _PlainFormatter(logging.Formatter):
    """Another formatter's lines without their ANSI escape sequences."""

    def __init__(self, inner: logging.Formatter | None):
        super().__init__()
        self.inner = inner or logging.Formatter()

    def format(self, record: logging.LogRecord) -> str:
        return strip_ansi(self.inner.format(record))


class OutputFolderError(ValueError):
    """An output folder that cannot be created or written to."""


def check_output_folder(path: Path | str) -> Path:
    """Make sure a command can write its results to the folder ``path`` before it does any work:
    the folder exists and takes a file, or can be created. Nothing is left behind (a folder that
    does not exist yet is not created here). Raises ``OutputFolderError`` with one line naming
    the folder; returns ``path`` as a ``Path``."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise OutputFolderError(f"{path} exists and is not a folder: give a folder for the results")
    existing = path
    while not existing.exists():  # the nearest folder above that exists
        if existing.parent == existing:
            break
        existing = existing.parent
    if not existing.is_dir():
        raise OutputFolderError(f"cannot create the folder {path}: {existing} is not a folder")
    try:
        if existing == path:
            with tempfile.TemporaryFile(dir=path):
                pass
        else:  # the folders below ``existing`` can be made where a folder can be made in it
            os.rmdir(tempfile.mkdtemp(dir=existing, prefix=".write_check_"))
    except OSError as err:
        what = "write to the folder" if existing == path else "create the folder"
        raise OutputFolderError(f"cannot {what} {path}: {err.strerror or err}") from None
    return path
