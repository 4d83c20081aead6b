"""The serial line of the loop bench: a pseudo-terminal pair or a real port, the wire's byte time,
and injected faults.

The plant side owns the line's emulation in both directions. Bytes it sends are written to the
device only when their last bit would have arrived (10 bits per byte at ``baud``: start, 8 data,
stop); bytes it reads are handed to the parser only once they could have crossed the wire. A
real port (``--device``) has its own byte time, so there the emulation adds none.
"""

from __future__ import annotations

import math
import os
import re
import tty
from collections import deque
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

BITS_PER_BYTE = 10  # start bit, 8 data bits, stop bit


def byte_time_s(n_bytes: int, baud: int) -> float:
    return n_bytes * BITS_PER_BYTE / baud


@dataclass(frozen=True)
class Faults:
    """Faults injected on the line (``parse``'s text form in brackets).

    drop, corrupt: probability that a frame (one state burst, or one command) is lost, or has one
    byte flipped, in each direction [drop=0.05,corrupt=0.01]. delay_ms: extra latency of every
    frame [delay_ms=30]. disconnect_at_s, disconnect_s: the line carries nothing from that flight
    time for that long [disconnect_at=20,disconnect_s=5]. stall_at_s, stall_s: the controller
    process stops answering for that long [stall_at=30,stall_s=2].
    """

    drop: float = 0.0
    corrupt: float = 0.0
    delay_ms: float = 0.0
    disconnect_at_s: float | None = None
    disconnect_s: float = 5.0
    stall_at_s: float | None = None
    stall_s: float = 2.0

    _NAMES: ClassVar[dict[str, str]] = {"drop": "drop", "corrupt": "corrupt", "delay_ms": "delay_ms", "disconnect_at": "disconnect_at_s",
              "disconnect_s": "disconnect_s", "stall_at": "stall_at_s", "stall_s": "stall_s"}

    def __post_init__(self):
        text_name = {field: name for name, field in self._NAMES.items()}
        for name in ("drop", "corrupt"):
            p = getattr(self, name)
            if not 0.0 <= p <= 1.0:  # NaN fails too
                raise ValueError(f"fault {name} is a probability in [0, 1], got {p}")
        for name in ("delay_ms", "disconnect_s", "stall_s", "disconnect_at_s", "stall_at_s"):
            value = getattr(self, name)
            if value is not None and not 0.0 <= value < math.inf:  # NaN fails too
                raise ValueError(f"fault {text_name[name]} must be a finite number >= 0 "
                                 f"({'ms' if name == 'delay_ms' else 's'}), got {value}")

    @classmethod
    def parse(cls, text: str | None) -> Faults:
        """``"drop=0.05,corrupt=0.01,delay_ms=30,disconnect_at=20"`` -> Faults; empty -> none. A
        fault that is not known, not a number, out of its range or given twice is refused
        (``ValueError``, one line)."""
        values: dict[str, float] = {}
        for item in filter(None, (s.strip() for s in (text or "").split(","))):
            match = re.fullmatch(r"([a-z_]+)=(.*)", item)
            if not match or match.group(1) not in cls._NAMES:
                raise ValueError(f"fault {item!r} not understood; give name=value with a name among "
                                 f"{', '.join(cls._NAMES)}")
            name = cls._NAMES[match.group(1)]
            if name in values:
                raise ValueError(f"fault {match.group(1)} given twice")
            try:
                values[name] = float(match.group(2))
            except ValueError:
                raise ValueError(f"fault {match.group(1)} must be a number, got {match.group(2)!r}") from None
        return cls(**values)

    def disconnected(self, time_s: float) -> bool:
        start = self.disconnect_at_s
        return start is not None and start <= time_s < start + self.disconnect_s

    def stalled(self, time_s: float) -> bool:
        start = self.stall_at_s
        return start is not None and start <= time_s < start + self.stall_s


def open_pty() -> tuple[int, int, str]:
    """A pseudo-terminal pair in raw mode: (master fd, slave fd, slave path). The controller opens
    the slave path as it would open ``/dev/ttyUSB0``; the plant side keeps the slave fd open so that
    the line stays up while the controller process starts or restarts."""
    master, slave = os.openpty()
    tty.setraw(slave)
    tty.setraw(master)
    os.set_blocking(master, False)
    return master, slave, os.ttyname(slave)


