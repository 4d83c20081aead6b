"""The trained controller at run time: loading, ONNX export and a runtime without TorchRL.

``PolicyRuntime`` is what flies the aircraft after training (evaluation, the loop bench): the
control stack its policy file records (``jsbsim_env.control.stack``: trims, observation, the
window kept exactly as training's ``CatFrames`` keeps it) around the network, run by PyTorch or by
its ONNX export (onnxruntime, one thread).

    >>> import numpy as np
    >>> from jsbsim_env.control.policy import PolicyRuntime
    >>> runtime = PolicyRuntime()  # the shipped controller
    >>> measurement = np.array([10000.0, 0.0, 0.02, 0, 0, 0, 10.0, 0.02, 0, 0, -0.05, 0, 0.5])  # m, rad, rad/s, m/s
    >>> goal = np.array([np.radians(3.0), 0.02, 10.0])  # roll, pitch rad; EAS m/s
    >>> command = runtime.act(measurement, goal, dt_s=0.04)  # aileron, elevator, rudder deg; throttle 0..1
    >>> command.shape
    (4,)
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import re
import tempfile
import warnings
from importlib import resources
from pathlib import Path

import numpy as np
import torch
from torch import nn

from aircraft import AIRCRAFT_NAME, Aircraft, load_aircraft
from jsbsim_env.control.checked_io import MAGIC, DamagedFileError, checked_load, non_finite_entries
from jsbsim_env.control.input_checks import InputLimits, check_interval, learned_interval_s
from jsbsim_env.control.network import ENCODERS, ActorNet, encoder_inputs
from jsbsim_env.control.observation import ActionError
from jsbsim_env.control.stack import FLIGHT_STACKS, ControlStack, StackSettings

SHIPPED_POLICY = "solar_uav_policy.pt"  # in shipped/ beside this module, with its ONNX export
ONNX_SOURCE_KEY = "policy_sha256"  # ONNX metadata: digest of the policy file the model was exported from
# An export beside a policy file is used only when it computes what the policy computes: its action
# for a probe window within this of PyTorch's (the two agree to about 1e-6).
ONNX_AGREEMENT_TOL = 1e-4



class PolicyFileError(RuntimeError):
    """A policy file that cannot be read or lacks what the runtime needs."""


class WrongAircraftError(PolicyFileError):
    """A policy flown on an aircraft other than the one it was trained on, without asking for it."""


def trained_aircraft(meta: dict, path: Path) -> tuple[str, str | None]:
    """The aircraft a policy file was trained on: its name and model fingerprint, from the file
    (``Trainer.save_policy``), else from the record beside a shipped policy; a file that records
    neither was written before other aircraft could be trained, on the paper's (fingerprint unknown)."""
    if "aircraft_model" in meta:
        return str(meta.get("aircraft", "?")), str(meta["aircraft_model"])
    record = path.with_suffix(".json")
    if record.is_file():
        try:
            model = json.loads(record.read_text()).get("aircraft_model")
        except (OSError, ValueError, AttributeError):
            model = None
        if isinstance(model, str):
            return AIRCRAFT_NAME, model
    return AIRCRAFT_NAME, None


def check_aircraft(meta: dict, path: Path, flown: Aircraft) -> None:
    """Refuse (``WrongAircraftError``, naming both) to fly a policy on an aircraft other than the one
    it was trained on: another model fingerprint, or, for a file that records none, another
    aircraft than the paper's."""
    name, model = trained_aircraft(meta, path)
    if model is None:
        same = flown.papers
        trained = f"{name} (a file that records no model)"
    else:
        same = flown.matches_model(model)
        trained = f"{name} (model {model[:12]})"
    if not same:
        raise WrongAircraftError(f"{path} was trained on {trained} and would fly {flown.describe()} (model "
                                 f"{flown.fingerprint[:12]}): a policy flies the aircraft it was trained on; ask for a "
                                 "transfer experiment (transfer=True, --transfer) to fly it on another")


def shipped_policy_path() -> Path:
    """The controller that ships with the package."""
    return Path(str(resources.files("jsbsim_env.control") / "shipped" / SHIPPED_POLICY))


