"""The flight computer's side of the loop bench: the aircraft model, the TECS + L1 autopilot, the
frame clock, the failsafe, and the measurements of the loop.

Each control frame (25 Hz) the plant flies the previous frame's command, takes the INS
measurement and the autopilot's demands (``missions.RouteFlight``: the same code as the
in-process route flight), sends them to the controller process over the serial line, and waits
for the answer:

- **lockstep**: it waits for each answer (or learns that the line lost the frame), so the flight
  is deterministic and as fast as the CPU allows;
- **realtime**: a frame clock ticks every 40 ms of wall time; an answer that has not arrived by the
  next tick is a missed deadline.

The failsafe, in the spirit of PX4's ``COM_OF_LOSS_T`` and ArduPilot's ``FS_SHORT_TIMEOUT``: a
missing answer holds the last command for up to ``timeout_frames`` frames (3 = 120 ms); after
that the plant's own gain-scheduled PID flies, until the controller has answered on time for
``recover_frames`` frames in a row. Every hand-over is logged with its flight time.

A controller process that dies during the flight (killed, crashed) is a lost controller, not a
failed bench: the plant stops waiting for it, the failsafe PID flies on to the end of the flight,
and the summary records when the loss was noticed (``controller_lost_at_s``) and the process's exit
code. Only a controller that never comes up (no first heartbeat) ends the bench with an error.

In real time a frame's answer counts only if the line carries it in time, so ``BenchConfig``
refuses a line that cannot: the frame's state burst and command at ``baud`` plus ``delay_ms`` each
way must fit in the failsafe's hold time, ``max(1, timeout_frames)`` frames (120 ms at the
defaults: ``delay_ms`` up to 50.8 ms at 115,200 baud). Past it every answer is late and the PID
flies the whole flight (``delay_ms=30`` already shows that), while the start waits on heartbeats
that come as late.
"""

from __future__ import annotations

import json
import math
import os
import select
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from aircraft import AIRCRAFT_NAME, load_aircraft
from jsbsim_env.bench.link import BITS_PER_BYTE, EmulatedLine, Faults, open_pty
from jsbsim_env.bench.node import percentiles_ms
from jsbsim_env.bench.wire import (
    CONTROLLER_SYSTEM_ID,
    PLANT_SYSTEM_ID,
    decode_command,
    encode_command,
    encode_state,
    heartbeat,
    is_crc_error,
    new_link,
)
from jsbsim_env.control.factory import CONTROLLER_NAMES
from jsbsim_env.control.pid import PIDAttitudeController
from jsbsim_env.missions import MissionResult, RouteConfig, RouteFlight

NETWORK, HOLD, PID = 0, 1, 2
SOURCE_NAMES = ("network", "hold", "pid")
COMMAND_BYTES = 40  # a HIL_ACTUATOR_CONTROLS frame is 44 bytes; shorter chunks are heartbeats or pieces
MAX_DURATION_S = 3600.0  # an hour of flight: the route's turbulence for it is made up front (a day: 2.7 GB)
# The shortest flight whose RMSE means something: 50 frames at 25 Hz, many times the 40-120 ms the
# controller's commands take to act, so that the errors it reports are the controller's.
MIN_DURATION_S = 2.0


def frame_line_bytes() -> int:
    """Bytes a frame puts on the line: its state burst and the command answering it, every field
    non-zero (MAVLink v2 trims trailing zeros, so this is the most a frame of the bench takes)."""
    state = np.linspace(0.1, 1.3, 13) + np.array([10_000.0] + [0.0] * 5 + [10.0] + [0.0] * 6)
    burst = encode_state(new_link(PLANT_SYSTEM_ID), 40_000, state, [0.1, 0.1, 10.5], 1.0, 10.0, 0.1)
    return len(burst) + len(encode_command(new_link(CONTROLLER_SYSTEM_ID), 40_000, [1.0, -1.0, 0.5, 0.4]))


def bench_route(duration_s: float = 60.0, seed: int = 0, aircraft=None) -> RouteConfig:
    """The bench's flight: the 10 km route's conditions (report Figs. 11-14) with turbulence from
    the first leg on, so that a short flight is the turbulent leg; another aircraft flies it at the
    middle of its envelope (``Aircraft.altitude_like_m``) at its reference EAS."""
    flown = load_aircraft(aircraft)
    return RouteConfig(aircraft=flown.spec, altitude_m=flown.altitude_like_m(10_000.0), eas_mps=flown.reference_eas_mps,
                       duration_s=duration_s, turbulence_legs=tuple(range(64)), seed=seed)


