"""Demonstrations: views that never cross an episode boundary, files, sampling, and bad input."""

import os

import gymnasium as gym
import numpy as np
import pytest
from gymnasium import spaces

from sb3_mbil import BC, MBIL, Demonstrations, Trajectory, as_demonstrations, load_demonstrations


def two_trajectories():
    a = Trajectory(np.arange(8, dtype=np.float32).reshape(4, 2), np.array([0, 1, 0]), terminated=True, episode_return=3.0)
    b = Trajectory(np.arange(100, 110, dtype=np.float32).reshape(5, 2), np.array([1, 1, 0, 1]), truncated=True)
    return Demonstrations([a, b], {"env_id": "Test-v0"})


def test_views_stay_inside_episodes():
    d = two_trajectories()
    pairs = d.pairs()
    assert len(pairs["observations"]) == 7
    tr = d.transitions()
    assert len(tr["observations"]) == 7
    np.testing.assert_array_equal(tr["dones"], [0, 0, 1, 0, 0, 0, 0])  # terminated, not truncated
    tup = d.tuples()
    assert len(tup["observations"]) == 2 + 3
    # every tuple's s' is the observation right after s in the same trajectory
    np.testing.assert_array_equal(tup["next_observations"] - tup["observations"], np.full((5, 2), 2.0))
    np.testing.assert_array_equal(tup["trajectory_index"], [0, 0, 1, 1, 1])
    np.testing.assert_array_equal(tup["next_actions"], [1, 0, 1, 0, 1])


def test_trajectory_without_final_observation():
    t = Trajectory(np.zeros((3, 2)), np.array([0, 1, 1]))
    d = Demonstrations([t])
    assert len(d.transitions()["observations"]) == 2
    assert len(d.tuples()["observations"]) == 2


def test_save_load_roundtrip(tmp_path):
    d = two_trajectories()
    path = d.save(tmp_path / "demo.npz")
    e = load_demonstrations(path)
    assert len(e) == 2 and e.metadata == {**d.metadata, "pool": str(path)}  # loading records where it came from
    for x, y in zip(d, e):
        np.testing.assert_array_equal(x.observations, y.observations)
        np.testing.assert_array_equal(x.actions, y.actions)
        assert (x.terminated, x.truncated) == (y.terminated, y.truncated)
    np.testing.assert_array_equal(e.episode_returns[:1], [3.0])
    assert np.isnan(e.episode_returns[1])
    np.testing.assert_array_equal(e.episode_lengths, [3, 4])


