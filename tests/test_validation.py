"""Held-out validation without the env: block splits, the ValidationCallback's logs, early stop and best model."""

import csv

import gymnasium as gym
import numpy as np
import pytest
import torch as th
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.logger import configure
from test_algorithms import FAST, NoStepping

from sb3_mbil import ALGORITHMS, BC, MBIL, ValidationCallback, as_demonstrations, load_demonstrations, split_blocks


@pytest.fixture(scope="module")
def demo():
    return load_demonstrations("CartPole-v1").sample(2, seed=0)


def test_blocks_partition_the_steps_and_pieces_keep_their_true_successors(demo):
    train, held = split_blocks(demo, 0.25, block_length=40, seed=3)
    assert train.n_steps + held.n_steps == demo.n_steps
    n_blocks = sum(-(-len(t) // 40) for t in demo)
    assert sum(-(-len(t) // 40) for t in held) >= 1 and held.n_steps <= round(0.25 * n_blocks) * 40
    # every (s, a, s') of a piece is a true transition of the original data
    originals = {o.tobytes() for t in demo for o in np.concatenate(
        [t.observations[:-1], t.observations[1:]], axis=1)}
    for part in (train, held):
        tr = part.transitions()
        pairs = np.concatenate([tr["observations"], tr["next_observations"]], axis=1)
        assert all(p.tobytes() in originals for p in pairs)
    # only a piece that ends its episode keeps the episode's end flags
    ends = [t for t in (*train, *held) if t.truncated or t.terminated]
    assert len(ends) == sum(t.truncated or t.terminated for t in demo)
    again = split_blocks(demo, 0.25, block_length=40, seed=3)
    assert [len(t) for t in again[1]] == [len(t) for t in held]  # seeded
    with pytest.raises(ValueError, match="holdout_fraction"):
        split_blocks(demo, 1.0)
    with pytest.raises(ValueError, match="at least 2 blocks"):
        split_blocks(load_demonstrations("CartPole-v1").sample(1, seed=0), 0.2, block_length=10_000)


@pytest.mark.parametrize("name", list(ALGORITHMS))
def test_validation_logs_held_out_losses_and_never_touches_the_env(name, demo, tmp_path):
    from sb3_mbil.experts.controllers import native_demo, native_env

    algo = ALGORITHMS[name]
    data = demo if native_env(algo) == "CartPole-v1" else native_demo(algo, 2)
    env = NoStepping(gym.make(native_env(algo)))
    model = algo("MlpPolicy", env, expert_data=data, seed=0, **FAST.get(name, {}))
    model.set_logger(configure(str(tmp_path), ["csv"]))
    cb = ValidationCallback(holdout_fraction=0.3, eval_freq=10, block_length=30)

    class Arm(BaseCallback):  # SB3's set-up reset the env once; from here on nothing may touch it
        def _on_training_start(self):
            NoStepping.armed = True

        def _on_step(self):
            return True

    try:
        model.learn(30, callback=[Arm(), cb], log_interval=10)
    finally:
        NoStepping.armed = False
    assert len(cb.history) == 3 and model.demonstrations().n_steps + cb.heldout.n_steps == as_demonstrations(data).n_steps
    with open(tmp_path / "progress.csv") as f:
        row = list(csv.DictReader(f))[-1]
    assert np.isfinite(float(row["validation/bc_loss"])) and np.isfinite(float(row["validation/best_bc_loss"]))
    if name == "mbil":  # MBIL fitted its flows on the training blocks only, and scores its balance loss
        assert model.flow_report["n_tuples"] == len(model.demonstrations().tuples()["observations"])
        assert np.isfinite(float(row["validation/balance_loss"]))


def test_early_stop_and_the_best_model(demo, tmp_path):
    cb = ValidationCallback(eval_freq=5, block_length=30, patience=2, min_delta=1e9, best_model_save_path=tmp_path,
                            restore_best=True)
    model = BC("MlpPolicy", "CartPole-v1", expert_data=demo, seed=0).learn(1000, callback=cb)
    # the first validation is the best (no later one improves by 1e9); two more, then the stop
    assert model.num_timesteps == 15 and cb.best_step == 5
    best = BC.load(tmp_path / "best_model.zip")
    assert best.num_timesteps == 5
    for k, v in best.policy.state_dict().items():  # restore_best put the best parameters back
        th.testing.assert_close(v, model.policy.state_dict()[k])
    with pytest.raises(ValueError, match="monitor: expected one of"):
        BC("MlpPolicy", "CartPole-v1", expert_data=demo).learn(5, callback=ValidationCallback(eval_freq=5, monitor="x"))


def test_mbil_monitor_the_balance_loss(demo):
    cb = ValidationCallback(eval_freq=10, block_length=30, monitor="balance_loss")
    MBIL("MlpPolicy", "CartPole-v1", expert_data=demo, seed=0, **FAST["mbil"]).learn(20, callback=cb)
    assert cb.best < float("inf") and all("balance_loss" in losses for _, losses in cb.history)