class DeterministicActor(nn.Module):
    """Observation window (..., window, observation size) -> action in [-1, 1]^4: tanh of the Gaussian's mean."""

    def __init__(self, net: ActorNet):
        super().__init__()
        self.net = net

    def forward(self, window: torch.Tensor) -> torch.Tensor:
        loc, _ = self.net(window)
        return torch.tanh(loc)


# How a policy file written before its ``stack`` entry recorded its stages: each flat setting with
# the value a file that does not name it was written with.
_FLAT_DEFAULTS = {"window": 8, "integral_trim": 0.0, "goal_trim_s": 0.0, "error_integral_decay": 0.0,
                  "observe_trims": True, "trims_in_surfaces": True, "rudder_trim_s": 0.0}


def stack_settings_of(data: dict, path: Path) -> StackSettings:
    """The control-stack settings a policy file records: its ``stack`` entry, or, in a file written
    before that entry, the flat settings it was saved with. A file whose stages this version no
    longer has (error integrals, a rudder trim, surface trims shown to the policy or left in its
    observed surfaces) is refused, naming them."""
    if "stack" in data:
        return StackSettings.from_dict(data["stack"])
    flat = {k: data.get(k, default) for k, default in _FLAT_DEFAULTS.items()}
    trimmed = float(flat["integral_trim"]) > 0.0
    gone = [name for name, present in (("error_integral_decay", float(flat["error_integral_decay"]) > 0.0),
                                       ("rudder_trim_s", float(flat["rudder_trim_s"]) > 0.0),
                                       ("observe_trims", trimmed and bool(flat["observe_trims"])),
                                       ("trims_in_surfaces", trimmed and bool(flat["trims_in_surfaces"]))) if present]
    if gone:
        raise PolicyFileError(f"{path} was trained with stages this version of the package no longer has "
                              f"({', '.join(f'{name}={flat[name]}' for name in gone)}); fly it with the version it "
                              "was trained with")
    return StackSettings(window_steps=int(flat["window"]), goal_trim_time_constant_s=float(flat["goal_trim_s"]),
                         surface_trim_gain=float(flat["integral_trim"]))


_FINGERPRINT = re.compile(r"[0-9a-f]{64}")


def check_record(data: dict, path: Path, stack: StackSettings) -> None:
    """Refuse (``PolicyFileError``, naming the field) a policy file whose record is not what the
    trainer writes (``Trainer.save_policy``): a task version this package does not have, a stack
    other than its task version's (``stack.FLIGHT_STACKS``), a file that records its task but not
    the aircraft it was trained on (name and 64-hex model fingerprint), frames or a seed that are
    no whole numbers. A file that records its task was written with the SHA-256 of its contents
    (``checked_io``): one without it (a plain ``torch.save``, as an edit by hand writes) is refused,
    so that the record which identifies the policy is always covered by its checksum. Files from
    before the task was recorded (the shipped policy) keep their flat settings, read by
    ``stack_settings_of``."""
    def refuse(why: str) -> PolicyFileError:
        return PolicyFileError(f"{path}: {why}; it is not a policy file as the trainer writes it (edited?): "
                               "train or ship it again")

    for key in ("frames", "seed"):
        value = data.get(key, 0)
        if isinstance(value, bool) or not isinstance(value, int) or (key == "frames" and value < 0):
            raise refuse(f"{key} must be a whole number{' >= 0' if key == 'frames' else ''}, got {value!r}")
    if "aircraft" in data and not isinstance(data["aircraft"], str):
        raise refuse(f"aircraft must be a name, got {data['aircraft']!r}")
    if "aircraft_model" in data and not (isinstance(data["aircraft_model"], str)
                                         and _FINGERPRINT.fullmatch(data["aircraft_model"])):
        raise refuse(f"aircraft_model must be a 64-hex fingerprint, got {data['aircraft_model']!r}")
    if "task" not in data:
        if "stack" in data:  # written by the trainer since it records the task
            raise refuse("it records its stack but not its task version")
        return
    task = data["task"]
    if task not in FLIGHT_STACKS:
        raise refuse(f"task {task!r} is not a task version of this package ({', '.join(FLIGHT_STACKS)})")
    if stack != FLIGHT_STACKS[task]:
        raise refuse(f"its stack {stack.to_dict()} is not the one {task} flies with ({FLIGHT_STACKS[task].to_dict()})")
    missing = [key for key in ("aircraft", "aircraft_model") if key not in data]
    if missing:
        raise refuse(f"it records its task but not {' or '.join(missing)}, the aircraft it was trained on")
    with path.open("rb") as fh:
        if fh.read(len(MAGIC)) != MAGIC:
            raise refuse("it records its task but was written without the SHA-256 of its contents")


