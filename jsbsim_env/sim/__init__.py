"""The simulation: JSBSim with trim and linear models (``simulation``), the flight core that adds
delay, noise, actuators, coefficient scaling and turbulence (``core``), the trim table episodes
start from, and the model checks run on every load."""

from .model_check import ModelError
from .simulation import Simulation, TrimError, TrimResult

__all__ = ["ModelError", "Simulation", "TrimError", "TrimResult"]
