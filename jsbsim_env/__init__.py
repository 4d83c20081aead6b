"""Simulation core and reinforcement-learning environments for the solar UAV in JSBSim."""

from .sim import ModelError, Simulation, TrimError, TrimResult

__all__ = ["ModelError", "Simulation", "TrimError", "TrimResult"]