class Failsafe:
    """Who flies each frame: the network's fresh command, the last one held, or the plant's PID."""

    def __init__(self, timeout_frames: int = 3, recover_frames: int = 5):
        if timeout_frames < 0 or recover_frames < 1:
            raise ValueError("timeout_frames must be >= 0 and recover_frames >= 1")
        self.timeout_frames, self.recover_frames = timeout_frames, recover_frames
        self.pid_in_charge = False
        self.missed_in_row = 0
        self.healthy_in_row = 0
        self.events: list[dict] = []

    def decide(self, fresh: bool, time_s: float) -> int:
        """The source of this frame's command given whether the network's answer came in time."""
        if fresh:
            self.missed_in_row = 0
            self.healthy_in_row += 1
            if self.pid_in_charge and self.healthy_in_row >= self.recover_frames:
                self.pid_in_charge = False
                self.events.append({"time_s": time_s, "event": "network_resumed"})
            return PID if self.pid_in_charge else NETWORK
        self.healthy_in_row = 0
        self.missed_in_row += 1
        if not self.pid_in_charge and self.missed_in_row > self.timeout_frames:
            self.pid_in_charge = True
            self.events.append({"time_s": time_s, "event": "pid_takeover"})
        return PID if self.pid_in_charge else HOLD

    @property
    def takeovers(self) -> int:
        return sum(e["event"] == "pid_takeover" for e in self.events)


