"""MAVLink v2 messages of the loop bench: what crosses the serial line, in which units.

Every control frame the flight computer (the plant side) sends one burst of five standard messages
(ATTITUDE, VFR_HUD, AOA_SSA, ACTUATOR_OUTPUT_STATUS, NAV_CONTROLLER_OUTPUT) and the attitude
controller answers with one HIL_ACTUATOR_CONTROLS; both send a HEARTBEAT once a second. pymavlink
packs them, numbers them and checks their CRC. The fields, units, axes and scaling are in one
table, in ``docs/loop_bench.md``; this module is that table in code.

Every float crosses as float32. ``wire_state`` and ``wire_command`` apply exactly the rounding a
round trip over the line applies, so an in-process run through them (``WireRounded``) is what the
lockstep bench must reproduce bit for bit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

try:
    from pymavlink.dialects.v20 import ardupilotmega as mavlink
except ImportError as exc:  # pragma: no cover - exercised only without the extra
    raise ImportError("the loop bench needs pymavlink and pyserial: pip install '.[bench]'") from exc

from jsbsim_env.control.base import AttitudeController

# Command scaling of HIL_ACTUATOR_CONTROLS.controls: surfaces in deg divided by these, throttle as is.
SURFACE_FULL_SCALE_DEG = (30.0, 30.0, 20.0)
PLANT_SYSTEM_ID, CONTROLLER_SYSTEM_ID = 1, 2
STATE_MESSAGES = ("ATTITUDE", "VFR_HUD", "AOA_SSA", "ACTUATOR_OUTPUT_STATUS", "NAV_CONTROLLER_OUTPUT")
_F32 = np.float32


def new_link(system_id: int) -> mavlink.MAVLink:
    """A MAVLink v2 endpoint (sequence numbers, CRC); parses garbage into BAD_DATA, never raises."""
    link = mavlink.MAVLink(None, srcSystem=system_id, srcComponent=1)
    link.robust_parsing = True
    return link


def pack(link: mavlink.MAVLink, message) -> bytes:
    """The message's bytes, numbered with the link's next sequence number (as ``MAVLink.send`` does)."""
    data = message.pack(link)
    link.seq = (link.seq + 1) % 256
    link.total_packets_sent += 1
    link.total_bytes_sent += len(data)
    return data


def is_crc_error(message) -> bool:
    return message.get_type() == "BAD_DATA" and "CRC" in str(getattr(message, "reason", ""))


@dataclass(frozen=True)
class StateFrame:
    """One control frame as the controller receives it."""

    time_us: int
    measurement: np.ndarray  # core.STATE_NAMES order
    setpoint: np.ndarray  # roll, pitch (rad), EAS (m/s)


def encode_state(link: mavlink.MAVLink, time_us: int, measurement, setpoint, heading_rad: float = 0.0,
                 groundspeed_mps: float = 0.0, climb_mps: float = 0.0) -> bytes:
    """The burst of one frame (the messages of the table above, in order)."""
    m, sp = [float(x) for x in measurement], [float(x) for x in setpoint]
    throttle_pct = round(min(max(m[12], 0.0), 1.0) * 100)
    messages = (
        link.attitude_encode(time_us // 1000, m[1], m[2], heading_rad, m[3], m[4], m[5]),
        link.vfr_hud_encode(m[6], groundspeed_mps, round(math.degrees(heading_rad)) % 360, throttle_pct,
                            m[0], climb_mps),
        link.aoa_ssa_encode(time_us, math.degrees(m[7]), math.degrees(m[8])),
        link.actuator_output_status_encode(time_us, 0b1111, [m[9], m[10], m[11], m[12]] + [0.0] * 28),
        link.nav_controller_output_encode(math.degrees(sp[0]), math.degrees(sp[1]), 0, 0, 0, 0.0,
                                          float(_F32(sp[2]) - _F32(m[6])), 0.0),
    )
    return b"".join(pack(link, msg) for msg in messages)


def _decoded_state(fields: dict) -> tuple[np.ndarray, np.ndarray]:
    """Measurement and setpoint from the (float32) fields of a burst, as the controller reads them."""
    att, hud, aoa, act, nav = (fields[name] for name in STATE_MESSAGES)
    f = [float(_F32(x)) for x in (hud.alt, att.roll, att.pitch, att.rollspeed, att.pitchspeed, att.yawspeed,
                                   hud.airspeed)]
    measurement = np.array(f + [math.radians(float(_F32(aoa.AOA))), math.radians(float(_F32(aoa.SSA)))]
                           + [float(_F32(x)) for x in act.actuator[:4]])
    eas_goal = float(_F32(hud.airspeed)) + float(_F32(nav.aspd_error))
    setpoint = np.array([math.radians(float(_F32(nav.nav_roll))), math.radians(float(_F32(nav.nav_pitch))), eas_goal])
    return measurement, setpoint


class FrameAssembler:
    """Collects the five messages of a burst into a ``StateFrame``; a burst with a message missing
    (lost or corrupted on the line) is counted in ``incomplete`` and skipped."""

    def __init__(self):
        self._fields: dict = {}
        self._time_us: int | None = None
        self.frames = 0
        self.incomplete = 0

    def feed(self, message) -> StateFrame | None:
        kind = message.get_type()
        if kind == "ATTITUDE":
            if self._fields:
                self.incomplete += 1
            self._fields, self._time_us = {"ATTITUDE": message}, int(message.time_boot_ms) * 1000
            return None
        if kind not in STATE_MESSAGES:
            return None
        if self._time_us is None:  # the burst's opening ATTITUDE was lost
            if kind == "NAV_CONTROLLER_OUTPUT":
                self.incomplete += 1
            return None
        if kind in ("AOA_SSA", "ACTUATOR_OUTPUT_STATUS") and int(message.time_usec) != self._time_us:
            self.incomplete += 1  # pieces of two different frames
            self._fields, self._time_us = {}, None
            return None
        self._fields[kind] = message
        if kind != "NAV_CONTROLLER_OUTPUT":
            return None
        fields, time_us = self._fields, self._time_us
        self._fields, self._time_us = {}, None
        if len(fields) != len(STATE_MESSAGES):
            self.incomplete += 1
            return None
        measurement, setpoint = _decoded_state(fields)
        self.frames += 1
        return StateFrame(time_us, measurement, setpoint)


def encode_command(link: mavlink.MAVLink, time_us: int, command) -> bytes:
    """HIL_ACTUATOR_CONTROLS for a physical command (aileron, elevator, rudder in deg, throttle)."""
    c = [float(x) for x in command]
    controls = [c[0] / SURFACE_FULL_SCALE_DEG[0], c[1] / SURFACE_FULL_SCALE_DEG[1], c[2] / SURFACE_FULL_SCALE_DEG[2],
                c[3]] + [0.0] * 12
    return pack(link, link.hil_actuator_controls_encode(time_us, controls, 0, 0))


def decode_command(message) -> tuple[int, np.ndarray]:
    """(frame time in us, physical command) of a HIL_ACTUATOR_CONTROLS message."""
    c = [float(_F32(x)) for x in message.controls[:4]]
    command = np.array([c[0] * SURFACE_FULL_SCALE_DEG[0], c[1] * SURFACE_FULL_SCALE_DEG[1],
                        c[2] * SURFACE_FULL_SCALE_DEG[2], c[3]])
    return int(message.time_usec), command


def heartbeat(link: mavlink.MAVLink, plant: bool) -> bytes:
    kind = mavlink.MAV_TYPE_FIXED_WING if plant else mavlink.MAV_TYPE_ONBOARD_CONTROLLER
    return pack(link, link.heartbeat_encode(kind, mavlink.MAV_AUTOPILOT_GENERIC, 0, 0, mavlink.MAV_STATE_ACTIVE))


def _roundtrip(data: bytes) -> list:
    return new_link(0).parse_buffer(data) or []


def wire_state(measurement, setpoint) -> tuple[np.ndarray, np.ndarray]:
    """The measurement and setpoint after a trip over the line (float32 fields, degrees where the
    message has degrees)."""
    assembler = FrameAssembler()
    frame = None
    for message in _roundtrip(encode_state(new_link(PLANT_SYSTEM_ID), 0, measurement, setpoint)):
        frame = assembler.feed(message) or frame
    return frame.measurement, frame.setpoint


def wire_command(command) -> np.ndarray:
    """The command after a trip over the line."""
    return decode_command(_roundtrip(encode_command(new_link(CONTROLLER_SYSTEM_ID), 0, command))[0])[1]


class WireRounded:
    """An attitude controller seen through the line: its inputs and outputs rounded as a round trip
    over the serial link rounds them. The lockstep bench reproduces ``fly_route`` with it exactly."""

    def __init__(self, controller: AttitudeController):
        self.controller = controller

    def reset(self) -> None:
        self.controller.reset()

    def update(self, dt_s: float, measurement, setpoint) -> np.ndarray:
        m, sp = wire_state(measurement, setpoint)
        return wire_command(self.controller.update(dt_s, m, sp))


__all__ = [
    "STATE_MESSAGES",
    "FrameAssembler",
    "StateFrame",
    "WireRounded",
    "decode_command",
    "encode_command",
    "encode_state",
    "heartbeat",
    "is_crc_error",
    "new_link",
    "wire_command",
    "wire_state",
]
