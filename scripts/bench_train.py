"""Training speed: time of one SAC update (actor, both critics, targets, CAPS) and env steps per
second of collection, with the default configuration.

``update_ms`` is the package's update (``training.sac``); ``reference_update_ms`` is TorchRL's own
``SACLoss`` update with the same networks, batch and CAPS (``training.sac_reference``), timed in the
same process in interleaved rounds, so that ``update_to_reference`` holds on a noisy machine.

    python scripts/bench_train.py --json [--device cuda] [--threads 2]
"""

from __future__ import annotations

import json
import statistics
import tempfile
import time

# torch, TorchRL and the simulation load in main(), after the arguments are parsed.
from training.runtime import (
    ScriptParser,
    non_negative_int,
    number_type,
    rounds_int,
    run_command,
    torchrl_logs_to_stderr,
    tune_allocator,
)


def main(argv: list[str] | None = None) -> int:
    parser = ScriptParser(__file__, description=__doc__.split("\n\n")[0])
    parser.add_argument("--device", default="cpu", help="torch device the update runs on (cpu, or cuda where a GPU is present)")
    parser.add_argument("--threads", type=non_negative_int, default=1,
                        help="torch threads (1, as training; 0: torch's default, all cores)")
    parser.add_argument("--updates", type=number_type(int, 1, 1_000_000), default=30, help="updates timed per round")
    parser.add_argument("--rounds", type=rounds_int, default=3, help="repeats of each measurement; the median is reported")
    parser.add_argument("--json", action="store_true", help="print the figures as JSON")
    args = parser.parse_args(argv)
    torchrl_logs_to_stderr()
    tune_allocator()
    import torch
    from torchrl.envs.utils import RandomPolicy

    from training.config import TrainConfig
    from training.networks import make_critic
    from training.sac_reference import SACLossReference
    from training.trainer import Trainer

    with tempfile.TemporaryDirectory() as tmp:
        try:  # a device that is not here, or settings out of range: one line
            config = TrainConfig(device=args.device, threads=args.threads)
            config.buffer.capacity = 20_000
            config.log.progress = False
            trainer = Trainer(config, tmp)
        except ValueError as err:
            parser.exit(2, f"bench_train: {err}\n")
        env = trainer.env
        # Collection: the actor picks actions, the batched environment steps (TorchRL rollout).
        collect_rates = []
        data = None
        for _ in range(args.rounds):
            t0 = time.perf_counter()
            with torch.no_grad():
                data = env.rollout(125, trainer.actor, break_when_any_done=False)
            collect_rates.append(data.numel() / (time.perf_counter() - t0))
        trainer.buffer.extend(data.reshape(-1).select(*trainer.stored_keys))
        random = env.rollout(250, RandomPolicy(env.action_spec), break_when_any_done=False)
        trainer.buffer.extend(random.reshape(-1).select(*trainer.stored_keys))
        # The reference's critics: the package's recurrent ones (a fresh pair, as the trainer's).
        critic = make_critic(config.network.lstm_hidden, config.network.mlp_hidden)
        reference = SACLossReference(
            trainer.actor, critic, env.action_spec,
            gamma=config.optim.gamma, tau=config.optim.tau, alpha=config.optim.alpha,
            auto_alpha=config.optim.auto_alpha, target_entropy=config.optim.target_entropy, lr=config.optim.lr,
            caps_kappa_temporal=config.caps.kappa_temporal, caps_kappa_spatial=config.caps.kappa_spatial,
            caps_sigma_spatial=config.caps.sigma_spatial, caps_batch_size=config.caps.batch_size,
            caps_action_weights=config.caps.action_weights)

        def time_updates(update) -> float:
            for _ in range(3):
                update(trainer.buffer.sample())
            if trainer.device.type == "cuda":
                torch.cuda.synchronize()
            t0 = time.perf_counter()
            for _ in range(args.updates):
                update(trainer.buffer.sample())
            if trainer.device.type == "cuda":
                torch.cuda.synchronize()
            return (time.perf_counter() - t0) / args.updates * 1e3

        # Interleaved rounds: the machine's load changes both timings alike, and the ratio keeps.
        update_ms, reference_ms = [], []
        for _ in range(args.rounds):
            update_ms.append(time_updates(trainer._update))
            reference_ms.append(time_updates(lambda b: reference.update(b.to(trainer.device))))
    result = {
        "device": args.device, "threads": torch.get_num_threads(), "num_envs": config.env.num_envs,
        "batch_size": config.buffer.batch_size,
        "update_ms": statistics.median(update_ms),
        "reference_update_ms": statistics.median(reference_ms),
        "update_to_reference": statistics.median(u / r for u, r in zip(update_ms, reference_ms)),
        "collect_env_steps_per_s": statistics.median(collect_rates),
    }
    # The default run's time per environment step and in total (evaluations not counted).
    result["updates_per_step"] = config.optim.updates_per_step
    per_step_s = config.optim.updates_per_step * result["update_ms"] / 1e3 + 1.0 / result["collect_env_steps_per_s"]
    result["default_run_hours_estimate"] = per_step_s * config.collector.total_frames / 3600
    print(json.dumps(result, indent=2) if args.json else "\n".join(f"{k:28s} {v}" for k, v in result.items()))
    return 0


if __name__ == "__main__":
    run_command(main, __file__)
