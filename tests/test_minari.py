"""Minari datasets in and out (a local store in a temporary folder; no network)."""

import gymnasium as gym
import minari
import numpy as np
import pytest

from sb3_mbil import MBIL, Demonstrations, load_demonstrations


@pytest.fixture
def store(tmp_path, monkeypatch):
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "minari"))
    return tmp_path / "minari"


def collect(dataset_id, n_episodes=3):
    """A dataset made with Minari's own data collector (a scripted CartPole controller)."""
    env = minari.DataCollector(gym.make("CartPole-v1"))
    for ep in range(n_episodes):
        obs, _ = env.reset(seed=ep)
        done = False
        while not done:
            obs, _, terminated, truncated, _ = env.step(int(obs[2] + 0.5 * obs[3] > 0))
            done = terminated or truncated
    return env.create_dataset(dataset_id=dataset_id, algorithm_name="scripted", author="test", author_email="t@t.t",
                              code_permalink="https://example.org", description="test")


def test_from_minari_keeps_every_episode(store):
    dataset = collect("cartpole/scripted-v0")
    demos = Demonstrations.from_minari("cartpole/scripted-v0")
    assert len(demos) == 3 and demos.metadata["env_id"] == "CartPole-v1"
    for episode, traj in zip(dataset.iterate_episodes(), demos):
        np.testing.assert_array_equal(traj.observations, episode.observations)  # T + 1 observations
        np.testing.assert_array_equal(traj.actions, episode.actions)
        assert traj.terminated == bool(episode.terminations[-1]) and traj.truncated == bool(episode.truncations[-1])
        assert traj.episode_return == pytest.approx(float(np.sum(episode.rewards)))
    # the same data by name, wherever expert data is accepted
    model = MBIL("MlpPolicy", "CartPole-v1", expert_data="minari:cartpole/scripted-v0", flow_max_steps=20,
                 noise_grid=(0.1,), seed=0).learn(20)
    assert model.demonstrations().n_steps == demos.n_steps


def test_to_minari_round_trip_without_a_recoverable_env(store):
    demos = load_demonstrations("CartPole-v1").sample(2, seed=0)
    env = gym.make("CartPole-v1")
    demos.metadata.pop("env_id", None)  # as for data whose env cannot be made here
    demos.to_minari("ours/cartpole-v0", observation_space=env.observation_space, action_space=env.action_space)
    back = Demonstrations.from_minari("ours/cartpole-v0")
    assert "env_id" not in back.metadata
    for a, b in zip(demos, back):
        np.testing.assert_array_equal(a.observations, b.observations)
        np.testing.assert_array_equal(a.actions, b.actions)
        assert (a.terminated, a.truncated) == (b.terminated, b.truncated)
        assert b.episode_return == pytest.approx(a.episode_return)


def test_minari_errors_name_what_is_wrong(store):
    with pytest.raises(ValueError, match=r"expected a Minari dataset id in the local store \(\[\]\), found 'nope/none-v0'"):
        load_demonstrations("minari:nope/none-v0")
    with pytest.raises(ValueError, match="env: expected an env id"):
        Demonstrations(load_demonstrations("CartPole-v1").sample(1, seed=0).trajectories).to_minari("x/y-v0")