def load_policy(path: Path | str) -> tuple[DeterministicActor, dict]:
    """The deterministic actor and the metadata saved with it (``Trainer.save_policy``); the
    metadata's ``stack`` is the ``StackSettings`` it flies with."""
    path = Path(path)
    if not path.is_file():
        raise PolicyFileError(f"no policy file at {path}")
    if path.suffix.lower() == ".onnx":
        raise PolicyFileError(f"{path} is an ONNX export, not a policy file: give the policy file (.pt) it was "
                              "exported from")
    try:
        data = checked_load(path)
    except DamagedFileError as err:  # damaged, or not a file of this package at all; it names the file
        raise PolicyFileError(str(err)) from err
    if isinstance(data, dict) and "format_version" in data and "sac" in data:  # training.checkpoint's keys
        raise PolicyFileError(f"{path} is a training checkpoint, not a policy file: give the run's best_policy.pt")
    if not isinstance(data, dict) or "actor" not in data or "network" not in data:
        raise PolicyFileError(f"{path} is not a policy file of this package (no actor network in it; it holds "
                              f"{_describe(data)})")
    try:
        bad = non_finite_entries(data["actor"])
        if bad:
            raise PolicyFileError(f"{path} holds NaN or infinite weights ({', '.join(bad[:3])}); it cannot fly")
        try:
            stack = stack_settings_of(data, path)
        except ValueError as err:
            raise PolicyFileError(f"{path}: {err}") from err
        prefix = "module.0.module."
        state = {k[len(prefix):]: v for k, v in data["actor"].items() if k.startswith(prefix)}
        kind = data["network"].get("encoder", "lstm")  # files before the encoder setting are LSTMs
        if kind not in ENCODERS:
            raise PolicyFileError(f"{path} has a {kind!r} encoder, which this version does not have "
                                  f"({', '.join(ENCODERS)})")
        inputs = encoder_inputs(state, kind, stack.window_steps)
        if inputs != stack.observation_size:
            raise PolicyFileError(f"{path} was trained on observations of {inputs} values, and its control stack "
                                  f"gives {stack.observation_size} in this version; train a new policy")
        net = ActorNet(data["network"]["lstm_hidden"], data["network"]["mlp_hidden"], obs_size=inputs, encoder=kind,
                       window=stack.window_steps)
        net.load_state_dict(state)
        check_record(data, path, stack)  # after the network's sizes, which name what an edit broke
    except PolicyFileError:
        raise
    except Exception as err:  # missing keys and shape mismatches all mean the same here
        why = "; ".join(line.strip() for line in str(err).splitlines() if line.strip())  # one line
        raise PolicyFileError(f"{path} is not a usable policy file: {why}") from err
    actor = DeterministicActor(net).eval()
    # The stack replaces the flat settings an older file records it with.
    meta = {k: v for k, v in data.items() if k != "actor" and k not in _FLAT_DEFAULTS}
    meta["stack"] = stack
    return actor, meta


def _describe(data) -> str:
    """What a loaded file holds, in a few words, for an error that refuses it."""
    if isinstance(data, dict):
        keys = [str(k) for k in data]
        shown = ", ".join(keys[:6]) + (f" and {len(keys) - 6} more" if len(keys) > 6 else "")
        return f"a dict with keys {shown}" if keys else "an empty dict"
    if isinstance(data, torch.Tensor):
        return f"a tensor of shape {tuple(data.shape)}"
    if isinstance(data, (list, tuple)):
        return f"a {type(data).__name__} of {len(data)} items"
    if isinstance(data, nn.Module):
        return f"a whole {type(data).__name__} module"
    return f"a {type(data).__name__}"


