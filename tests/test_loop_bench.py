"""The loop bench: the MAVLink mapping, the line's byte time and faults, the failsafe, and whole
flights with the controller in its own process over a pseudo-terminal."""

import json
import math
import os
import select
import subprocess
import sys
import time

import numpy as np
import pytest

pytest.importorskip("pymavlink")
pytest.importorskip("serial")

from jsbsim_env.bench.link import EmulatedLine, Faults, byte_time_s, open_pty
from jsbsim_env.bench.plant import HOLD, NETWORK, PID, BenchConfig, Failsafe, bench_route, run_bench
from jsbsim_env.bench.wire import (
    FrameAssembler,
    WireRounded,
    decode_command,
    encode_command,
    encode_state,
    is_crc_error,
    new_link,
    wire_command,
    wire_state,
)
from jsbsim_env.control.pid import PIDAttitudeController
from jsbsim_env.missions import fly_route

MEASUREMENT = np.array([10012.5, 0.031, -0.017, 0.002, -0.004, 0.011, 10.23, 0.052, -0.006, 0.01, -0.02, 0.003, 0.41])
SETPOINT = np.array([0.05, 0.012, 10.0])


def _parse(data: bytes):
    return new_link(9).parse_buffer(data) or []


def test_state_and_command_cross_the_line_to_float32_precision():
    m, sp = wire_state(MEASUREMENT, SETPOINT)
    np.testing.assert_allclose(m, MEASUREMENT, rtol=2e-7, atol=1e-9)
    np.testing.assert_allclose(sp, SETPOINT, rtol=2e-7, atol=1e-8)
    command = np.array([3.5, -12.25, 1.0, 0.4125])
    np.testing.assert_allclose(wire_command(command), command, rtol=1e-7)
    # The decode of a parsed message is what wire_command gives.
    (message,) = _parse(encode_command(new_link(2), 440_000, command))
    time_us, decoded = decode_command(message)
    assert time_us == 440_000 and np.array_equal(decoded, wire_command(command))


def test_a_burst_with_a_message_lost_or_corrupted_is_skipped_and_counted():
    tx = new_link(1)
    bursts = [encode_state(tx, k * 40_000, MEASUREMENT, SETPOINT) for k in range(3)]
    damaged = bytearray(bursts[1])
    damaged[20] ^= 0xFF  # inside the first message's payload: its CRC fails
    assembler = FrameAssembler()
    messages = _parse(bursts[0] + bytes(damaged) + b"\x00\xfd\x13noise" + bursts[2])
    crc = sum(is_crc_error(msg) for msg in messages)
    frames = [f for f in (assembler.feed(msg) for msg in messages if msg.get_type() != "BAD_DATA") if f is not None]
    assert crc == 1
    assert next(f.time_us for f in frames) == 0
    assert 40_000 not in [f.time_us for f in frames]
    assert assembler.incomplete >= 1


def test_faults_parse_and_refuse_what_they_do_not_know():
    f = Faults.parse("drop=0.05,corrupt=0.01,delay_ms=30,disconnect_at=20")
    assert (f.drop, f.corrupt, f.delay_ms, f.disconnect_at_s, f.disconnect_s) == (0.05, 0.01, 30.0, 20.0, 5.0)
    assert f.disconnected(22.0) and not f.disconnected(25.0)
    assert Faults.parse("") == Faults()
    with pytest.raises(ValueError, match="'lose=0.1' not understood"):
        Faults.parse("lose=0.1")
    with pytest.raises(ValueError, match="probability"):
        Faults.parse("drop=2")


def test_failsafe_holds_then_hands_to_the_pid_and_back():
    fs = Failsafe(timeout_frames=3, recover_frames=5)
    misses = [fs.decide(False, 0.04 * k) for k in range(6)]
    assert misses == [HOLD, HOLD, HOLD, PID, PID, PID]
    assert fs.events == [{"time_s": 0.04 * 3, "event": "pid_takeover"}]
    back = [fs.decide(True, 1.0 + 0.04 * k) for k in range(6)]
    assert back == [PID, PID, PID, PID, NETWORK, NETWORK]
    assert fs.events[-1]["event"] == "network_resumed" and fs.takeovers == 1


def test_the_line_takes_ten_bits_a_byte():
    master, slave, _ = open_pty()
    try:
        line = EmulatedLine(master, baud=9600, faults=Faults())
        data = bytes(range(96))  # 96 bytes at 9600 baud: 100 ms on the wire
        t0 = time.perf_counter()
        line.send(data, t0)
        assert select.select([slave], [], [], 0.05)[0] == []  # nothing has arrived half-way
        while line.next_event_s() is not None:
            line.pump(time.perf_counter())
            time.sleep(0.002)
        assert time.perf_counter() - t0 >= byte_time_s(96, 9600) - 1e-3
        assert os.read(slave, 200) == data
    finally:
        os.close(master)
        os.close(slave)


def test_lockstep_reproduces_the_in_process_flight_bit_for_bit():
    result = run_bench(BenchConfig(mode="lockstep", controller="policy", duration_s=4.0, seed=3))
    reference = fly_route(WireRounded(_policy()), bench_route(4.0, 3))
    s = result.summary
    assert s["frames"] == 100 and s["missed_deadlines"] == 0 and s["dropped_frames"] == 0
    assert s["frames_by_source"]["network"] == 100
    assert np.array_equal(result.mission.arrays["command"], reference.arrays["command"])
    assert np.array_equal(result.mission.arrays["pitch_rad"], reference.arrays["pitch_rad"])


