"""What the commands share about their process: settings that make training fast on a CPU (torch
threads, the memory allocator), TorchRL's log lines, their argument parser and number types (a
value out of range is refused in one line before any work), and the check of an output folder
before any work is done (results of an earlier run are never replaced silently). Nothing here
imports torch at module level, so that a command can parse its arguments (and refuse bad ones)
before loading it."""

from __future__ import annotations

import argparse
import ctypes
import logging
import math
import os
import re
import signal
import sys
import tempfile
import threading
import warnings
from collections.abc import Callable
from pathlib import Path

from aircraft import AIRCRAFT_NAME

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


def available_memory() -> int | None:
    """Bytes of memory this machine can give a new allocation without swapping (``MemAvailable``;
    the physical memory where the kernel does not say), None where neither is known."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, ValueError, OSError):
        return None


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
    (``--json``). Each line goes above the progress bar (tqdm's ``write``), not into the bar being
    drawn; where stderr is not a terminal (a log file, a pipe) the lines go without TorchRL's colour
    codes. Imports TorchRL (which sets up its logger on import)."""
    import torchrl  # noqa: F401 - creates the "torchrl" logger and its handler

    for handler in logging.getLogger("torchrl").handlers:
        if not isinstance(handler, logging.StreamHandler) or isinstance(handler.stream, _AboveProgressBars):
            continue
        if handler.stream not in (sys.stdout, sys.stderr):
            continue
        if not _is_terminal(sys.stderr) and not isinstance(handler.formatter, _PlainFormatter):
            handler.setFormatter(_PlainFormatter(handler.formatter))
        handler.setStream(_AboveProgressBars(sys.stderr))


class _AboveProgressBars:
    """A log handler's stream that writes each whole line with ``tqdm.write``, which clears any
    progress bar, writes the line and draws the bar again below it."""

    def __init__(self, stream):
        self.stream = stream
        self._partial = ""

    def write(self, text: str) -> int:
        from tqdm import tqdm

        *lines, self._partial = (self._partial + text).split("\n")
        for line in lines:
            tqdm.write(line, file=self.stream)
        return len(text)

    def flush(self) -> None:
        self.stream.flush()


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


# ---------------------------------------------------------------------------------- the commands' process
class CommandStopped(KeyboardInterrupt):
    """SIGTERM, raised as Ctrl-C's ``KeyboardInterrupt`` is, so that a command's ``finally`` blocks
    and process pools (``training.workers``) clean up the same way for both."""

    signal_name = "SIGTERM"


def _raise_stopped(signum, frame) -> None:
    raise CommandStopped()


def run_command(main: Callable[[], int | None], script: str | Path) -> None:
    """Run a command's ``main`` and exit with its code. A stop request ends it in one line on stderr,
    ``NAME: stopped by SIGINT (Ctrl-C) before it finished``, with a shell's exit code for the signal
    (130 or 143), never a traceback: Ctrl-C (SIGINT) and SIGTERM both raise ``KeyboardInterrupt``
    in the main thread. A command that keeps partial work says so itself before this line. A
    reader that stops reading (``| head``) ends it quietly."""
    name = Path(script).stem
    if threading.current_thread() is threading.main_thread():  # the only thread that may set handlers
        signal.signal(signal.SIGTERM, _raise_stopped)
    try:
        code = main()
        sys.stdout.flush()  # here, so that a reader gone away (BrokenPipeError) is handled below
    except KeyboardInterrupt as stop:
        which = getattr(stop, "signal_name", "SIGINT")
        print(f"{name}: stopped by {which}{' (Ctrl-C)' if which == 'SIGINT' else ''} before it finished",
              file=sys.stderr)
        code = 128 + int(getattr(signal, which))
    except BrokenPipeError:
        # What reads the output has stopped (``| head``): end quietly, as a shell tool does; stdout
        # goes nowhere so that the interpreter's own flush at exit does not fail again.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        code = 128 + int(signal.SIGPIPE)
    sys.exit(code)


