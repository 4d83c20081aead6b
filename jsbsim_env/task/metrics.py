"""Evaluation helpers shared by every controller: tracking error, smoothness, episode recording.

* ``rmse``: root-mean-square error of a signal against its reference.
* ``smoothness``: Sm of the paper's Section 5 (Mysore et al. 2021):
  Sm = 2 / (n fs) * sum_i M_i f_i over the FFT amplitudes M_i at frequencies f_i; lower is smoother.
* ``EpisodeRecorder``: time histories of states, goals, commands and rewards, saved as ``.npz``
  and plotted like the paper's Fig. 9.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from jsbsim_env.control.observation import GOAL_NAMES
from jsbsim_env.sim.core import STATE_NAMES
from jsbsim_env.task.attitude import REWARD_TERMS


def rmse(signal: np.ndarray, reference: np.ndarray | float = 0.0) -> float:
    """Root-mean-square of ``signal - reference``."""
    err = np.asarray(signal, dtype=float) - reference
    return float(np.sqrt(np.mean(err * err)))


# The attitude errors every comparison judges (``EpisodeRecorder.tracking_metrics``'s keys): roll,
# pitch and sideslip RMSE in degrees.
ATTITUDE_RMSE_KEYS = ("rmse_roll_deg", "rmse_pitch_deg", "rmse_beta_deg")
ACTUATORS = ("aileron", "elevator", "rudder", "throttle")


def actuator_smoothness(commands: np.ndarray, sample_rate_hz: float) -> dict[str, float]:
    """Sm of each column of ``commands`` (aileron, elevator, rudder in degrees, throttle 0..1),
    with the surfaces taken in radians: on that scale our figures and the paper's Table 8 have the
    same order of magnitude, which they do not in degrees."""
    c = np.asarray(commands, dtype=float)
    to_si = np.array([np.pi / 180.0, np.pi / 180.0, np.pi / 180.0, 1.0])
    return {f"smoothness_{name}": smoothness(c[:, j] * to_si[j], sample_rate_hz) for j, name in enumerate(ACTUATORS)}


def smoothness(signal: np.ndarray, sample_rate_hz: float) -> float:
    """Sm = 2 / (n fs) * sum_i M_i f_i (the paper's Section 5).

    M_i is the one-sided amplitude spectrum of the ``n`` samples (a sinusoid of amplitude A gives
    M = A at its frequency), f_i the bin frequencies, fs the sample rate. A constant signal gives
    0; a sinusoid of amplitude A and frequency f over whole periods gives 2 A f / (n fs).
    """
    x = np.asarray(signal, dtype=float)
    n = x.size
    amplitudes = 2.0 * np.abs(np.fft.rfft(x)) / n
    amplitudes[0] /= 2.0  # the mean appears once
    if n % 2 == 0:
        amplitudes[-1] /= 2.0  # so does the Nyquist bin of an even length
    freqs = np.fft.rfftfreq(n, d=1.0 / sample_rate_hz)
    return float(2.0 / (n * sample_rate_hz) * np.sum(amplitudes * freqs))


def json_ready(obj, why=None, nulls: dict | None = None, path: str = ""):
    """``obj`` (nested dicts, lists, numbers) with every NaN or infinity replaced by None, since
    JSON has neither; ``nulls``, where given, receives each replaced value's path and
    ``why(path)``, the reason to print beside it."""
    if isinstance(obj, (float, np.floating)):
        if math.isfinite(obj):
            return float(obj)
        if nulls is not None:
            nulls[path] = why(path) if why else "not a finite number"
        return None
    if isinstance(obj, (np.integer, np.bool_)):
        return obj.item()
    if isinstance(obj, dict):
        return {k: json_ready(v, why, nulls, f"{path}.{k}" if path else str(k)) for k, v in obj.items()}
    if isinstance(obj, (list, tuple, np.ndarray)):
        return [json_ready(v, why, nulls, f"{path}[{i}]") for i, v in enumerate(obj)]
    return obj


@dataclass
class EpisodeRecorder:
    """Collects one episode step by step; ``arrays()`` gives the time histories."""

    time_s: list[float] = field(default_factory=list)
    true_state: list[np.ndarray] = field(default_factory=list)
    goal: list[np.ndarray] = field(default_factory=list)
    command: list[np.ndarray] = field(default_factory=list)  # aileron, elevator, rudder (deg), throttle
    reward_terms: list[np.ndarray] = field(default_factory=list)

    def record(self, time_s: float, true_state, goal, command, reward_terms) -> None:
        self.time_s.append(float(time_s))
        self.true_state.append(np.asarray(true_state, dtype=float).copy())
        self.goal.append(np.asarray(goal, dtype=float).copy())
        self.command.append(np.asarray(command, dtype=float).copy())
        self.reward_terms.append(np.asarray(reward_terms, dtype=float).copy())

    def arrays(self) -> dict[str, np.ndarray]:
        return {"time_s": np.array(self.time_s), "true_state": np.array(self.true_state),
                "goal": np.array(self.goal), "command": np.array(self.command),
                "reward_terms": np.array(self.reward_terms)}

    def save(self, path: Path | str) -> None:
        """Write the histories (and their column names) to an ``.npz`` file."""
        np.savez_compressed(path, **self.arrays(), state_names=np.array(STATE_NAMES),
                            goal_names=np.array(GOAL_NAMES), reward_term_names=np.array([*REWARD_TERMS, "reward"]))

    def tracking_metrics(self, sample_rate_hz: float | None = None) -> dict[str, float]:
        """RMSE of roll, pitch (deg), EAS (m/s) against their goals and of sideslip (deg) against
        zero; smoothness of each actuator command (``actuator_smoothness``)."""
        a = self.arrays()
        s, g, c = a["true_state"], a["goal"], a["command"]
        if sample_rate_hz is None:
            sample_rate_hz = 1.0 / float(np.median(np.diff(a["time_s"])))
        out = {
            "rmse_roll_deg": rmse(np.degrees(s[:, 1]), np.degrees(g[:, 0])),
            "rmse_pitch_deg": rmse(np.degrees(s[:, 2]), np.degrees(g[:, 1])),
            "rmse_airspeed_eas_mps": rmse(s[:, 6], g[:, 2]),
            "rmse_beta_deg": rmse(np.degrees(s[:, 8])),
        }
        out.update(actuator_smoothness(c, sample_rate_hz))
        return out

    def plot(self, path: Path | str, title: str = "") -> None:
        """Time histories of roll, pitch, EAS and sideslip against their goals, and the actuators."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        a = self.arrays()
        t, s, g, c = a["time_s"], a["true_state"], a["goal"], a["command"]
        fig, axes = plt.subplots(4, 2, figsize=(11, 9), sharex=True)
        panels = ((np.degrees(s[:, 1]), np.degrees(g[:, 0]), "roll, deg"),
                  (np.degrees(s[:, 2]), np.degrees(g[:, 1]), "pitch, deg"),
                  (s[:, 6], g[:, 2], "EAS, m/s"), (np.degrees(s[:, 8]), np.zeros_like(t), "sideslip, deg"))
        for ax, (y, ref, label) in zip(axes[:, 0], panels):
            ax.plot(t, ref, "k--", lw=1, label="command")
            ax.plot(t, y, lw=1.2, label="aircraft")
            ax.set_ylabel(label)
            ax.grid(alpha=0.3)
        axes[0, 0].legend(fontsize=8)
        for ax, j, label in zip(axes[:, 1], range(4), ("aileron, deg", "elevator, deg", "rudder, deg", "throttle")):
            ax.plot(t, c[:, j], lw=1)
            ax.set_ylabel(label)
            ax.grid(alpha=0.3)
        for ax in axes[-1]:
            ax.set_xlabel("time, s")
        fig.suptitle(title)
        fig.tight_layout()
        fig.savefig(path, dpi=110)
        plt.close(fig)
