"""The attitude controller's process of the loop bench, as it would run on its own computer.

It opens a serial device (the bench's pseudo-terminal, or ``/dev/ttyUSB0`` on real hardware),
reads the flight computer's state bursts, answers each with the controller's command and sends a
heartbeat once a second. It keeps no clock of its own: the flight computer's frames trigger it.
Run it alone against a real port with

    python -m jsbsim_env.bench.node --device /dev/ttyUSB0 --baud 115200 --controller policy

On SIGTERM or Ctrl-C it writes its counters (frames answered, compute time, CRC errors, frames
that arrived incomplete) to ``--stats`` and exits.
"""

from __future__ import annotations

import argparse
import json
import math
import select
import signal
import sys
import time
from pathlib import Path

import numpy as np

from jsbsim_env.bench.link import Faults
from jsbsim_env.bench.wire import (
    CONTROLLER_SYSTEM_ID,
    PLANT_SYSTEM_ID,
    FrameAssembler,
    encode_command,
    heartbeat,
    is_crc_error,
    new_link,
)
from jsbsim_env.control.factory import CONTROLLER_NAMES

# A gap between frames longer than this (the plant's failsafe timeout) starts the controller afresh:
# its memory of the flight before the gap no longer describes the aircraft.
RESET_AFTER_GAP_S = 0.12


def percentiles_ms(seconds: list[float]) -> dict[str, float | None]:
    """p50, p99 and max of durations given in seconds, in ms (None where there are none)."""
    if not seconds:
        return {"p50": None, "p99": None, "max": None}
    a = np.asarray(seconds) * 1000.0
    return {"p50": float(np.percentile(a, 50)), "p99": float(np.percentile(a, 99)), "max": float(a.max())}


class ControllerNode:
    """Serves one controller on one open serial port (anything with ``read``, ``write``,
    ``in_waiting`` and ``fileno``, as pyserial's ``Serial``)."""

    def __init__(self, port, controller, rate_hz: float = 25.0, faults: Faults | None = None):
        self.port, self.controller = port, controller
        self.dt_s = 1.0 / rate_hz
        self.faults = faults or Faults()
        self.link = new_link(CONTROLLER_SYSTEM_ID)
        self.assembler = FrameAssembler()
        self.compute_s: list[float] = []
        self.counts = {"answered": 0, "skipped_stale": 0, "crc_errors": 0, "bad_bytes": 0, "sequence_gaps": 0,
                       "resets": 0, "stalls": 0, "bad_frames": 0, "controller_errors": 0}
        self.last_error: str | None = None
        self._last_frame_us: int | None = None
        self._expected_seq: int | None = None
        self._stalled = False
        self._next_heartbeat = 0.0
        self.running = True

    def stats(self) -> dict:
        return {**self.counts, "incomplete_frames": self.assembler.incomplete, "last_error": self.last_error,
                "compute_ms": percentiles_ms(self.compute_s)}

    def _sequence(self, message) -> None:
        """Count messages lost between the plant's sequence numbers."""
        if message.get_srcSystem() != PLANT_SYSTEM_ID:
            return
        seq = message.get_seq()
        if self._expected_seq is not None and seq != self._expected_seq:
            self.counts["sequence_gaps"] += (seq - self._expected_seq) % 256
        self._expected_seq = (seq + 1) % 256

    def handle(self, data: bytes) -> int:
        """Parse received bytes and answer the newest complete frame among them; returns frames answered."""
        newest = None
        for message in self.link.parse_buffer(data) or []:
            if message.get_type() == "BAD_DATA":
                self.counts["crc_errors" if is_crc_error(message) else "bad_bytes"] += 1
                continue
            self._sequence(message)
            frame = self.assembler.feed(message)
            if frame is not None:
                if newest is not None:
                    self.counts["skipped_stale"] += 1  # a backlog: only the newest state matters
                newest = frame
        if newest is None:
            return 0
        self.answer(newest)
        return 1

    def answer(self, frame) -> None:
        t_s = frame.time_us / 1e6
        if self.faults.stalled(t_s) and not self._stalled:
            self._stalled = True  # the process hangs once, for the whole stall
            self.counts["stalls"] += 1
            time.sleep(self.faults.stall_s)
            return
        if self._last_frame_us is not None and (frame.time_us - self._last_frame_us) / 1e6 > RESET_AFTER_GAP_S:
            self.controller.reset()
            self.counts["resets"] += 1
        self._last_frame_us = frame.time_us
        if not (np.all(np.isfinite(frame.measurement)) and np.all(np.isfinite(frame.setpoint))):
            self.counts["bad_frames"] += 1  # well-formed but not a state: no answer, the plant's failsafe acts
            return
        start = time.perf_counter()
        try:
            command = self.controller.update(self.dt_s, frame.measurement, frame.setpoint)
        except ValueError as err:  # the controller refused its input (ActionError, CommandError, ...)
            self.counts["controller_errors"] += 1
            self.last_error = str(err)
            return
        self.compute_s.append(time.perf_counter() - start)
        self.port.write(encode_command(self.link, frame.time_us, command))
        self.counts["answered"] += 1

    def serve(self, idle_timeout_s: float = math.inf) -> None:
        """Answer frames until ``running`` turns false, the device goes away, or nothing arrives
        for ``idle_timeout_s``."""
        last_data = time.monotonic()
        fd = self.port.fileno()
        while self.running:
            now = time.monotonic()
            if now >= self._next_heartbeat:
                self.port.write(heartbeat(self.link, plant=False))
                self._next_heartbeat = now + 1.0
            ready, _, _ = select.select([fd], [], [], 0.2)
            if not ready:
                if time.monotonic() - last_data > idle_timeout_s:
                    return
                continue
            data = self.port.read(max(self.port.in_waiting, 1))
            if data:
                last_data = time.monotonic()
                self.handle(data)