# ---------------------------------------------------------------------------------- the commands' arguments
class _DefaultsHelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """``--help`` with each option's default once: none added where the help already says it, nor
    for a default that says nothing (an unset option, a flag that is off, an empty list)."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        if "default" in text.lower() or action.default is None or action.default is False \
                or (isinstance(action.default, (list, tuple)) and not action.default):
            return text
        return super()._get_help_string(action)


class ScriptParser(argparse.ArgumentParser):
    """The argument parser of every command in ``scripts/``: options are matched whole (never by
    prefix), ``--help`` shows each option's default once, and a refused argument is one line on stderr,
    ``NAME: --option must be ..., got ...``, with exit code 2 (``--help`` shows the usage).

    ``script`` is the command's file (``__file__``): its name is the program in ``--help`` and its
    stem opens every error line, as the commands' own messages do."""

    def __init__(self, script: str | Path, description: str | None = None, **kwargs):
        kwargs.setdefault("allow_abbrev", False)
        kwargs.setdefault("formatter_class", _DefaultsHelpFormatter)
        super().__init__(prog=Path(script).name, description=description, **kwargs)
        self.command_name = Path(script).stem

    def error(self, message: str):
        # argparse says "argument --episodes: must be at least 1, got 0"; the line reads better as
        # "--episodes must be at least 1, got 0" (the types below all say "must ...").
        message = re.sub(r"^argument ([^:]+): (?=must )", r"\1 ", message)
        message = re.sub(r"^argument ([^:]+): ", r"\1: ", message)
        self.exit(2, f"{self.command_name}: {message}\n")


def _number_text(value: float) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


def number_type(kind: type = float, low: float | None = None, high: float | None = None, *,
                low_open: bool = False, high_open: bool = False, unit: str = "", infinite_ok: bool = False,
                outside: str | None = None, name: str | None = None):
    """An argparse ``type=`` that takes a number of ``kind`` (int or float) in a range and refuses
    anything else with ``ArgumentTypeError`` ("must be ..., got ..."). NaN is always refused;
    infinity too unless ``infinite_ok`` (and the range allows it). ``low`` / ``high``: the
    bounds (None: none), ``low_open`` / ``high_open``: bounds that are not allowed themselves.
    ``outside`` names the range where it has a name ("the flight envelope"): a value out of it is
    then "VALUE is outside the flight envelope, in [0, 20000] m". The returned function carries
    ``kind``, ``low``, ``high`` and ``allowed`` (the range in words)."""
    if kind not in (int, float):
        raise TypeError(f"number_type takes int or float, not {kind!r}")
    suffix = f" {unit}" if unit else ""
    if low is not None and high is not None:
        allowed = (f"in {'(' if low_open else '['}{_number_text(low)}, {_number_text(high)}{')' if high_open else ']'}"
                   f"{suffix}")
    elif low is not None:
        if low_open:
            allowed = "positive" if low == 0 else f"above {_number_text(low)}{suffix}"
        else:
            allowed = f"at least {_number_text(low)}{suffix}"
    elif high is not None:
        allowed = f"{'below' if high_open else 'at most'} {_number_text(high)}{suffix}"
    else:
        allowed = "a finite number" if not infinite_ok else "a number"
    whole = "a whole number" if kind is int else "a number"

    def convert(text: str):
        try:
            value = kind(text)
        except (TypeError, ValueError):
            raise argparse.ArgumentTypeError(f"must be {whole}, got {text!r}") from None
        not_finite = math.isnan(value) or (math.isinf(value) and not infinite_ok)
        too_low = low is not None and (value <= low if low_open else value < low)
        too_high = high is not None and (value >= high if high_open else value > high)
        if (not_finite or too_low or too_high) and outside is not None:
            raise argparse.ArgumentTypeError(f"{text} is outside {outside}, {allowed}")
        if not_finite:
            bounded = low is not None and high is not None or allowed == "a finite number"
            raise argparse.ArgumentTypeError(f"must be {allowed}{'' if bounded else ' and finite'}, got {text}")
        if too_low or too_high:
            raise argparse.ArgumentTypeError(f"must be {allowed}, got {text}")
        return value

    convert.__name__ = name or f"{kind.__name__}_{allowed.replace(' ', '_')}"
    convert.kind, convert.low, convert.high, convert.allowed = kind, low, high, allowed
    return convert


