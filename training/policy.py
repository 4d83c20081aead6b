"""The trained controller at run time: loading, ONNX export and a runtime without TorchRL.

``PolicyRuntime`` is what flies the aircraft after training (evaluation, the loop bench): it keeps
the 8-step observation window exactly as training's ``CatFrames`` does (a new episode's window is
its first observation repeated), scales observations and maps actions to actuator commands, and
runs either the PyTorch network or its ONNX export (onnxruntime, one thread).
"""

from __future__ import annotations

import hashlib
import math
import os
import tempfile
import warnings
from importlib import resources
from pathlib import Path

import numpy as np
import torch
from torch import nn

from jsbsim_env.controllers.goal_trim import GoalIntegrator
from jsbsim_env.controllers.integral_trim import TrimIntegrator
from jsbsim_env.task import (
    ActionError,
    ErrorIntegrals,
    action_list_to_command,
    check_trim_settings,
    initial_last_action,
    insert_trims,
    observation_size,
    scale_row,
    without_trims,
)
from training.checkpoint import atomic_save, checked_load, non_finite_entries
from training.networks import ActorNet

SHIPPED_POLICY = "solar_uav_policy.pt"  # in the training package, with its ONNX export beside it
ONNX_SOURCE_KEY = "policy_sha256"  # ONNX metadata: digest of the policy file the model was exported from


class PolicyFileError(RuntimeError):
    """A policy file that cannot be read or lacks what the runtime needs."""


def shipped_policy_path() -> Path:
    """The controller that ships with the package."""
    return Path(str(resources.files("training") / "shipped" / SHIPPED_POLICY))


class DeterministicActor(nn.Module):
    """Observation window (..., window, observation size) -> action in [-1, 1]^4: tanh of the Gaussian's mean."""

    def __init__(self, net: ActorNet):
        super().__init__()
        self.net = net

    def forward(self, window: torch.Tensor) -> torch.Tensor:
        loc, _ = self.net(window)
        return torch.tanh(loc)


def load_policy(path: Path | str) -> tuple[DeterministicActor, dict]:
    """The deterministic actor and the metadata saved with it (``Trainer.save_policy``); the metadata's
    ``error_integral_decay``, ``integral_trim`` (0 for files from before them), and ``observe_trims``
    (True before it) set the observation layout; ``trims_in_surfaces`` (True before it) what the
    observed surface positions hold; ``rudder_trim_s`` (0 before it) the trims; ``goal_trim_s`` (0
    before it) the goal trim flown with it (``jsbsim_env.controllers.goal_trim``)."""
    path = Path(path)
    if not path.is_file():
        raise PolicyFileError(f"no policy file at {path}")
    try:
        data = checked_load(path)
        bad = non_finite_entries(data["actor"])
        if bad:
            raise PolicyFileError(f"{path} holds NaN or infinite weights ({', '.join(bad[:3])}); it cannot fly")
        decay = float(data.get("error_integral_decay", 0.0))
        trim = float(data.get("integral_trim", 0.0))
        observe_trims = bool(data.get("observe_trims", True))
        trims_in_surfaces = bool(data.get("trims_in_surfaces", True))
        rudder_trim_s = float(data.get("rudder_trim_s", 0.0))
        check_trim_settings(trim, observe_trims, rudder_trim_s)
        goal_trim_s = float(data.get("goal_trim_s", 0.0))
        if goal_trim_s:
            GoalIntegrator(goal_trim_s)  # refuses a time constant out of range
        expected = observation_size(decay, trim, observe_trims)
        prefix = "module.0.module."
        state = {k[len(prefix):]: v for k, v in data["actor"].items() if k.startswith(prefix)}
        inputs = state["encoder.lstm.weight_ih_l0"].shape[1]
        if inputs != expected:
            raise PolicyFileError(f"{path} was trained on observations of {inputs} values, and its settings give "
                                  f"{expected} in this version (the last action was added); train a new policy")
        net = ActorNet(data["network"]["lstm_hidden"], data["network"]["mlp_hidden"], obs_size=inputs,
                       initial_std=data["network"].get("initial_std", 1.0))
        net.load_state_dict(state)
    except PolicyFileError:
        raise
    except Exception as err:  # unpickling, missing keys and shape mismatches all mean the same here
        raise PolicyFileError(f"{path} is not a usable policy file: {err}") from err
    actor = DeterministicActor(net).eval()
    meta = {k: v for k, v in data.items() if k != "actor"}
    meta["error_integral_decay"], meta["integral_trim"], meta["observe_trims"] = decay, trim, observe_trims
    meta["trims_in_surfaces"], meta["rudder_trim_s"], meta["goal_trim_s"] = trims_in_surfaces, rudder_trim_s, goal_trim_s
    return actor, meta