def _write_json_atomically(path: Path, data: dict) -> None:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(data, indent=1))
    tmp.replace(path)


def _positive(kind: type, infinite_ok: bool = False):
    """An argparse type: a positive number of ``kind`` (infinity only where ``infinite_ok``)."""
    def convert(text: str):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be a positive number, got {text!r}") from None
        if not value > 0 or (math.isinf(value) and not infinite_ok):  # NaN fails too
            raise argparse.ArgumentTypeError(f"must be positive{'' if infinite_ok else ' and finite'}, got {text}")
        return value

    convert.__name__ = f"positive_{kind.__name__}"
    return convert


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], allow_abbrev=False,
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--device", required=True, help="serial device path (a pty of the bench, or /dev/ttyUSB0)")
    parser.add_argument("--baud", type=_positive(int), default=115200, help="line rate, bit/s")
    parser.add_argument("--controller", default="policy", choices=CONTROLLER_NAMES)
    parser.add_argument("--policy", default=None, help="policy file (.pt); the shipped policy when omitted")
    parser.add_argument("--aircraft", default=None,
                        help="the aircraft flown (a packaged aircraft's name or a built aircraft's folder); the "
                             "paper's when omitted")
    parser.add_argument("--transfer", action="store_true",
                        help="fly a policy on an aircraft it was not trained on (a transfer experiment)")
    parser.add_argument("--rate-hz", type=_positive(float), default=25.0, help="control frame rate the controller assumes, Hz")
    parser.add_argument("--faults", default="", help="controller-side faults: stall_at=S,stall_s=D (flight time, s)")
    parser.add_argument("--stats", default=None, help="write the counters here (JSON) on exit")
    parser.add_argument("--idle-timeout-s", type=_positive(float, infinite_ok=True), default=math.inf,
                        help="exit after this long without a byte, s")
    args = parser.parse_args(argv)
    try:
        faults = Faults.parse(args.faults)
    except ValueError as exc:
        parser.error(str(exc))
    import serial

    try:
        port = serial.Serial(args.device, baudrate=args.baud, timeout=0)
    except (serial.SerialException, OSError) as exc:
        print(f"cannot open serial device {args.device}: {exc}", file=sys.stderr)
        return 2
    from jsbsim_env.control.factory import make_controller

    controller = make_controller(args.controller, args.policy, aircraft=args.aircraft, transfer=args.transfer)
    node = ControllerNode(port, controller, args.rate_hz, faults)

    def stop(signum, frame):
        node.running = False

    signal.signal(signal.SIGTERM, stop)
    signal.signal(signal.SIGINT, stop)
    try:
        node.serve(args.idle_timeout_s)
    except (serial.SerialException, OSError) as exc:
        print(f"serial device {args.device} failed: {exc}", file=sys.stderr)
    finally:
        if args.stats:
            _write_json_atomically(Path(args.stats), node.stats())
        port.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