def _policy():
    from jsbsim_env.control.policy import PolicyRuntime

    return PolicyRuntime(None, backend="onnx")


def test_a_disconnect_hands_control_to_the_pid_within_the_timeout_and_back():
    cfg = BenchConfig(mode="lockstep", controller="pid", duration_s=5.0,
                      faults=Faults.parse("disconnect_at=1,disconnect_s=1.5"))
    s = run_bench(cfg).summary
    events = s["failsafe_events"]
    assert [e["event"] for e in events] == ["pid_takeover", "network_resumed"]
    assert 1.0 < events[0]["time_s"] <= 1.0 + 3 * 0.04 + 1e-9  # the stated timeout: 3 frames
    assert 2.5 <= events[1]["time_s"] <= 2.5 + 6 * 0.04
    assert s["ended_early"] is None and s["failsafe_takeovers"] == 1
    assert s["line_faults_injected"]["disconnected"] > 0 and s["dropped_frames"] >= 37


def test_dropped_frames_are_counted_and_the_flight_goes_on():
    cfg = BenchConfig(mode="lockstep", controller="pid", duration_s=4.0, faults=Faults.parse("drop=0.1"), seed=1)
    s = run_bench(cfg).summary
    injected = s["line_faults_injected"]["dropped"]
    assert injected > 0 and s["dropped_frames"] == injected == s["missed_deadlines"]
    assert s["ended_early"] is None


def test_real_time_answers_arrive_after_the_wire_time_and_within_the_frame():
    s = run_bench(BenchConfig(mode="realtime", controller="pid", duration_s=2.0)).summary
    burst = len(encode_state(new_link(1), 0, MEASUREMENT, SETPOINT))
    wire_ms = 1000.0 * byte_time_s(burst + 44, 115_200)  # state burst out, command back
    assert s["frames"] == 50
    assert s["latency_ms"]["p50"] >= wire_ms - 0.5
    for key in ("missed_deadlines", "latency_ms", "dropped_frames", "crc_errors", "failsafe_takeovers",
                "ended_early", "tracking_rmse", "controller_compute_ms"):
        assert key in s
    assert math.isfinite(s["tracking_rmse"]["pitch_deg"])


def test_the_controller_node_names_a_device_it_cannot_open(tmp_path):
    out = subprocess.run([sys.executable, "-m", "jsbsim_env.bench.node", "--device", str(tmp_path / "ttyNONE"),
                          "--controller", "pid"], check=False, capture_output=True, text=True, timeout=120)
    assert out.returncode == 2 and "cannot open serial device" in out.stderr


def test_loop_bench_refuses_a_real_time_fault_in_lockstep(tmp_path):
    out = subprocess.run([sys.executable, "scripts/loop_bench.py", "--mode", "lockstep", "--faults", "delay_ms=30",
                          "--out", str(tmp_path)], check=False, capture_output=True, text=True, timeout=120,
                         cwd=os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    assert out.returncode == 2 and "real-time faults" in out.stderr


def test_loop_bench_writes_its_summary(tmp_path):
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    out = subprocess.run([sys.executable, "scripts/loop_bench.py", "--mode", "lockstep", "--controller", "pid",
                          "--duration", "2", "--json", "--out", str(tmp_path)], check=False, capture_output=True,
                         text=True, timeout=300, cwd=root)
    assert out.returncode == 0, out.stderr
    summary = json.loads(out.stdout)
    assert summary == json.loads((tmp_path / "summary.json").read_text())
    assert summary["frames"] == 50 and summary["in_process"]["rmse_ratio"]["pitch_deg"] == pytest.approx(1.0, abs=1e-3)
    assert (tmp_path / "loop_bench.png").stat().st_size > 0


class _Line:
    """Stands in for the line: hands over the given bytes once."""

    def __init__(self, data: bytes):
        self.data = data

    def poll(self, now, frame_bytes=0):
        data, self.data = self.data, b""
        return data


def test_the_plant_refuses_a_well_formed_command_no_actuator_takes():
    from jsbsim_env.bench.plant import Plant

    plant = Plant(BenchConfig(mode="lockstep"))
    link = new_link(2)
    data = (encode_command(link, 0, [90.0, 0.0, 0.0, 0.5]) + encode_command(link, 40_000, [math.nan, 0, 0, 0.5])
            + encode_command(link, 80_000, [5.0, -3.0, 1.0, 0.45]) + b"\xfd\x00garbage")
    plant._receive(_Line(data), 1.0)
    assert plant.counts["bad_commands"] == 2
    assert list(plant.answers) == [80_000] and np.allclose(plant.answers[80_000][1], [5.0, -3.0, 1.0, 0.45])


class _Port:
    def __init__(self):
        self.written = []

    def write(self, data):
        self.written.append(data)


def test_the_controller_node_answers_no_state_that_is_not_finite():
    from jsbsim_env.bench.node import ControllerNode

    node = ControllerNode(_Port(), PIDAttitudeController())
    tx = new_link(1)
    bad = MEASUREMENT.copy()
    bad[2] = math.nan
    node.handle(encode_state(tx, 0, bad, SETPOINT))
    node.handle(encode_state(tx, 40_000, MEASUREMENT, SETPOINT))
    assert node.counts["bad_frames"] == 1 and node.counts["answered"] == 1 and len(node.port.written) == 1