def _rewrite_setting(path: Path, key: str, value: float) -> None:
    """Set one flight-time setting of a policy file, in place and atomically, after ``load_policy``
    accepted the file as it is and as it will be (a refused value leaves the file as it was)."""
    data = checked_load(path)
    data[key] = float(value)
    atomic_save(data, path)


def set_goal_trim(path: Path | str, time_constant_s: float) -> None:
    """Make the policy file at ``path`` fly with goal trim of this time constant (0: none), in place
    and atomically. The goal trim is a flight-time setting (training episodes go without it), so a
    policy trained before the setting existed flies with it as one trained with it recorded."""
    path = Path(path)
    load_policy(path)  # a clear error for a missing or broken file, before anything is written
    if time_constant_s:
        GoalIntegrator(time_constant_s)  # refuses a time constant out of range
    _rewrite_setting(path, "goal_trim_s", time_constant_s)


def set_integral_trim(path: Path | str, fraction: float) -> None:
    """Make the policy file at ``path`` fly with its integral trim at this fraction of the PID's
    integral gains (``jsbsim_env.controllers.integral_trim``), in place and atomically.

    Only the gains change: the policy must have been trained with hidden trims (``integral_trim`` > 0,
    ``observe_trims`` False), so that its observation is the same at any gain and it learned to fly
    with a trim beside it; a policy trained without one, or one that sees its trims, is refused."""
    path = Path(path)
    _, meta = load_policy(path)
    check_flight_integral_trim(fraction, meta["integral_trim"], meta["observe_trims"], meta["rudder_trim_s"],
                               trained_as=str(path))
    _rewrite_setting(path, "integral_trim", fraction)


def check_flight_integral_trim(fraction: float, trained: float, observe_trims: bool, rudder_trim_s: float,
                               trained_as: str = "a policy") -> None:
    """Raise ``ValueError`` naming the problem unless a policy trained with integral trim ``trained``
    (``observe_trims`` as given) can fly with its trim at ``fraction`` of the PID's integral gains:
    only hidden trims can change, since the policy's observation does not depend on them."""
    if trained <= 0.0 or observe_trims:
        raise ValueError(f"{trained_as} was trained with integral_trim {trained:g} and observe_trims {observe_trims}: "
                         "only a policy trained with hidden integral trims can fly with other trim gains")
    if not fraction > 0.0:  # NaN fails too
        raise ValueError(f"integral_trim must be > 0 for a policy trained with one, got {fraction}")
    check_trim_settings(fraction, observe_trims, rudder_trim_s)


def policy_digest(path: Path | str) -> str:
    """SHA-256 of a policy file, stored in its ONNX export to tell a stale export from a current one."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def onnx_source_digest(path: Path | str) -> str | None:
    """The policy digest an ONNX export was made from (None: no file, or no digest in it)."""
    import onnx

    path = Path(path)
    if not path.exists():
        return None
    model = onnx.load(str(path), load_external_data=False)
    return {p.key: p.value for p in model.metadata_props}.get(ONNX_SOURCE_KEY)


def export_onnx(actor: DeterministicActor, path: Path | str, window: int = 8, source_digest: str | None = None) -> Path:
    """Write the deterministic actor as ONNX (batch of one window, fixed shape), atomically, with
    ``source_digest`` (``policy_digest`` of its policy file) in the model's metadata."""
    import onnx

    path = Path(path)
    example = torch.zeros(1, window, actor.net.encoder.lstm.input_size)
    handle, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name, suffix=".tmp")
    os.close(handle)
    try:
        with warnings.catch_warnings():
            # The TorchScript exporter is chosen on purpose (the torch.export one needs onnxscript),
            # and its tracer's notes on the LSTM's shape checks and batch size hold for this one
            # fixed input shape (one window), which is all the export serves.
            warnings.filterwarnings("ignore", category=DeprecationWarning)
            warnings.filterwarnings("ignore", category=torch.jit.TracerWarning)
            warnings.filterwarnings("ignore", message="Exporting a model to ONNX with a batch_size other than 1")
            torch.onnx.export(actor, (example,), tmp, input_names=["window"], output_names=["action"],
                              dynamo=False, opset_version=17)
        if source_digest is not None:
            model = onnx.load(tmp)
            model.metadata_props.add(key=ONNX_SOURCE_KEY, value=source_digest)
            onnx.save(model, tmp)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return path


