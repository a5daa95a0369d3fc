"""The distribution-shift harness (benchmarks/harness/shift.py) on real envs."""

import gymnasium as gym
import numpy as np
import pytest

from benchmarks.harness.results import read_result_rows
from benchmarks.harness.shift import (
    SHIFT_KINDS,
    SHIFT_LEVELS,
    DistributionShift,
    expert_stds,
    perturb_initial_state,
    plot_shift,
    run_shifts,
    shift_table,
)


@pytest.mark.parametrize("env_id", ["LunarLander-v3", "Hopper-v4"])
def test_initial_state_moves_by_the_noise_in_observation_units(env_id):
    env = gym.make(env_id)
    obs, _ = env.reset(seed=3)
    np.testing.assert_allclose(perturb_initial_state(env, np.zeros_like(obs)), obs, atol=1e-6)  # the env's own formula
    noise = np.random.default_rng(0).normal(size=obs.shape) * 0.05
    moved = perturb_initial_state(env, noise)
    if env_id == "LunarLander-v3":  # the lander's velocities only
        expected = obs.copy()
        expected[[2, 3, 5]] += noise[[2, 3, 5]]
        np.testing.assert_allclose(moved, expected, atol=1e-4)
    else:
        np.testing.assert_allclose(moved, obs + noise, atol=1e-6)
    env.step(env.action_space.sample())  # the perturbed state is a state the env runs from


def test_observation_noise_changes_what_the_policy_sees_not_the_episode():
    obs_std, _ = expert_stds("LunarLander-v3")
    plain = gym.make("LunarLander-v3")
    noisy = DistributionShift(gym.make("LunarLander-v3"), "observation", 0.1, obs_std, None, seed=0)
    o1, _ = plain.reset(seed=5)
    o2, _ = noisy.reset(seed=5)
    assert not np.allclose(o1, o2)
    for a in [0, 1, 2, 3, 2, 2]:
        r1 = plain.step(a)[1]
        r2 = noisy.step(a)[1]
        assert r1 == r2


def test_action_noise_levels():
    ones = np.ones(3), np.ones(1)
    env, ref = DistributionShift(gym.make("Pendulum-v1"), "action", 0.0, *ones), gym.make("Pendulum-v1")
    env.reset(seed=1)
    ref.reset(seed=1)
    a = np.array([0.5], dtype=np.float32)
    assert env.step(a)[0].tolist() == ref.step(a)[0].tolist()  # level 0: the action itself
    noisy = DistributionShift(gym.make("Pendulum-v1"), "action", 0.1, *ones)
    noisy.reset(seed=1)
    ref.reset(seed=1)
    assert noisy.step(a)[0].tolist() != ref.step(a)[0].tolist()

    def states(level):  # CartPole, always action 0; at level 1 every action is a uniformly random one
        env = DistributionShift(gym.make("CartPole-v1"), "action", level, np.ones(4), None, seed=0)
        env.reset(seed=0)
        return [env.step(0)[0].tolist() for _ in range(8)]

    assert states(0.0) != states(1.0)
    with pytest.raises(ValueError, match="kind: expected one of"):
        DistributionShift(gym.make("CartPole-v1"), "gravity", 0.1, np.ones(4), None)
    with pytest.raises(ValueError, match="level: expected a finite number >= 0, found -0.1"):
        DistributionShift(gym.make("CartPole-v1"), "action", -0.1, np.ones(4), None)
    with pytest.raises(ValueError, match="env: expected a MuJoCo env or LunarLander"):
        DistributionShift(gym.make("CartPole-v1"), "initial", 0.1, np.ones(4), None).reset(seed=0)


def test_run_shifts_writes_every_kind_and_level_once(tmp_path):
    csv = tmp_path / "shift.csv"
    variants = {"bc": ("bc", {})}
    assert run_shifts(variants, ["LunarLander-v3"], [0], str(csv), n_episodes=2, n_updates=20) == 1
    rows = read_result_rows(csv)
    assert len(rows) == len(SHIFT_KINDS) * len(SHIFT_LEVELS)
    clean = {r["mean_return"] for r in rows if float(r["level"]) == 0}
    assert len(clean) == 1  # one unperturbed evaluation, shared by the kinds
    assert run_shifts(variants, ["LunarLander-v3"], [0], str(csv), n_episodes=2, n_updates=20) == 0
    assert "| LunarLander-v3 | observation | 0.1 |" in shift_table(rows)
    plot_shift(rows, str(tmp_path / "shift.png"))
    assert (tmp_path / "shift.png").read_bytes()[:4] == b"\x89PNG"
