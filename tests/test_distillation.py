"""Distillation from an LQI (``jsbsim_env.control.teacher``, ``training.trainer``'s DAgger phase):
the teacher's labels, the mixture that flies while distilling, the critics' warm-up and SAC with
the teacher's steps in each batch."""

from __future__ import annotations

import copy
import csv
import gc
from dataclasses import replace

import numpy as np
import pytest
import torch
from tensordict import TensorDict

from jsbsim_env.control.lqi import LQIAttitudeController
from jsbsim_env.control.network import ActorNet
from jsbsim_env.control.observation import action_to_command, command_to_action
from jsbsim_env.control.policy import PolicyRuntime
from jsbsim_env.control.residual import RESIDUAL_BASES
from jsbsim_env.control.teacher import TEACHERS, TeacherStage, check_teacher
from jsbsim_env.task.attitude import AttitudeTaskBatch
from jsbsim_env.task.versions import VERSIONS
from training.checkpoint import checked_load, load_checkpoint
from training.config import TrainConfig
from training.sac import RecurrentSAC
from training.trainer import DISTILLED_POLICY, TeacherMix, Trainer, dagger_share

V3 = VERSIONS["SolarUAVAttitude-v3"]


def test_the_teachers_are_the_lqis_a_residual_rides_on_and_another_name_is_refused():
    assert TEACHERS == RESIDUAL_BASES
    check_teacher("")
    with pytest.raises(ValueError, match="teacher must be one of lqi, lqi_tuned, lqi_robust"):
        check_teacher("pid")
    with pytest.raises(ValueError, match="needs a teacher"):
        TeacherStage("")


def test_flying_the_teachers_actions_flies_exactly_its_lqi():
    # The teacher reads what the policy reads and holds what reached the actuators: flown by its own
    # labels, the task flies the LQI step for step (the same flight as the LQI flown by hand).
    task = replace(V3.task, external_throttle=0.0)
    taught, alone = AttitudeTaskBatch(1, task, teacher="lqi"), AttitudeTaskBatch(1, task)
    lqi = LQIAttitudeController()
    taught.reset_one(0, 5)
    alone.reset_one(0, 5)
    for _ in range(300):
        command = lqi.update(alone.cores[0].setup.control_interval_s, alone.measurements()[0], alone.goals[0])
        alone.step(np.clip(command_to_action(command, alone.action_scale), -1.0, 1.0)[None])
        taught.step(taught.teacher_actions())
    # The labels are float32, as the replay buffer keeps them: equal to their rounding.
    np.testing.assert_allclose(taught.states, alone.states, rtol=1e-6, atol=1e-6)
    with pytest.raises(RuntimeError, match="no teacher"):
        alone.teacher_actions()


def test_the_teacher_labels_the_state_the_policy_led_the_aircraft_to():
    # DAgger's labels: flown by something else, the teacher's label at each step is the LQI's from
    # the measurement and goal the policy reads, with the command that was flown as its delayed one.
    task = replace(V3.task, external_throttle=0.0)
    batch = AttitudeTaskBatch(1, task, teacher="lqi")
    lqi = LQIAttitudeController()
    batch.reset_one(0, 7)
    dt_s = batch.cores[0].setup.control_interval_s
    flown = np.array([[0.1, -0.05, 0.0, 0.6]])
    for _ in range(20):
        label = command_to_action(lqi.update(dt_s, batch.measurements()[0], batch.goals[0]), batch.action_scale)
        np.testing.assert_allclose(batch.teacher_actions()[0], np.clip(label, -1.0, 1.0), rtol=0.0, atol=1e-6)
        batch.step(flown)
        lqi.last_command = action_to_command(flown[0], batch.action_scale).tolist()


def test_set_std_gives_every_input_that_exploration_and_leaves_the_mean():
    torch.manual_seed(0)
    net = ActorNet(8, 16, obs_size=23, window=8)
    window = torch.randn(5, 8, 23)
    loc_before, _ = net(window)
    net.set_std(0.075)
    loc, scale = net(window)
    torch.testing.assert_close(loc, loc_before)
    torch.testing.assert_close(scale, torch.full_like(scale, 0.075), rtol=1e-5, atol=1e-6)


def test_the_teachers_share_falls_from_all_steps_to_none_and_the_mixture_follows_it():
    assert dagger_share(0, 100) == 1.0 and dagger_share(50, 100) == 0.5 and dagger_share(150, 100) == 0.0

    class Fixed(torch.nn.Module):
        in_keys, out_keys = ["observation"], ["action"]

        def forward(self, td):
            td["action"] = torch.zeros(td.batch_size[0], 4)
            return td

    mix = TeacherMix(Fixed())
    td = TensorDict({"observation": torch.zeros(1000, 3), "teacher_action": torch.ones(1000, 4)}, batch_size=[1000])
    for beta in (1.0, 0.0, 0.3):
        mix.beta = beta
        out = mix(td.clone())
        acted = out["teacher_acted"]
        assert torch.equal(out["action"][acted], torch.ones(int(acted.sum()), 4))
        assert torch.equal(out["action"][~acted], torch.zeros(int((~acted).sum()), 4))
        assert abs(acted.float().mean().item() - beta) < 0.06


@pytest.mark.parametrize(("changes", "words"), [
    ({"distill": {"teacher": "pid"}}, "distill.teacher must be one of"),
    ({"distill": {"teacher": "lqi"}, "env": {"task": "SolarUAVAttitude-v5"}}, "is a residual on an LQI"),
    ({"distill": {"teacher": "lqi", "dagger_frames": 200_000}}, "must exceed distill.dagger_frames"),
    ({"distill": {"teacher": "lqi", "start_std": 0.0}}, "distill.start_std must be")])