def add_aircraft_options(parser: argparse.ArgumentParser, where: str, transfer: bool = True) -> None:
    """``--aircraft`` (the aircraft flown; ``where`` says how the command's flights move into its
    envelope) and, where ``transfer``, ``--transfer`` (a policy flown on an aircraft it was not
    trained on)."""
    parser.add_argument("--aircraft", default=AIRCRAFT_NAME,
                        help="the aircraft flown: a packaged aircraft's name or a folder built by "
                             f"scripts/build_aircraft.py --out (default: the paper's, solar_uav); {where}")
    if transfer:
        parser.add_argument("--transfer", action="store_true",
                            help="fly a policy on an aircraft it was not trained on (a transfer experiment)")


def check_in_envelope(flown, altitude_m: float, eas_mps: float) -> None:
    """Refuse (``ValueError``) a flight condition given as ``--altitude-m`` and ``--veas-mps`` outside
    the envelope of ``flown`` (an ``aircraft.Aircraft``): "--altitude-m 25000 is outside
    small_solar_uav's envelope, [0, 3000] m"."""
    for option, value, (low, high), unit in (("--altitude-m", altitude_m, flown.altitude_range_m, "m"),
                                             ("--veas-mps", eas_mps, flown.eas_range_mps, "m/s")):
        if not low <= value <= high:
            raise ValueError(f"{option} {value:g} is outside {flown.name}'s envelope, [{low:g}, {high:g}] {unit}")


def name_list(text: str, allowed, option: str) -> list[str]:
    """A comma-separated list of names, each one of ``allowed`` and each once (a command's
    ``--controllers A,B``); ``ValueError`` naming ``option`` otherwise."""
    names = [n.strip() for n in text.split(",") if n.strip()]
    bad = [n for n in names if n not in allowed]
    if bad or not names:
        raise ValueError(f"{option} takes any of {', '.join(allowed)}, got {text!r}")
    if len(set(names)) < len(names):
        raise ValueError(f"{option}: each once, got {text!r}")
    return names


finite_float = number_type(float, name="finite_float")
positive_float = number_type(float, 0.0, low_open=True, name="positive_float")
non_negative_float = number_type(float, 0.0, name="non_negative_float")
probability = number_type(float, 0.0, 1.0, name="probability")
positive_int = number_type(int, 1, name="positive_int")
# Every count a command takes has an upper bound, so that a slip (1e6 for 1e3) is a one-line refusal
# instead of days of flying or all the memory: the realisations of a condition at most the frozen
# test set's size (``training.evaluation.seeds.TEST_SEEDS``), which is as many as any comparison here uses.
MAX_EPISODES = 1000
episodes_int = number_type(int, 1, MAX_EPISODES, name="episodes")
MAX_WORKERS = 1024  # processes; the pools start at most the machine's cores (``training.workers.pool_size``)
workers_int = number_type(int, 1, MAX_WORKERS, name="workers")
MAX_ROUNDS = 1000  # repeats of a timing
rounds_int = number_type(int, 1, MAX_ROUNDS, name="rounds")
non_negative_int = number_type(int, 0, name="non_negative_int")
seed_int = number_type(int, 0, name="seed")  # numpy's generators take seeds >= 0
# jsbsim_env.control.factory.CONTROLLER_NAMES, spelled out for the commands' --controller choices:
# the factory loads the simulation, which a mistyped option need not wait for (a test keeps the two equal).
CONTROLLER_NAMES = ("policy", "pid", "lqi", "pid_tuned", "lqi_tuned", "pid_robust", "lqi_robust", "lqi_stressed")


# ---------------------------------------------------------------------------------- results of an earlier run
def claim_output_file(path: Path | str, overwrite: bool = False) -> Path:
    """For a command that writes one file (a folder's commands: ``training.output_folders``):
    ``path`` is not a folder, its folder can be written to, and an existing file is refused unless
    ``overwrite``."""
    path = Path(path)
    if path.is_dir():
        raise OutputFolderError(f"{path} is a folder: give the file's name")
    check_output_folder(path.parent)
    if path.exists() and not overwrite:
        raise OutputFolderError(f"{path} holds the result of an earlier run: give another file name, "
                                "or --overwrite to replace it")
    return path