def policy_digest(path: Path | str) -> str:
    """SHA-256 of a policy file, stored in its ONNX export to tell a stale export from a current one."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def onnx_source_digest(path: Path | str) -> str | None:
    """The policy digest an ONNX export was made from (None: no file, no digest in it, or a file
    that cannot be read as ONNX: truncated, damaged or something else)."""
    import onnx

    path = Path(path)
    if not path.is_file():
        return None
    try:
        model = onnx.load(str(path), load_external_data=False)
    except Exception:  # noqa: BLE001 - protobuf's DecodeError and the like: not an export to use
        return None
    return {p.key: p.value for p in model.metadata_props}.get(ONNX_SOURCE_KEY)


def export_onnx(actor: DeterministicActor, path: Path | str, window: int = 8, source_digest: str | None = None) -> Path:
    """Write the deterministic actor as ONNX (batch of one window, fixed shape), atomically, with
    ``source_digest`` (``policy_digest`` of its policy file) in the model's metadata."""
    import onnx

    path = Path(path)
    example = torch.zeros(1, window, actor.net.obs_size)
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
        network_alone: fly the network without the classical stages its file records (goal trim,
            surface trim), to measure what the network does by itself; its inputs (window, error
            integrals) stay as they are.
        aircraft: the aircraft it flies (``aircraft.load_aircraft``; the paper's by default): its
            surface trim's gains are that aircraft's PID's. A policy trained on another aircraft is
            refused (``WrongAircraftError``) unless ``transfer``.
    """

    def __init__(self, policy_path: Path | str | None = None, backend: str = "onnx", network_alone: bool = False,
                 aircraft: Aircraft | Path | str | None = None, transfer: bool = False):
        path = Path(policy_path) if policy_path is not None else shipped_policy_path()
        if policy_path is None and not path.exists():
            raise PolicyFileError("no trained controller ships with this version of the package; pass a policy file "
                                  "(for example runs/<name>/best_policy.pt)")
        self.actor, self.meta = load_policy(path)
        self.aircraft = load_aircraft(aircraft)
        if not transfer:
            check_aircraft(self.meta, path, self.aircraft)
        settings = self.meta["stack"]
        self.stack = ControlStack(settings.network_alone() if network_alone else settings, self.aircraft)
        self.limits = InputLimits(self.aircraft)
        self.interval_limits_s = learned_interval_s()
        self.window = self.stack.settings.window_steps
        self.observation_size = self.stack.settings.observation_size
        self.backend = backend
        self._window_shape = (self.window, self.observation_size)
        if backend == "onnx":
            self._session = self._onnx_session(path)
        elif backend != "torch":
            raise ValueError(f"backend must be 'onnx' or 'torch', got {backend!r}")

    def _onnx_session(self, path: Path):
        """An onnxruntime session (one thread) on the ONNX export of the policy file at ``path``:
        the one beside it when it was made from this very file (a training run rewrites its best
        policy, so an older export must not be reused), loads and computes what the policy does;
        else a fresh export in a temporary folder that lives as long as the runtime: nothing is
        written beside the user's files (``scripts/ship_policy.py`` writes the export that ships)."""
        digest = policy_digest(path)
        beside = path.with_suffix(".onnx")
        if onnx_source_digest(beside) == digest:
            try:
                session = _ort_session(beside)
                if self._agrees(session):
                    return session
            except Exception:  # noqa: BLE001, S110 - damaged past its metadata: exported afresh below
                pass
        self._export_dir = tempfile.TemporaryDirectory()
        return _ort_session(export_onnx(self.actor, Path(self._export_dir.name) / beside.name, self.window, digest))

    def _agrees(self, session) -> bool:
        """Whether ``session`` gives the PyTorch actor's action for a probe window (an export whose
        weights changed after it was written, on disk or in a copy, would not)."""
        probe = np.random.default_rng(0).normal(size=(1, *self._window_shape)).astype(np.float32)
        with torch.no_grad():
            expected = self.actor(torch.from_numpy(probe))[0].numpy()
        got = session.run(None, {"window": probe})[0][0]
        return got.shape == expected.shape and bool(np.all(np.abs(got - expected) <= ONNX_AGREEMENT_TOL))

    def reset(self) -> None:
        """A new flight: the window, the last action and the trims start afresh."""
        self.stack.reset()

    def push(self, observation: np.ndarray) -> np.ndarray:
        """Add one scaled observation; returns the window (window, observation size), oldest first."""
        return self.stack.window.push(self._as_frame(observation)).copy()

    def action(self, window: np.ndarray) -> np.ndarray:
        """Action in [-1, 1]^4 for one window (window, observation size), oldest first. A window of
        another shape (PyTorch's LSTM would read any length) or not finite (onnxruntime's LSTM
        would turn a NaN into a finite action) is refused (``ValueError``). The runtime's own
        window (``act``, ``act_scaled``, ``push``) had each row checked as it came in, and is not
        checked again here: a check of the whole window would cost a tenth of a control step."""
        x = np.asarray(window, dtype=np.float32)
        if x.shape != self._window_shape:
            raise ValueError(f"window must have shape {self._window_shape} (steps, observation values), "
                             f"got {x.shape}")
        if x is not self.stack.window.rows and not math.isfinite(x.sum(dtype=np.float64)):  # float64: no overflow
            raise ValueError("window is not finite (NaN or infinity in it)")
        if self.backend == "onnx":
            return self._session.run(None, {"window": x[None]})[0][0]
        with torch.no_grad():
            return self.actor(torch.from_numpy(x[None]))[0].numpy()

    def act(self, measurement: np.ndarray, goal: np.ndarray, dt_s: float | None = None) -> np.ndarray:
        """Actuator command (aileron, elevator, rudder in deg, throttle) for a measured state
        (``core.STATE_NAMES``) and goal (roll, pitch in rad, EAS in m/s); ``dt_s``, the control
        interval, is needed by a policy that flies with trims. A measurement or goal of another
        shape, or outside what the aircraft and the task make possible, and an interval that is no
        real number of seconds within the task's intervals (``input_checks``: each with its margin)
        are refused (``ValueError`` naming the value, its unit and the limit) before any stage
        moves: the network would map them to some finite command."""
        m, asked = self.limits.check(measurement, goal)  # plain floats: numpy's per-call overhead costs more
        if dt_s is not None:
            dt_s = check_interval(dt_s, self.interval_limits_s, "learned controller")
        elif self.stack.needs_interval:
            raise ValueError("this policy flies with a surface or goal trim: give act() the control interval dt_s")
        raw = self.action(self.stack.observe(m, asked, dt_s)).tolist()
        action = [min(max(x, -1.0), 1.0) for x in raw]  # a NaN stays NaN
        if not all(-1.0 <= x <= 1.0 for x in action):
            self.reset()  # the window and trims hold this step already: start the next call afresh
            raise ActionError(f"the policy's action {raw} is not finite (the runtime was reset)")
        return np.array(self.stack.command(action))

    def update(self, dt_s: float, measurement: np.ndarray, setpoint: np.ndarray) -> np.ndarray:
        """``act`` under the shared attitude-controller interface (``jsbsim_env.control.base``)."""
        return self.act(measurement, setpoint, dt_s)

    def act_scaled(self, observation: np.ndarray) -> np.ndarray:
        """Action in [-1, 1]^4 for an already scaled observation, as the environments give (the
        environment adds any surface trims to the command). An observation of another size, or
        not finite, is refused (``ValueError``) before either backend: onnxruntime's LSTM would
        turn a NaN into a finite action."""
        return self.action(self.stack.window.push(self._as_frame(observation)))

    def _as_frame(self, observation: np.ndarray) -> np.ndarray:
        """One scaled observation as a window row (float32, ``observation_size`` values), finite."""
        frame = np.asarray(observation, dtype=np.float32)
        if frame.shape != (self.observation_size,):
            raise ValueError(f"observation must have shape ({self.observation_size},), got {frame.shape}")
        # A sum of plain floats is not finite if any value is not (and cannot overflow as float32 could).
        if not math.isfinite(sum(frame.tolist())):
            raise ValueError(f"observation {frame.tolist()} is not finite")
        return frame


def _ort_session(path: Path):
    """An onnxruntime session on one thread, on the CPU."""
    import onnxruntime as ort

    options = ort.SessionOptions()
    options.intra_op_num_threads = 1
    options.inter_op_num_threads = 1
    return ort.InferenceSession(str(path), options, providers=["CPUExecutionProvider"])


__all__ = [
    "DeterministicActor",
    "PolicyFileError",
    "PolicyRuntime",
    "export_onnx",
    "load_policy",
    "onnx_source_digest",
    "policy_digest",
    "shipped_policy_path",
    "stack_settings_of",
]