class PolicyRuntime:
    """Keeps the observation window and turns measurements into actuator commands.

    Args:
        policy_path: a policy file (``load_policy``); the shipped one by default.
        backend: ``"onnx"`` (onnxruntime, the ``.onnx`` file beside the policy, exported again
            if it is missing or was made from another policy file) or ``"torch"``.
    """

    def __init__(self, policy_path: Path | str | None = None, backend: str = "onnx"):
        path = Path(policy_path) if policy_path is not None else shipped_policy_path()
        if policy_path is None and not path.exists():
            raise PolicyFileError("no trained controller ships with this version of the package; pass a policy file "
                                  "(for example runs/<name>/best_policy.pt)")
        self.actor, self.meta = load_policy(path)
        self.window = int(self.meta.get("window", 8))
        self.backend = backend
        decay, trim = self.meta["error_integral_decay"], self.meta["integral_trim"]
        self._observe_trims = trim > 0.0 and self.meta["observe_trims"]
        self._trim_free_surfaces = trim > 0.0 and not self.meta["trims_in_surfaces"]
        self.observation_size = observation_size(decay, trim, self._observe_trims)
        self._integrals = ErrorIntegrals(decay) if decay > 0.0 else None
        self._trim = TrimIntegrator(trim, rudder_time_s=self.meta["rudder_trim_s"]) if trim > 0.0 else None
        goal_trim_s = self.meta["goal_trim_s"]
        self._goal_trim = GoalIntegrator(goal_trim_s) if goal_trim_s else None
        # The window, oldest row first, shifted in place each step; empty until the episode's first push.
        self._window = np.zeros((self.window, self.observation_size), dtype=np.float32)
        self._filled = False
        self._last_action: list[float] | None = None  # fed back into the next observation
        if backend == "onnx":
            import onnxruntime as ort

            onnx_path = self._current_onnx(path)
            options = ort.SessionOptions()
            options.intra_op_num_threads = 1
            options.inter_op_num_threads = 1
            self._session = ort.InferenceSession(str(onnx_path), options, providers=["CPUExecutionProvider"])
        elif backend != "torch":
            raise ValueError(f"backend must be 'onnx' or 'torch', got {backend!r}")

    def _current_onnx(self, path: Path) -> Path:
        """The ONNX export of the policy file at ``path``: the one beside it when it was made from
        this very file (a training run rewrites its best policy, so an older export must not be
        reused), else a fresh export in a temporary folder that lives as long as the runtime:
        nothing is written beside the user's files (``scripts/ship_policy.py`` writes the export
        that ships)."""
        digest = policy_digest(path)
        onnx_path = path.with_suffix(".onnx")
        if onnx_source_digest(onnx_path) == digest:
            return onnx_path
        self._export_dir = tempfile.TemporaryDirectory()
        return export_onnx(self.actor, Path(self._export_dir.name) / onnx_path.name, self.window, digest)

    def reset(self) -> None:
        """Forget the window, the last action, the error integrals and the trims (a new episode)."""
        self._filled = False
        self._last_action = None
        if self._integrals is not None:
            self._integrals.reset()
        if self._trim is not None:
            self._trim.reset()
        if self._goal_trim is not None:
            self._goal_trim.reset()

    def push(self, observation: np.ndarray) -> np.ndarray:
        """Add one scaled observation; returns the window (window, observation size), oldest first."""
        return self._push(self._as_frame(observation)).copy()

    def _push(self, obs: np.ndarray) -> np.ndarray:
        """``push`` without the copy: the runtime's own window, valid until the next push."""
        if not self._filled:
            self._window[:] = obs  # as CatFrames pads a new episode
            self._filled = True
        else:
            self._window[:-1] = self._window[1:]
            self._window[-1] = obs
        return self._window

    def action(self, window: np.ndarray) -> np.ndarray:
        """Action in [-1, 1]^4 for one window."""
        x = np.asarray(window, dtype=np.float32)[None]
        if self.backend == "onnx":
            return self._session.run(None, {"window": x})[0][0]
        with torch.no_grad():
            return self.actor(torch.from_numpy(x))[0].numpy()

    def act(self, measurement: np.ndarray, goal: np.ndarray, dt_s: float | None = None) -> np.ndarray:
        """Actuator command (aileron, elevator, rudder in deg, throttle) for a measured state
        (``core.STATE_NAMES``) and goal (roll, pitch in rad, EAS in m/s); ``dt_s``, the control
        interval, is needed by a policy trained with integral trim. A measurement or goal that is
        not finite is refused (``ValueError``): the network would map it to some finite command."""
        # On plain floats throughout: numpy's per-call overhead would cost more than the arithmetic.
        m, asked = np.asarray(measurement, dtype=float).tolist(), np.asarray(goal, dtype=float).tolist()
        # One sum of plain floats is not finite if any value is not, at a fraction of np.isfinite's cost.
        if not math.isfinite(sum(m) + sum(asked)):
            raise ValueError(f"measurement {m} or goal {asked} is not finite")
        if dt_s is None and (self._trim is not None or self._goal_trim is not None):
            raise ValueError("this policy flies with integral or goal trim: give act() the control interval dt_s")
        # The goal moved by the goal trim, as GoalTrim gives it.
        g = self._goal_trim.goal(asked) if self._goal_trim is not None else asked
        first = self._last_action is None
        if first:
            self._last_action = initial_last_action(m).tolist()
        if self._trim is not None and not first:  # as in training: the integrators start from zero with the episode
            self._trim.integrate(dt_s, m, g)
        seen = without_trims(m, self._trim.trim_deg) if self._trim_free_surfaces else m
        row = scale_row(seen + self._last_action + g)  # the layout of AttitudeTaskBatch._observation
        if self._observe_trims:
            row = insert_trims(row, self._trim.trim_deg)
        if self._integrals is not None:
            row = self._integrals.extend(row)
        obs = np.array(row, dtype=np.float32)
        raw = self.action(self._push(obs)).tolist()
        action = [min(max(x, -1.0), 1.0) for x in raw]  # a NaN stays NaN
        if not all(-1.0 <= x <= 1.0 for x in action):
            self.reset()  # the window and trims hold this step already: start the next call afresh
            raise ActionError(f"the policy's action {raw} is not finite (the runtime was reset)")
        self._last_action = action
        command = action_list_to_command(action)  # within the actuators' travel for actions in [-1, 1]
        if self._trim is not None:
            command = self._trim.apply(command)  # clips the trimmed surfaces to their travel
        if self._goal_trim is not None:  # this step's error against the goal asked for moves the next goal
            self._goal_trim.integrate(dt_s, m, asked)
        return np.array(command)

    def update(self, dt_s: float, measurement: np.ndarray, setpoint: np.ndarray) -> np.ndarray:
        """``act`` under the shared attitude-controller interface (``jsbsim_env.controllers.base``)."""
        return self.act(measurement, setpoint, dt_s)

    def act_scaled(self, observation: np.ndarray) -> np.ndarray:
        """Action in [-1, 1]^4 for an already scaled observation (as the environments give, trims
        and error integrals included where the policy has them; the environment adds the trims to
        the command)."""
        return self.action(self._push(self._as_frame(observation)))

    def _as_frame(self, observation: np.ndarray) -> np.ndarray:
        """One scaled observation as a window row (float32, ``observation_size`` values)."""
        return np.asarray(observation, dtype=np.float32).reshape(self.observation_size)


__all__ = [
    "DeterministicActor",
    "PolicyFileError",
    "PolicyRuntime",
    "check_flight_integral_trim",
    "export_onnx",
    "load_policy",
    "onnx_source_digest",
    "policy_digest",
    "set_goal_trim",
    "set_integral_trim",
    "shipped_policy_path",
]
