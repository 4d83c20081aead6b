"""Trim of the nominal aircraft on an altitude x EAS grid, filled on demand and interpolated.

Episode starts need a trimmed state in a few milliseconds; a full trim takes tens. The grid's
cells are trimmed the first time a start falls in them and kept for the life of the process, one
table per aircraft (JSBSim root and aircraft name).
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import numpy as np

import aircraft
from jsbsim_env.sim.simulation import ALTITUDE_RANGE_M, EAS_RANGE_MPS, Simulation, TrimError

GRID_ALTITUDES_M = np.array([0.0, 500.0, *np.arange(1000.0, 20001.0, 1000.0)])
GRID_EAS_MPS = np.arange(EAS_RANGE_MPS[0], EAS_RANGE_MPS[1] + 0.01, 1.0)


@dataclass(frozen=True)
class TrimPoint:
    alpha_deg: float
    elevator_deg: float
    throttle: float


class TrimTable:
    """Bilinear interpolation of trimmed alpha, elevator and throttle (nominal coefficients).

    Args:
        root: JSBSim root of the aircraft; the packaged one by default.
        aircraft_name: aircraft folder under ``<root>/aircraft``.
    """

    _shared: ClassVar[dict[tuple[Path, str], TrimTable]] = {}
    _lock = threading.Lock()

    def __init__(self, root: Path | str | None = None, aircraft_name: str = aircraft.AIRCRAFT_NAME):
        self.root = Path(root).resolve() if root is not None else aircraft.jsbsim_root()
        self.aircraft_name = aircraft_name
        self._sim: Simulation | None = None
        self._cells: dict[tuple[int, int], np.ndarray] = {}

    @classmethod
    def shared(cls, root: Path | str | None = None, aircraft_name: str = aircraft.AIRCRAFT_NAME) -> TrimTable:
        """One table per aircraft (JSBSim root and aircraft name) and process.

        The simulation rate is not part of the key: a trim is a steady state, the same at any rate
        to its tolerance (60 and 240 Hz differ by 1e-5 in throttle).
        """
        table = cls(root, aircraft_name)
        with cls._lock:
            return cls._shared.setdefault((table.root, aircraft_name), table)

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
                self._sim = Simulation(self.root, aircraft_name=self.aircraft_name)
            t = self._sim.trim(float(GRID_ALTITUDES_M[i]), float(GRID_EAS_MPS[j]))
            self._cells[key] = np.array([t.alpha_deg, t.elevator_deg, t.throttle])
        return self._cells[key]

    def fill(self) -> None:
        """Trim every grid point now (about 3 s) instead of on first use."""
        for i in range(len(GRID_ALTITUDES_M)):
            for j in range(len(GRID_EAS_MPS)):
                self._node(i, j)

    def lookup(self, altitude_m: float, airspeed_eas_mps: float) -> TrimPoint:
        """Trim at any point of the envelope (clipped to it); ``TrimError`` for a point that is not finite."""
        if not (math.isfinite(altitude_m) and math.isfinite(airspeed_eas_mps)):
            raise TrimError(f"no trim at altitude {altitude_m} m, EAS {airspeed_eas_mps} m/s: both must be finite")
        h = float(np.clip(altitude_m, *ALTITUDE_RANGE_M))
        v = float(np.clip(airspeed_eas_mps, *EAS_RANGE_MPS))
        i = int(np.clip(np.searchsorted(GRID_ALTITUDES_M, h) - 1, 0, len(GRID_ALTITUDES_M) - 2))
        j = int(np.clip(np.searchsorted(GRID_EAS_MPS, v) - 1, 0, len(GRID_EAS_MPS) - 2))
        fh = (h - GRID_ALTITUDES_M[i]) / (GRID_ALTITUDES_M[i + 1] - GRID_ALTITUDES_M[i])
        fv = (v - GRID_EAS_MPS[j]) / (GRID_EAS_MPS[j + 1] - GRID_EAS_MPS[j])
        x = ((1 - fh) * (1 - fv) * self._node(i, j) + fh * (1 - fv) * self._node(i + 1, j)
             + (1 - fh) * fv * self._node(i, j + 1) + fh * fv * self._node(i + 1, j + 1))
        return TrimPoint(*map(float, x))