def test_failed_save_leaves_nothing(tmp_path, monkeypatch):
    d = two_trajectories()
    d.save(tmp_path / "demo.npz")
    good = (tmp_path / "demo.npz").read_bytes()

    def boom(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(np, "savez_compressed", boom)
    with pytest.raises(OSError):
        Demonstrations(list(d)[:1]).save(tmp_path / "demo.npz")
    assert (tmp_path / "demo.npz").read_bytes() == good  # old file intact
    assert os.listdir(tmp_path) == ["demo.npz"]  # no temporary left behind


def test_sample_is_deterministic():
    trajs = [Trajectory(np.full((3, 1), i, dtype=np.float32), np.array([0, 1])) for i in range(50)]
    d = Demonstrations(trajs)
    first = [t.observations[0, 0] for t in d.sample(5, seed=3)]
    again = [t.observations[0, 0] for t in d.sample(5, seed=3)]
    other = [t.observations[0, 0] for t in d.sample(5, seed=4)]
    assert first == again and first != other and len(set(first)) == 5
    with pytest.raises(ValueError, match="n: expected"):
        d.sample(51, seed=0)


# ---------------------------------------------------------------------- bad input
CARTPOLE_OBS = gym.make("CartPole-v1").observation_space
CARTPOLE_ACT = gym.make("CartPole-v1").action_space
PENDULUM = gym.make("Pendulum-v1")


def good_pair(n=5):
    return np.zeros((n + 1, 4), dtype=np.float32), np.zeros(n, dtype=np.int64)


@pytest.mark.parametrize(
    "data, match",
    [
        ([(np.full((6, 4), np.nan), np.zeros(5, dtype=int))], "observations: expected finite"),
        ([(np.full((6, 4), np.inf), np.zeros(5, dtype=int))], "observations: expected finite"),
        ([(np.zeros((6, 3)), np.zeros(5, dtype=int))], r"observations: expected per-step shape \(4,\)"),
        ([(np.zeros((6, 4), dtype=complex), np.zeros(5, dtype=int))], "observations: expected a real numeric dtype"),
        ([(np.array([["a"] * 4] * 6), np.zeros(5, dtype=int))], "observations: expected a real numeric dtype"),
        ([(np.zeros((6, 4)), np.full(5, 2))], r"actions: expected actions in \[0, 1\]"),
        ([(np.zeros((6, 4)), np.full(5, 0.5))], "actions: expected integer actions"),
        ([(np.zeros((9, 4)), np.zeros(5, dtype=int))], "observations: expected 5 or 6 rows"),
        ([], "expected at least one trajectory"),
        ([(np.zeros((1, 4)), np.zeros(0, dtype=int))], "actions: expected at least one action"),
        ([(np.zeros((6, 4), dtype=object), np.zeros(5, dtype=int))], "object array"),
        (np.zeros((6, 4)), "found a single array"),
        ([np.zeros(3)], r"expected an \(observations, actions\) pair"),
        (42, "expert_data: expected"),
    ],
)
def test_bad_data_raises_value_error(data, match):
    with pytest.raises(ValueError, match=match):
        as_demonstrations(data, CARTPOLE_OBS, CARTPOLE_ACT)


def test_box_actions_outside_bounds():
    obs = np.zeros((6, 3), dtype=np.float32)
    with pytest.raises(ValueError, match="within the action space bounds"):
        as_demonstrations([(obs, np.full((5, 1), 3.0))], PENDULUM.observation_space, PENDULUM.action_space)
    with pytest.raises(ValueError, match="actions: expected finite"):
        as_demonstrations([(obs, np.full((5, 1), np.nan))], PENDULUM.observation_space, PENDULUM.action_space)
    with pytest.raises(ValueError, match=r"per-step shape \(1,\)"):
        as_demonstrations([(obs, np.zeros((5, 2)))], PENDULUM.observation_space, PENDULUM.action_space)


@pytest.mark.parametrize("algo", [MBIL, BC])
def test_algorithms_refuse_bad_data_before_training(algo):
    with pytest.raises(ValueError, match="observations: expected finite"):
        algo("MlpPolicy", "CartPole-v1", expert_data=[(np.full((6, 4), np.nan), np.zeros(5, dtype=int))])
    with pytest.raises(ValueError, match="expert_data: expected demonstrations"):
        algo("MlpPolicy", "CartPole-v1").learn(5)


def test_mbil_refuses_trajectories_too_short_for_a_tuple():
    data = [good_pair(5), (np.zeros((2, 4), dtype=np.float32), np.zeros(1, dtype=np.int64))]
    model = MBIL("MlpPolicy", "CartPole-v1", expert_data=data)
    with pytest.raises(ValueError, match="trajectories of 2 or more steps"):
        model.learn(5)
    # BC needs only (s, a) pairs
    BC("MlpPolicy", "CartPole-v1", expert_data=data).learn(5)


def test_file_problems(tmp_path):
    with pytest.raises(FileNotFoundError):
        load_demonstrations(tmp_path / "missing.npz")
    np.savez_compressed(tmp_path / "keys.npz", observations=np.zeros((3, 4)))
    with pytest.raises(ValueError, match="missing"):
        load_demonstrations(tmp_path / "keys.npz")
    np.savez_compressed(
        tmp_path / "obj.npz",
        observations=np.array([np.zeros(4), "x"], dtype=object),
        actions=np.zeros(1),
        n_observations=np.array([2]),
        n_actions=np.array([1]),
        terminated=np.array([False]),
        truncated=np.array([False]),
    )
    with pytest.raises(ValueError, match="allow_pickle=False"):
        load_demonstrations(tmp_path / "obj.npz")
    (tmp_path / "junk.npz").write_bytes(b"not a zip file")
    with pytest.raises(ValueError, match="readable .npz"):
        load_demonstrations(tmp_path / "junk.npz")


def test_paths_are_accepted(tmp_path):
    path = Demonstrations([Trajectory(*good_pair())]).save(tmp_path / "d.npz")
    BC("MlpPolicy", "CartPole-v1", expert_data=str(path)).learn(3)
    BC("MlpPolicy", "CartPole-v1", expert_data=path).learn(3)


class DictObsEnv(gym.Env):
    observation_space = spaces.Dict({"x": spaces.Box(-1, 1, (2,))})
    action_space = spaces.Discrete(2)


class MultiDiscreteEnv(gym.Env):
    observation_space = spaces.Box(-1, 1, (2,))
    action_space = spaces.MultiDiscrete([2, 2])


@pytest.mark.parametrize("algo", [MBIL, BC])
@pytest.mark.parametrize("env, match", [(DictObsEnv, "observation_space: expected a gymnasium Box"), (MultiDiscreteEnv, "action_space: expected Discrete or Box")])
def test_unsupported_spaces(algo, env, match):
    with pytest.raises(ValueError, match=match):
        algo("MlpPolicy", env())


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(alpha=-1.0), "alpha: expected a finite number >= 0"),
        (dict(alpha=0.0, beta=0.0), "found both 0"),
        (dict(noise_grid=()), "noise_grid"),
        (dict(transition_noise_grid=(-0.1,)), "transition_noise_grid: expected a non-empty list"),
        (dict(validation_fraction=1.5), "validation_fraction"),
        (dict(bc_loss="hinge"), "bc_loss: expected one of"),
        (dict(bc_loss="mse"), "bc_loss: expected 'nll' or 'auto' for Discrete"),
        (dict(batch_size=0), "batch_size"),
    ],
)
def test_bad_hyperparameters(kwargs, match):
    with pytest.raises(ValueError, match=match):
        MBIL("MlpPolicy", "CartPole-v1", **kwargs)
