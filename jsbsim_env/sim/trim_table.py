"""Trim of the nominal aircraft on an altitude x EAS grid, filled on demand and interpolated.

Episode starts need a trimmed state in a few milliseconds; a full trim takes tens. The grid's
cells are trimmed the first time a start falls in them and kept for the life of the process, one
table per aircraft (JSBSim root and aircraft name). The grid spans the aircraft's envelope
(``grid``): the paper's aircraft's is 0, 500 m, then every 1,000 m to 20 km, by 8 to 12 m/s EAS in
steps of 1 m/s.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import numpy as np

from aircraft import Aircraft, load_aircraft
from jsbsim_env.sim.simulation import ALTITUDE_RANGE_M, EAS_RANGE_MPS, Simulation, TrimError

ALTITUDE_CELLS = 20  # the envelope's altitude range in 20 cells, the lowest split in two (the ground's effect)
EAS_STEP_MPS = 1.0  # at most; the EAS range in equal cells


def grid(altitude_range_m: tuple[float, float], eas_range_mps: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """The trim grid's altitudes (m) and EAS (m/s) over an envelope."""
    (h0, h1), (v0, v1) = altitude_range_m, eas_range_mps
    step = (h1 - h0) / ALTITUDE_CELLS
    altitudes = np.array([h0, h0 + 0.5 * step, *(h0 + step * np.arange(1, ALTITUDE_CELLS + 1))])
    speeds = np.linspace(v0, v1, max(2, math.ceil((v1 - v0) / EAS_STEP_MPS - 1e-9) + 1))
    return altitudes, speeds


GRID_ALTITUDES_M, GRID_EAS_MPS = grid(ALTITUDE_RANGE_M, EAS_RANGE_MPS)  # the paper's aircraft's


@dataclass(frozen=True)
class TrimPoint:
    alpha_deg: float
    elevator_deg: float
    throttle: float
    aileron_deg: float  # the lateral trim: zero for a symmetric aircraft (see ``TrimResult``)
    rudder_deg: float
    beta_deg: float


class TrimTable:
    """Bilinear interpolation of the trim (``TrimPoint``; nominal coefficients).

    Args:
        aircraft: the aircraft (``aircraft.load_aircraft``); the paper's by default.
    """

    _shared: ClassVar[dict[tuple[Path, str], TrimTable]] = {}
    _lock = threading.Lock()

    def __init__(self, aircraft: Aircraft | Path | str | None = None):
        self.aircraft = load_aircraft(aircraft)
        self.root, self.aircraft_name = self.aircraft.root, self.aircraft.name
        self.altitudes_m, self.eas_mps = grid(self.aircraft.altitude_range_m, self.aircraft.eas_range_mps)
        self._sim: Simulation | None = None
        self._cells: dict[tuple[int, int], np.ndarray] = {}

    @classmethod
    def shared(cls, aircraft: Aircraft | Path | str | None = None) -> TrimTable:
        """One table per aircraft (JSBSim root and aircraft name) and process.

        The simulation rate is not part of the key: a trim is a steady state, the same at any rate
        to its tolerance (60 and 240 Hz differ by 1e-5 in throttle).
        """
        found = load_aircraft(aircraft)
        with cls._lock:
            key = (found.root, found.name)
            if key not in cls._shared:
                cls._shared[key] = cls(found)
            return cls._shared[key]

    @classmethod
    def forget_shared(cls) -> None:
        """Drop this process's shared tables. A node's trim starts from the state the table's
        simulation was left in by the node before, which moves it by about 1e-9; work that must
        give the same numbers in any process (a sweep's jobs) starts from empty tables."""
        with cls._lock:
            cls._shared.clear()

    def _node(self, i: int, j: int) -> np.ndarray:
        key = (i, j)
        if key not in self._cells:
            if self._sim is None:
                self._sim = Simulation(self.aircraft)
            t = self._sim.trim(float(self.altitudes_m[i]), float(self.eas_mps[j]))
            self._cells[key] = np.array([t.alpha_deg, t.elevator_deg, t.throttle, t.aileron_deg, t.rudder_deg,
                                         t.beta_deg])
        return self._cells[key]

    def fill(self) -> None:
        """Trim every grid point now (about 3 s) instead of on first use."""
        for i in range(len(self.altitudes_m)):
            for j in range(len(self.eas_mps)):
                self._node(i, j)

    def lookup(self, altitude_m: float, airspeed_eas_mps: float) -> TrimPoint:
        """Trim at any point of the envelope (clipped to it); ``TrimError`` for a point that is not finite."""
        if not (math.isfinite(altitude_m) and math.isfinite(airspeed_eas_mps)):
            raise TrimError(f"no trim at altitude {altitude_m} m, EAS {airspeed_eas_mps} m/s: both must be finite")
        hs, vs = self.altitudes_m, self.eas_mps
        h = float(np.clip(altitude_m, hs[0], hs[-1]))
        v = float(np.clip(airspeed_eas_mps, vs[0], vs[-1]))
        i = int(np.clip(np.searchsorted(hs, h) - 1, 0, len(hs) - 2))
        j = int(np.clip(np.searchsorted(vs, v) - 1, 0, len(vs) - 2))
        fh = (h - hs[i]) / (hs[i + 1] - hs[i])
        fv = (v - vs[j]) / (vs[j + 1] - vs[j])
        x = ((1 - fh) * (1 - fv) * self._node(i, j) + fh * (1 - fv) * self._node(i + 1, j)
             + (1 - fh) * fv * self._node(i, j + 1) + fh * fv * self._node(i + 1, j + 1))
        return TrimPoint(*map(float, x))