class EmulatedLine:
    """The plant's end of the line: byte time, extra delay and faults on a file descriptor.

    ``send`` takes a whole frame; ``poll`` returns the received bytes whose time has come. With
    ``emulate_timing`` False (lockstep), bytes go and come at once. ``flight_time_s`` set by the
    plant decides the disconnection window. Counts what it injects and what overflowed in ``counts``.
    """

    def __init__(self, fd: int, baud: int, faults: Faults, seed: int = 0, emulate_timing: bool = True):
        if baud <= 0:
            raise ValueError(f"baud must be positive, got {baud}")
        self.fd, self.baud, self.faults = fd, baud, faults
        self.emulate_timing = emulate_timing
        self.rng = np.random.default_rng(seed)
        self.flight_time_s = 0.0
        self._out: deque[tuple[float, bytes]] = deque()  # (write at, bytes)
        self._in: deque[tuple[float, bytes]] = deque()  # (hand over at, bytes)
        self._tx_busy_until = self._rx_busy_until = 0.0
        self.counts = {"dropped": 0, "corrupted": 0, "disconnected": 0, "overflowed": 0}

    def _fault(self, data: bytes) -> bytes | None:
        """The frame as the line delivers it, or None where the line loses it."""
        if self.faults.disconnected(self.flight_time_s):
            self.counts["disconnected"] += 1
            return None
        if self.faults.drop and self.rng.random() < self.faults.drop:
            self.counts["dropped"] += 1
            return None
        if self.faults.corrupt and self.rng.random() < self.faults.corrupt:
            self.counts["corrupted"] += 1
            b = bytearray(data)
            b[int(self.rng.integers(len(b)))] ^= int(self.rng.integers(1, 256))
            return bytes(b)
        return data

    def _arrival(self, now: float, n_bytes: int, busy_until: float) -> float:
        if not self.emulate_timing:
            return now
        return max(now, busy_until) + byte_time_s(n_bytes, self.baud)

    def send(self, data: bytes, now: float) -> bool:
        """Queue a frame; False where the line lost or damaged it (a fault)."""
        delivered = self._fault(data)
        if delivered is None:
            return False
        self._queue(delivered, now, self.faults.delay_ms / 1000.0 * self.emulate_timing)
        return delivered is data

    def send_raw(self, data: bytes, now: float) -> None:
        """Queue bytes that no fault touches (heartbeats before the flight starts)."""
        self._queue(data, now, 0.0)

    def _queue(self, data: bytes, now: float, extra_delay_s: float) -> None:
        """Bytes go out once their last bit would have crossed the wire, plus ``extra_delay_s``."""
        done = self._tx_busy_until = self._arrival(now, len(data), self._tx_busy_until)
        self._out.append((done + extra_delay_s, data))
        self.pump(now)

    def pump(self, now: float) -> None:
        """Write the queued frames whose time has come."""
        while self._out and self._out[0][0] <= now:
            _, data = self._out.popleft()
            try:
                written = os.write(self.fd, data)
            except BlockingIOError:
                written = 0
            if written < len(data):
                # The receiver's buffer is full (a stalled reader): as on a UART, the rest is lost.
                self.counts["overflowed"] += 1

    def next_event_s(self) -> float | None:
        """The earliest time something queued is due, or None."""
        times = [q[0][0] for q in (self._out, self._in) if q]
        return min(times) if times else None

    def read_into_queue(self, now: float, frame_bytes: int = 0) -> None:
        """Take what the device holds; each chunk gets the time its last byte would arrive."""
        while True:
            try:
                data = os.read(self.fd, 4096)
            except (BlockingIOError, OSError):
                return
            if not data:
                return
            delivered = self._fault(data) if frame_bytes and len(data) >= frame_bytes else data
            if delivered is None:
                continue
            done = self._arrival(now, len(delivered), self._rx_busy_until)
            self._rx_busy_until = done
            self._in.append((done + self.faults.delay_ms / 1000.0 * self.emulate_timing, delivered))

    def poll(self, now: float, frame_bytes: int = 0) -> bytes:
        """Bytes received whose time has come; chunks of at least ``frame_bytes`` (a whole command)
        pass through the fault injection."""
        self.pump(now)
        self.read_into_queue(now, frame_bytes)
        out = []
        while self._in and self._in[0][0] <= now:
            out.append(self._in.popleft()[1])
        return b"".join(out)


__all__ = ["BITS_PER_BYTE", "EmulatedLine", "Faults", "byte_time_s", "open_pty"]