@dataclass
class BenchConfig:
    """One bench flight. ``device`` None: a pseudo-terminal pair and a controller process started
    here; a path: a real port, with the controller process started by the user elsewhere."""

    mode: str = "realtime"  # or "lockstep"
    controller: str = "policy"  # or "pid"
    policy: str | None = None
    aircraft: str = AIRCRAFT_NAME  # the aircraft flown (``aircraft.load_aircraft``)
    transfer: bool = False  # fly a policy on an aircraft it was not trained on
    duration_s: float = 60.0
    baud: int = 115_200
    faults: Faults = field(default_factory=Faults)
    device: str | None = None
    seed: int = 0
    rate_hz: float = 25.0
    timeout_frames: int = 3
    recover_frames: int = 5
    lockstep_wait_s: float = 2.0  # lockstep: an answer not here after this long (wall time) was lost
    start_timeout_s: float = 120.0  # the controller process's first heartbeat, wall time

    def __post_init__(self):
        if self.mode not in ("realtime", "lockstep"):
            raise ValueError(f"mode must be 'realtime' or 'lockstep', got {self.mode!r}")
        if self.controller not in CONTROLLER_NAMES:
            raise ValueError(f"controller must be one of {', '.join(CONTROLLER_NAMES)}, got {self.controller!r}")
        if not MIN_DURATION_S <= self.duration_s <= MAX_DURATION_S:  # NaN fails too
            raise ValueError(f"duration must be {MIN_DURATION_S:g} to {MAX_DURATION_S:g} s (the shortest flight whose "
                             f"RMSE means something, the longest whose turbulence is made up front), "
                             f"got {self.duration_s:g} s")
        for name, low in (("baud", 1), ("seed", 0), ("timeout_frames", 0), ("recover_frames", 1)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
                raise ValueError(f"{name} must be a whole number >= {low}, got {value!r}")
        for name in ("rate_hz", "lockstep_wait_s", "start_timeout_s"):
            if not 0.0 < getattr(self, name) < math.inf:
                raise ValueError(f"{name} must be positive and finite, got {getattr(self, name)}")
        f = self.faults
        if self.mode == "lockstep" and (f.delay_ms or f.stall_at_s is not None):
            raise ValueError("delay_ms and stall are real-time faults: lockstep waits for every answer")
        for name, start in (("disconnect_at", f.disconnect_at_s), ("stall_at", f.stall_at_s)):
            if start is not None and start >= self.duration_s:
                raise ValueError(f"fault {name}={start:g} is at or after the flight's end ({self.duration_s:g} s): "
                                 "it would never happen")
        if self.mode == "realtime":
            self._check_line_time()

    @property
    def hold_s(self) -> float:
        """How long the failsafe waits on the controller before the PID flies: ``timeout_frames``
        frames, at least one."""
        return max(1, self.timeout_frames) / self.rate_hz

    def _check_line_time(self) -> None:
        """Refuse a line on which no answer can arrive within the hold time (module docstring)."""
        wire_s = frame_line_bytes() * BITS_PER_BYTE / self.baud
        round_trip_s = wire_s + 2.0 * self.faults.delay_ms / 1000.0
        if round_trip_s <= self.hold_s:
            return
        frames = max(1, self.timeout_frames)
        budget = (f"a frame's round trip (its state burst and command at {self.baud} baud, {wire_s * 1000:.1f} ms, "
                  f"plus delay_ms each way) must fit in the failsafe's hold time, {frames} frame"
                  f"{'s' if frames > 1 else ''} of {1000 / self.rate_hz:g} ms = {self.hold_s * 1000:g} ms "
                  "(--timeout-frames)")
        if wire_s > self.hold_s:
            raise ValueError(f"baud {self.baud} is too slow for real time: {budget}")
        most = (self.hold_s - wire_s) / 2.0 * 1000.0
        raise ValueError(f"fault delay_ms={self.faults.delay_ms:g} is more than the line can carry in time: {budget}; "
                         f"the most delay_ms is {math.floor(most * 10) / 10:g}")


@dataclass
class BenchResult:
    summary: dict
    frames: dict[str, np.ndarray]  # per frame: time_s, latency_ms, fresh, source, tick_late_ms
    mission: MissionResult


def child_python_env() -> dict[str, str]:
    """The environment of a child Python process that must import the very modules this process
    imported (the same ``jsbsim_env``, the same ``aircraft``): this process's ``sys.path``, as
    absolute folders, on ``PYTHONPATH``. Run the child in a folder without Python packages too
    (``_ControllerProcess`` runs it in its temporary folder): ``python -m`` puts the current
    folder first on the child's path, ahead of ``PYTHONPATH``, and a checkout there would be
    imported in place of what this process imported."""
    path = [os.path.abspath(entry or os.curdir) for entry in sys.path]
    return {**os.environ, "PYTHONPATH": os.pathsep.join(dict.fromkeys(path)), "OMP_NUM_THREADS": "1"}


class _ControllerProcess:
    """The controller node in a child process on the pty's slave side, importing the package from
    where this process imported it (``child_python_env``), run in ``stats_path``'s folder."""

    def __init__(self, cfg: BenchConfig, device: str, stats_path: Path):
        stats_path = stats_path.resolve()
        cmd = [sys.executable, "-m", "jsbsim_env.bench.node", "--device", device, "--baud", str(cfg.baud),
               "--controller", cfg.controller, "--rate-hz", str(cfg.rate_hz), "--stats", str(stats_path)]
        if cfg.policy:
            cmd += ["--policy", str(Path(cfg.policy).resolve())]  # the child runs in another folder
        cmd += ["--aircraft", load_aircraft(cfg.aircraft).spec] + (["--transfer"] if cfg.transfer else [])
        f = cfg.faults
        if f.stall_at_s is not None:
            cmd += ["--faults", f"stall_at={f.stall_at_s},stall_s={f.stall_s}"]
        self.stats_path = stats_path
        self.stderr = tempfile.TemporaryFile()  # noqa: SIM115 - open while the process lives
        self.proc = subprocess.Popen(cmd, stderr=self.stderr, env=child_python_env(), cwd=stats_path.parent)

    def alive(self) -> bool:
        return self.proc.poll() is None

    def stderr_tail(self, chars: int = 2000) -> str:
        self.stderr.seek(0)
        return self.stderr.read().decode(errors="replace")[-chars:]

    def check_alive(self) -> None:
        """Raise ``RuntimeError`` with the end of its stderr where the process has exited (before
        the flight: a controller that never came up)."""
        if not self.alive():
            raise RuntimeError(f"the controller process exited with code {self.proc.returncode}:\n"
                               f"{self.stderr_tail()}")

    def stop(self) -> dict:
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.stderr.close()
        try:
            return json.loads(self.stats_path.read_text())
        except (OSError, ValueError):
            return {}


class Plant:
    """Runs one bench flight (``run``)."""

    def __init__(self, cfg: BenchConfig):
        self.cfg = cfg
        flown = load_aircraft(cfg.aircraft)
        self.command_low, self.command_high = np.array(flown.command_low), np.array(flown.command_high)
        self.link = new_link(PLANT_SYSTEM_ID)
        self.frame_s = 1.0 / cfg.rate_hz
        self.answers: dict[int, tuple[float, np.ndarray]] = {}  # frame time (us) -> (arrival, command)
        self.counts = {"crc_errors": 0, "bad_bytes": 0, "bad_commands": 0, "heartbeats": 0, "late_answers": 0}
        self.controller_seen = False
        self.process: _ControllerProcess | None = None  # the controller process this plant started (pty only)
        # A controller process that died during the flight: when it was noticed, its exit code, its last words.
        self.controller_lost: dict | None = None

    # ------------------------------------------------------------------ receiving
    def _receive(self, line: EmulatedLine, now: float) -> None:
        data = line.poll(now, COMMAND_BYTES)
        if not data:
            return
        for message in self.link.parse_buffer(data) or []:
            kind = message.get_type()
            if kind == "BAD_DATA":
                self.counts["crc_errors" if is_crc_error(message) else "bad_bytes"] += 1
            elif kind == "HEARTBEAT":
                self.counts["heartbeats"] += 1
                self.controller_seen = True
            elif kind == "HIL_ACTUATOR_CONTROLS":
                time_us, command = decode_command(message)
                # A well-formed message can still carry a command no actuator takes (NaN, out of
                # range): it is counted and treated as no answer.
                if np.all(command >= self.command_low - 1e-6) and np.all(command <= self.command_high + 1e-6):
                    self.answers[time_us] = (now, np.clip(command, self.command_low, self.command_high))
                else:
                    self.counts["bad_commands"] += 1

    def _wait(self, fd: int, line: EmulatedLine, until: float) -> None:
        """Receive until wall time ``until`` (real time) or until something arrives."""
        now = time.perf_counter()
        due = line.next_event_s()
        wake = min(until, due) if due is not None else until
        if wake > now:
            select.select([fd], [], [], wake - now)
        self._receive(line, time.perf_counter())

    # ------------------------------------------------------------------ the flight
    def run(self, progress=None) -> BenchResult:
        cfg = self.cfg
        stats_dir = tempfile.TemporaryDirectory()
        process = None
        port = None
        if cfg.device is None:
            master, slave, path = open_pty()
            fd = master
            process = self.process = _ControllerProcess(cfg, path, Path(stats_dir.name) / "controller.json")
        else:
            import serial

            try:
                port = serial.Serial(cfg.device, baudrate=cfg.baud, timeout=0)
            except (serial.SerialException, OSError) as exc:
                raise RuntimeError(f"cannot open serial device {cfg.device}: {exc}") from exc
            fd, slave = port.fileno(), None
            os.set_blocking(fd, False)
        line = EmulatedLine(fd, cfg.baud, cfg.faults, seed=cfg.seed,
                            emulate_timing=cfg.mode == "realtime" and cfg.device is None)
        try:
            self._await_controller(fd, line, process)
            result = self._fly(fd, line, process, progress)
        finally:
            controller_stats = process.stop() if process is not None else {}
            if cfg.device is None:
                os.close(master)
                os.close(slave)
            elif port is not None:
                port.close()
            stats_dir.cleanup()
        return self._summarise(*result, line, controller_stats)

    def _await_controller(self, fd: int, line: EmulatedLine, process) -> None:
        """Heartbeats until the controller's first one arrives (its process imports and loads first)."""
        deadline = time.perf_counter() + self.cfg.start_timeout_s
        next_heartbeat = 0.0
        while not self.controller_seen:
            now = time.perf_counter()
            if now > deadline:
                raise RuntimeError(f"no heartbeat from the controller within {self.cfg.start_timeout_s} s")
            if process is not None:
                process.check_alive()
            if now >= next_heartbeat:
                line.send_raw(heartbeat(self.link, plant=True), now)
                next_heartbeat = now + 1.0
            self._wait(fd, line, now + 0.1)

    def _fly(self, fd: int, line: EmulatedLine, process, progress):
        cfg = self.cfg
        flight = RouteFlight(bench_route(cfg.duration_s, cfg.seed, cfg.aircraft))
        pid = PIDAttitudeController(aircraft=cfg.aircraft)  # the failsafe: the aircraft's own PID
        failsafe = Failsafe(cfg.timeout_frames, cfg.recover_frames)
        n = flight.steps
        log = {"time_s": np.full(n, np.nan), "latency_ms": np.full(n, np.nan), "fresh": np.zeros(n, bool),
               "source": np.full(n, -1), "tick_late_ms": np.full(n, np.nan)}
        realtime = cfg.mode == "realtime"
        sent_times = np.full(n, np.nan)
        last_network = None
        start = time.perf_counter()
        k = 0
        measurement, setpoint = flight.demand()
        while True:
            tick = start + k * self.frame_s
            time_us = round(k * self.frame_s * 1e6)
            line.flight_time_s = flight_time = k * self.frame_s
            nav = flight.navigation  # as the step's demands were computed from
            burst = encode_state(self.link, time_us, measurement, setpoint, nav.heading_rad,
                                 math.hypot(nav.v_north_mps, nav.v_east_mps), -nav.v_down_mps)
            if k % round(cfg.rate_hz) == 0:
                burst += heartbeat(self.link, plant=True)
            while realtime and time.perf_counter() < tick:  # the frame clock; receive meanwhile
                self._wait(fd, line, tick)
            sent_at = sent_times[k] = time.perf_counter()
            log["tick_late_ms"][k] = (sent_at - tick) * 1000.0 if realtime else 0.0
            delivered = line.send(burst, sent_at)
            # Wait for this frame's answer: until the next tick, or (lockstep) until it comes.
            if realtime:
                deadline = tick + self.frame_s
                while time_us not in self.answers and time.perf_counter() < deadline:
                    self._wait(fd, line, deadline)
            else:
                give_up = time.perf_counter() + cfg.lockstep_wait_s
                errors_before = self.counts["crc_errors"] + self.counts["bad_bytes"]
                lost_before = sum(line.counts.values())
                while delivered and time_us not in self.answers and self.controller_lost is None:
                    if process is not None and not process.alive():
                        break  # the controller process died: nothing will answer (handled below)
                    if (self.counts["crc_errors"] + self.counts["bad_bytes"] > errors_before
                            or sum(line.counts.values()) > lost_before or time.perf_counter() > give_up):
                        break  # the answer was lost on the line, or the controller is silent
                    self._wait(fd, line, time.perf_counter() + 0.05)
            if process is not None and self.controller_lost is None and not process.alive():
                self._lose_controller(process, flight_time, failsafe)
            # Answers to earlier frames came after their deadline: late, and of no use now (their
            # latency still counts).
            for t, (arrived, _) in self.answers.items():
                j = round(t / (self.frame_s * 1e6))
                if t < time_us and 0 <= j < k and math.isnan(log["latency_ms"][j]):
                    self.counts["late_answers"] += 1
                    log["latency_ms"][j] = (arrived - sent_times[j]) * 1000.0
            answer = self.answers.pop(time_us, None)
            self.answers = {t: a for t, a in self.answers.items() if t > time_us}
            fresh = answer is not None
            if fresh:
                log["latency_ms"][k] = (answer[0] - sent_at) * 1000.0
            source = failsafe.decide(fresh, flight_time)
            if source == HOLD and last_network is None:
                source = PID  # nothing to hold yet: the PID flies until the first answer
            if source == NETWORK:
                command = last_network = answer[1]
            elif source == HOLD:
                command = last_network
            else:
                if k == 0 or log["source"][k - 1] != PID:
                    pid.reset()  # from its trim: the integrators of a controller that was not flying mean nothing
                command = pid.update(self.frame_s, measurement, setpoint)
            log["time_s"][k], log["fresh"][k], log["source"][k] = flight_time, fresh, source
            flight.advance(command)
            k += 1
            if progress is not None and k % round(cfg.rate_hz) == 0:
                progress(k / n)
            if flight.done:
                break
            measurement, setpoint = flight.demand()
        wall_s = time.perf_counter() - start
        frames = {key: v[:k] for key, v in log.items()}
        return frames, flight.result(), failsafe, wall_s

    def _lose_controller(self, process: _ControllerProcess, time_s: float, failsafe: Failsafe) -> None:
        """The controller process died during the flight: no answer will come, so the frames no
        longer wait for one (lockstep) and the failsafe's PID takes over after its timeout, as for
        a silent controller, to the end of the flight."""
        self.controller_lost = {"time_s": time_s, "exit_code": process.proc.returncode,
                                "stderr_tail": process.stderr_tail(500)}
        failsafe.events.append({"time_s": time_s, "event": "controller_lost"})

    # ------------------------------------------------------------------ the figures
    def _summarise(self, frames: dict, mission: MissionResult, failsafe: Failsafe, wall_s: float,
                   line: EmulatedLine, controller: dict) -> BenchResult:
        cfg = self.cfg
        lost = self.controller_lost
        n = len(frames["time_s"])
        latency = frames["latency_ms"][np.isfinite(frames["latency_ms"])] / 1000.0
        answered = int(np.isfinite(frames["latency_ms"]).sum())  # on time or late
        metrics = mission.metrics() if n else {}
        summary = {
            "mode": cfg.mode, "controller": cfg.controller, "baud": cfg.baud, "rate_hz": cfg.rate_hz,
            "device": cfg.device or "pty", "faults": asdict(cfg.faults),
            "seed": cfg.seed, "duration_s": cfg.duration_s, "wall_s": wall_s,
            "frames": n,
            "missed_deadlines": int(n - frames["fresh"].sum()),
            "missed_fraction": float(1.0 - frames["fresh"].mean()) if n else None,
            "latency_ms": percentiles_ms(list(latency)),
            "latency_jitter_ms": float(np.std(latency) * 1000.0) if latency.size else None,
            "tick_late_ms": percentiles_ms(list(frames["tick_late_ms"][frames["tick_late_ms"] >= 0] / 1000.0)),
            "dropped_frames": n - answered,
            "late_answers": self.counts["late_answers"],
            "crc_errors": self.counts["crc_errors"] + int(controller.get("crc_errors", 0)),
            "crc_errors_at_plant": self.counts["crc_errors"],
            "crc_errors_at_controller": controller.get("crc_errors"),
            "bad_bytes": self.counts["bad_bytes"] + int(controller.get("bad_bytes", 0)),
            "bad_commands": self.counts["bad_commands"],
            "line_faults_injected": dict(line.counts),
            "failsafe_takeovers": failsafe.takeovers,
            "failsafe_events": failsafe.events,
            # A controller process that died during the flight (None: it lived to the end).
            "controller_lost_at_s": lost["time_s"] if lost else None,
            "controller_exit_code": lost["exit_code"] if lost else None,
            "frames_by_source": {name: int((frames["source"] == i).sum()) for i, name in enumerate(SOURCE_NAMES)},
            "ended_early": mission.ended_early,
            "controller_compute_ms": controller.get("compute_ms"),
            "controller_counts": {k: v for k, v in controller.items() if k != "compute_ms"},
            "tracking_rmse": {k[len("rmse_"):]: v for k, v in metrics.items() if k.startswith("rmse_")},
        }
        return BenchResult(summary, frames, mission)


def run_bench(cfg: BenchConfig, progress=None) -> BenchResult:
    """Fly one bench flight; see ``BenchConfig`` and the module docstring."""
    return Plant(cfg).run(progress)


def plot_bench(result: BenchResult, path: Path | str) -> None:
    """Latency per frame against the deadline, who flew, and the tracking errors."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    f, a = result.frames, result.mission.arrays
    fig, ax = plt.subplots(3, 1, figsize=(10, 8), sharex=True)
    frame_ms = 1000.0 / result.summary["rate_hz"]
    ax[0].plot(f["time_s"], f["latency_ms"], ".", ms=2, label="state sent -> command received")
    ax[0].axhline(frame_ms, color="r", lw=0.8, label=f"deadline ({frame_ms:.0f} ms)")
    ax[0].set_ylabel("latency, ms")
    ax[0].legend(loc="upper right", fontsize=8)
    ax[1].step(f["time_s"], f["source"], where="post")
    ax[1].set_yticks(range(len(SOURCE_NAMES)), SOURCE_NAMES)
    ax[1].set_ylabel("command from")
    t = a["time_s"]
    for name, err in (("roll", np.degrees(a["roll_rad"] - a["roll_cmd_rad"])),
                      ("pitch", np.degrees(a["pitch_rad"] - a["pitch_cmd_rad"])),
                      ("sideslip", np.degrees(a["beta_rad"]))):
        ax[2].plot(t, err, lw=0.8, label=name)
    ax[2].set_ylabel("error, deg")
    ax[2].set_xlabel("flight time, s")
    ax[2].legend(loc="upper right", fontsize=8)
    s = result.summary
    fig.suptitle(f"loop bench: {s['controller']}, {s['mode']}, {s['baud']} baud")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


__all__ = ["BenchConfig", "BenchResult", "Failsafe", "Plant", "bench_route", "plot_bench", "run_bench"]