def test_a_distillation_that_cannot_run_is_refused_by_name(changes, words):
    data = TrainConfig().to_dict()
    for group, values in changes.items():
        data[group].update(values)
    with pytest.raises(ValueError, match=words):
        TrainConfig.from_dict(data)


def test_a_distilling_run_imitates_then_warms_its_critics_then_learns_with_the_teachers_steps(tmp_path, tiny_config):
    c = tiny_config(total_frames=256)
    c.env.task = V3.env_id
    c.distill.teacher = "lqi"
    c.distill.dagger_frames = 128
    c.distill.critic_warmup_updates = 10
    c.log.checkpoint_every_frames = 128
    run = tmp_path / "run"
    trainer = Trainer(c, run)
    trainer.train()
    assert trainer.counters.critics_warmed
    # Imitation (1 per step), the warm-up, then SAC (0.25 per step) after the distillation.
    assert trainer.counters.updates == 128 * 1 + 10 + 128 * c.optim.updates_per_step
    # The actor's Adam moments are SAC's alone: reset after imitation.
    first = next(trainer.sac.actor_net.parameters())
    assert int(trainer.sac.optimizer.state[first]["step"]) == 128 * c.optim.updates_per_step
    # SAC's actor loss kept the teacher's term.
    assert any(r["loss_imitation"] and r["loss_actor"] for r in csv.DictReader((run / "progress.csv").open()))
    # The offline buffer holds only steps the teacher flew: each action is its label.
    offline = trainer.offline_buffer[:]
    assert 0 < len(trainer.offline_buffer) < 128
    torch.testing.assert_close(offline["action"], offline["teacher_action"])
    # The network as distilled is kept, and flies with its task version's stack alone.
    runtime = PolicyRuntime(run / DISTILLED_POLICY, backend="torch")
    distilled = checked_load(run / DISTILLED_POLICY)["evaluation"]
    assert distilled["frames"] == 128 and trainer.counters.best_eval >= distilled["return_norm"]
    assert runtime.stack.residual is None and runtime.stack.settings.error_integrals
    data = load_checkpoint(run / "checkpoint.pt")
    kept, updates = len(trainer.offline_buffer), trainer.counters.updates
    assert len(data["offline_buffer"]["data"]) == kept
    del trainer  # its run folder's lock goes with it
    gc.collect()

    # A resumed run goes on with SAC (no second distillation or warm-up).
    more = tiny_config(total_frames=320)
    more.env.task, more.distill = c.env.task, c.distill
    resumed = Trainer(more, run, resume=True)
    assert resumed.counters.critics_warmed and len(resumed.offline_buffer) == kept
    resumed.train()
    assert resumed.counters.updates == updates + 64 * c.optim.updates_per_step


def test_the_imitation_term_keeps_the_actor_on_the_teacher_only_where_the_goal_is_as_flown(tmp_path, tiny_config):
    c = tiny_config(total_frames=256)
    c.env.task, c.distill.teacher, c.distill.dagger_frames = V3.env_id, "lqi", 128
    trainer = Trainer(c, tmp_path / "run")
    batch = trainer.env.rollout(40, break_when_any_done=False).reshape(-1)
    batch = batch.select(*trainer.stored_keys)
    batch["next", "achieved"] = batch["next", "achieved"] + 0.05  # relabelled goals move away from the flown ones
    seen = {}

    def update(b, actor=True):
        seen["batch"] = b
        return {}

    trainer.sac.update = update
    trainer.config.buffer.relabel_fraction = 0.5
    trainer._update(batch)
    relabelled = seen["batch"]
    mask = relabelled["imitation_mask"].bool()
    same = (relabelled["observation"] == batch["observation"]).flatten(1).all(1)
    assert torch.equal(mask, same) and 0 < int(mask.sum()) < len(batch)

    # SAC's actor update with the term moves the actions towards the teacher's; without it, not.
    batch["imitation_mask"] = torch.ones(len(batch))
    after = {}
    for weight in (0.0, 1e3):
        torch.manual_seed(0)
        sac = RecurrentSAC(copy.deepcopy(trainer.sac.actor_net), copy.deepcopy(list(trainer.sac.critics)), gamma=0.99,
                           tau=0.005, alpha=1e-6, auto_alpha=False, target_entropy=-4.0, lr=1e-3,
                           caps_kappa_temporal=0.0, caps_kappa_spatial=0.0, caps_sigma_spatial=0.05,
                           caps_batch_size=8, imitation_weight=weight)
        for _ in range(50):
            sac.update(batch)
        loc, _ = sac.actor_net(batch["observation"])
        after[weight] = (torch.tanh(loc) - batch["teacher_action"]).square().mean().item()
    assert after[1e3] < 0.8 * after[0.0]


def test_a_teacher_or_residual_base_the_aircraft_has_no_table_for_is_refused_in_one_line_before_any_work(
        small_aircraft, tmp_path, load_script, capsys):
    script = load_script("train_torchrl")
    for options in (["--env.task", V3.env_id, "--distill.teacher", "lqi_tuned"],
                    ["--env.task", "SolarUAVAttitude-v6"]):
        code = script.main(["--aircraft", str(small_aircraft), *options, "--log.run_root", str(tmp_path / "runs")])
        err = capsys.readouterr().err.strip()
        assert code == 2 and len(err.splitlines()) == 1 and "has no gain table" in err and "tune_classical" in err
        assert not (tmp_path / "runs").exists()
