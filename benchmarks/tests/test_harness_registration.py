"""The harness picks up a registered algorithm: the toy algorithm of tests/toy_algorithm.py runs through the zoo
bridge, the grid harness and the SB3 contract."""

import gymnasium as gym
import numpy as np
import optuna
from sb3_mbil import load_demonstrations


def test_a_toy_algorithm_is_picked_up_by_the_zoo_the_harness_and_the_contract(toy, tmp_path):
    from sb3_mbil import zoo
    from benchmarks.harness.grid import Run, run_one, tuned_settings

    zoo.check_registration()  # sampler, converter and hyperparameter file found from the folder
    trial = optuna.create_study(sampler=optuna.samplers.RandomSampler(seed=0)).ask()
    params = zoo.SAMPLERS["toy"](trial, 2, 1, {})
    assert set(params) >= {"learning_rate", "batch_size", "policy_kwargs"}
    assert tuned_settings("toy", "CartPole-v1")["n_timesteps"] == 20
    row = run_one(Run("toy", "CartPole-v1", 1, 0), n_episodes=2)
    assert row["algo"] == "toy" and row["gradient_steps"] == 20
    # the SB3 contract: learn, save, load (safe), the same predictions
    demos = load_demonstrations("CartPole-v1").sample(1, seed=0)
    model = toy("MlpPolicy", "CartPole-v1", expert_data=demos, seed=0, **params).learn(10)
    model.save(tmp_path / "toy.zip")
    loaded = toy.load(tmp_path / "toy.zip", safe=True)
    obs = np.stack([gym.make("CartPole-v1").observation_space.sample() for _ in range(8)])
    np.testing.assert_array_equal(model.predict(obs, deterministic=True)[0], loaded.predict(obs, deterministic=True)[0])
