"""Expert agents and shipped pools: hub path (offline, against a local hub cache), local zoo training, bad input."""

import logging
import os
import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest
import torch
from stable_baselines3 import DQN

from sb3_mbil import load_demonstrations
from sb3_mbil.common.demonstrations import available_pools
from sb3_mbil.experts import EXPERTS, SECOND_EXPERTS, generate_demonstrations, get_expert, load_expert_file

# Shipped pools: the acceptance thresholds of their experts, and their size.
SHIPPED = {env: spec.min_return for env, spec in EXPERTS.items()}
POOL_SIZE = {"CartPole-v1": 1000, "Acrobot-v1": 1000, "LunarLander-v3": 1000}  # MuJoCo pools: 50 trajectories
SECOND_POOLS = SECOND_EXPERTS  # each classic-control env's second expert, pool "<env>-<algo>"


@pytest.fixture(scope="module")
def dqn_zip(tmp_path_factory):
    path = tmp_path_factory.mktemp("model") / "dqn-CartPole-v1.zip"
    DQN("MlpPolicy", "CartPole-v1", learning_starts=0, seed=0).save(path)
    return path


@pytest.mark.parametrize("env_id, expert", [(e, None) for e in SHIPPED if e in available_pools()]
                         + [(e, a) for e, a in SECOND_POOLS.items() if f"{e}-{a}" in available_pools()])
def test_shipped_pools_match_their_envs(env_id, expert):
    d = load_demonstrations(env_id, expert=expert)
    env = gym.make(env_id)
    assert len(d) == POOL_SIZE.get(env_id, 50)
    d.check_spaces(env.observation_space, env.action_space)
    assert d.metadata["env_id"] == env_id
    assert d.episode_returns.mean() >= SHIPPED[env_id]
    a, b = d.sample(3, seed=0), d.sample(3, seed=0)
    assert a.metadata["sampled"]["indices"] == b.metadata["sampled"]["indices"]


def test_unknown_pool_name_lists_available():
    with pytest.raises(ValueError, match=r"shipped pool name \["):
        load_demonstrations("NoSuchEnv-v0")


def make_hub_cache(root, model_zip, org="sb3", name="dqn-CartPole-v1"):
    rev = "0123456789abcdef0123456789abcdef01234567"
    repo = root / f"models--{org}--{name}"
    (repo / "refs").mkdir(parents=True)
    (repo / "refs" / "main").write_text(rev)
    snap = repo / "snapshots" / rev
    snap.mkdir(parents=True)
    (snap / f"{name}.zip").write_bytes(model_zip.read_bytes())
    return root


@pytest.mark.parametrize("offline_flag", ["1", None])
def test_hub_path_reads_a_local_hub_cache(tmp_path, dqn_zip, offline_flag):
    cache = make_hub_cache(tmp_path / "hub", dqn_zip)
    env = {k: v for k, v in os.environ.items() if k != "HF_HUB_OFFLINE"}
    env["HF_HUB_CACHE"] = str(cache)
    if offline_flag:
        env["HF_HUB_OFFLINE"] = offline_flag
    code = "from sb3_mbil.experts import load_hub_expert; e = load_hub_expert('CartPole-v1', 'dqn'); print(e.source)"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "hub:sb3/dqn-CartPole-v1"


def test_unreachable_hub_falls_back_to_local_zoo_training(tmp_path, monkeypatch, caplog):
    """A tiny real rl_zoo3 training of DQN on CartPole, through rl_zoo3's own command line."""
    monkeypatch.setenv("SB3_MBIL_CACHE", str(tmp_path))
    monkeypatch.setenv("HF_HUB_OFFLINE", "1")
    caplog.set_level(logging.INFO, logger="sb3_mbil.experts")
    expert, record = get_expert("CartPole-v1", "hub", seed=3, min_return=0.0, n_eval_episodes=3, n_timesteps=200)
    assert expert.source == "zoo:dqn seed=3"
    assert record["eval_episodes"] == 3
    assert any("training the expert locally with rl_zoo3 instead" in r.message for r in caplog.records)
    assert (tmp_path / "zoo" / "dqn-CartPole-v1-seed3-n200" / "dqn" / "CartPole-v1_1" / "best_model.zip").is_file()


def test_expert_that_falls_is_refused(dqn_zip):
    """An untrained DQN on CartPole-v1 ends every episode long before the time limit (500 steps)."""
    expert, record = get_expert("CartPole-v1", str(dqn_zip), algo="dqn", min_return=0.0, n_eval_episodes=2,
                                min_full_fraction=0.0)
    assert record["eval_full_fraction"] == 0.0
    with pytest.raises(ValueError, match="100% of them to the time limit"):
        get_expert("CartPole-v1", str(dqn_zip), algo="dqn", min_return=0.0, n_eval_episodes=2, min_full_fraction=1.0)


@pytest.mark.parametrize("min_full_fraction, stops", [(0.0, True), (1.0, False)])
def test_stop_on_return_can_require_episodes_to_the_time_limit(min_full_fraction, stops):
    from stable_baselines3 import PPO

    from sb3_mbil.common.callbacks import StopTrainingOnReturn

    model = PPO("MlpPolicy", "CartPole-v1", n_steps=64, batch_size=64, n_epochs=1, seed=0)
    with torch.no_grad():  # always push left: the pole falls within a few dozen steps, on every machine
        model.policy.action_net.weight.zero_()
        model.policy.action_net.bias.copy_(torch.tensor([10.0, -10.0]))
    stop = StopTrainingOnReturn(min_return=-1e9, eval_freq=64, n_eval_episodes=2, min_full_fraction=min_full_fraction,
                                verbose=0)
    model.learn(256, callback=stop)
    assert stop.last_full_fraction == 0.0  # an untrained pole falls long before the time limit (500 steps)
    assert (model.num_timesteps < 256) == stops


def test_a_stop_check_ends_once_too_many_episodes_fell():
    """A 100-episode check that requires 95% to the time limit has failed after 6 falls: with chunks of 4 episodes
    it stops after the second chunk."""
    from stable_baselines3 import PPO

    from sb3_mbil.common.callbacks import StopTrainingOnReturn

    model = PPO("MlpPolicy", "CartPole-v1", n_steps=64, batch_size=64, n_epochs=1, seed=0)
    with torch.no_grad():  # always push left
        model.policy.action_net.weight.zero_()
        model.policy.action_net.bias.copy_(torch.tensor([10.0, -10.0]))
    stop = StopTrainingOnReturn(min_return=-1e9, eval_freq=64, n_eval_episodes=100, min_full_fraction=0.95,
                                chunk_episodes=4, verbose=0)
    model.learn(64, callback=stop)
    assert stop.last_eval_episodes == 8 and stop.last_full_fraction == 0.0
    with pytest.raises(ValueError, match="chunk_episodes: expected an integer >= 1, found 0"):
        StopTrainingOnReturn(min_return=0.0, chunk_episodes=0)


def test_second_expert_pools_by_name_and_algorithm():
    from sb3_mbil.common.demonstrations import pool_name

    assert pool_name("LunarLander-v3") == "LunarLander-v3"
    assert pool_name("LunarLander-v3", "ppo") == "LunarLander-v3"  # the first pool's expert
    assert load_demonstrations("CartPole-v1", expert="dqn").metadata["pool"] == "CartPole-v1"
    for env_id, algo in SECOND_POOLS.items():
        if f"{env_id}-{algo}" in available_pools():
            d = load_demonstrations(env_id, expert=algo.upper())
            assert d.metadata["pool"] == f"{env_id}-{algo}"
            assert d.metadata["expert"]["algo"] == algo
    with pytest.raises(ValueError, match=r"expert: expected one of \['ppo'"):
        load_demonstrations("LunarLander-v3", expert="trpo")


def test_corrupt_or_mismatched_models_are_refused(tmp_path, dqn_zip):
    junk = tmp_path / "junk.zip"
    junk.write_bytes(b"PK\x03\x04 not really a zip")
    with pytest.raises(ValueError, match="SB3 cannot load"):
        load_expert_file(junk, "CartPole-v1", "dqn")
    with pytest.raises(ValueError, match="expected a model for Acrobot-v1"):
        load_expert_file(dqn_zip, "Acrobot-v1", "dqn")
    with pytest.raises(FileNotFoundError):
        load_expert_file(tmp_path / "missing.zip", "CartPole-v1", "dqn")


def test_weak_expert_is_refused_and_leaves_no_pool(tmp_path, dqn_zip):
    out = tmp_path / "pool.npz"
    with pytest.raises(ValueError, match="expected a mean return >= 1000000"):
        generate_demonstrations("CartPole-v1", 5, str(dqn_zip), out=out, algo="dqn", min_return=1e6, n_eval_episodes=2,
                                progress=False)
    assert not out.exists() and os.listdir(tmp_path) == []


def test_generate_script(tmp_path, dqn_zip):
    out = tmp_path / "pool.npz"
    proc = subprocess.run(
        [sys.executable, "scripts/generate_expert_data.py", "--env", "CartPole-v1", "--n-trajectories", "4", "--source",
         str(dqn_zip), "--algo", "dqn", "--min-return", "0", "--eval-episodes", "2", "--out", str(out)],
        capture_output=True, text=True, timeout=300, cwd=os.path.dirname(os.path.dirname(__file__)),
    )
    assert proc.returncode == 0, proc.stderr
    assert "return" in proc.stdout and "episode length" in proc.stdout
    d = load_demonstrations(out)
    assert len(d) == 4 and np.all(np.isfinite(d.episode_returns))
    assert d.metadata["expert"]["algo"] == "dqn"


def test_a_fresh_install_trains_mbil_on_three_lunarlander_trajectories():
    from sb3_mbil import MBIL

    demos = load_demonstrations("LunarLander-v3").sample(3, seed=0)
    model = MBIL("MlpPolicy", "LunarLander-v3", expert_data=demos, seed=0, flow_max_steps=40, noise_grid=(0.1,),
                 fit_transition=True)
    model.learn(20)
    report = model.flow_report
    # the binary leg-contact dimensions must not make the flows' likelihood blow up
    assert np.isfinite(report["transition_heldout_ll"]) and report["transition_heldout_ll"] < 100


def test_imitation_converters_roundtrip():
    from dataclasses import dataclass

    from sb3_mbil.common.imitation_compat import from_imitation, to_imitation

    @dataclass(frozen=True)
    class ImitationTrajectory:  # the fields and constructor of imitation.data.types.Trajectory
        obs: np.ndarray
        acts: np.ndarray
        infos: object
        terminal: bool

    @dataclass(frozen=True)
    class ImitationTrajectoryWithRew(ImitationTrajectory):
        rews: np.ndarray = None

    d = load_demonstrations("CartPole-v1").sample(2, seed=1)
    converted = to_imitation(d, trajectory_class=ImitationTrajectory)
    assert len(converted) == 2 and converted[0].obs.shape[0] == converted[0].acts.shape[0] + 1
    back = from_imitation(converted)
    for a, b in zip(d, back):
        np.testing.assert_array_equal(a.observations, b.observations)
        np.testing.assert_array_equal(a.actions, b.actions)
        assert a.terminated == b.terminated
    with_rew = [ImitationTrajectoryWithRew(t.obs, t.acts, None, t.terminal, np.ones(len(t.acts))) for t in converted]
    np.testing.assert_array_equal(from_imitation(with_rew).episode_returns, d.episode_lengths)
    with pytest.raises(ValueError, match="expected an imitation Trajectory"):
        from_imitation([object()])


def test_to_imitation_without_imitation_says_what_to_pass():
    from sb3_mbil.common.imitation_compat import to_imitation

    try:
        import imitation  # noqa: F401
    except ImportError:
        with pytest.raises(ImportError, match="pass trajectory_class"):
            to_imitation(load_demonstrations("CartPole-v1").sample(1, seed=0))
    else:
        converted = to_imitation(load_demonstrations("CartPole-v1").sample(1, seed=0))
        assert type(converted[0]).__module__.startswith("imitation")


def test_sampled_actions_pool(tmp_path):
    """--sampled-actions records the stochastic expert's actions, reproducibly for a seed, and says so."""
    from stable_baselines3 import SAC

    model_zip = tmp_path / "sac-Pendulum-v1.zip"
    SAC("MlpPolicy", "Pendulum-v1", seed=0).save(model_zip)
    kw = dict(algo="sac", min_return=-1e9, n_eval_episodes=1, progress=False)
    det, _ = generate_demonstrations("Pendulum-v1", 2, str(model_zip), seed=3, **kw)
    sampled, path = generate_demonstrations("Pendulum-v1", 2, str(model_zip), seed=3, out=tmp_path / "s.npz",
                                            sampled_actions=True, **kw)
    again, _ = generate_demonstrations("Pendulum-v1", 2, str(model_zip), seed=3, sampled_actions=True, **kw)
    assert det.metadata["expert_actions"] == "deterministic"
    assert load_demonstrations(path).metadata["expert_actions"] == "sampled"
    np.testing.assert_array_equal(det[0].observations[0], sampled[0].observations[0])  # same resets
    assert not np.allclose(det[0].actions, sampled[0].actions)
    np.testing.assert_array_equal(sampled[0].actions, again[0].actions)
    space = gym.make("Pendulum-v1").action_space
    assert np.all(sampled[0].actions >= space.low) and np.all(sampled[0].actions <= space.high)


def test_sampled_actions_of_a_deterministic_actor(tmp_path):
    """A TD3 expert's sampled actions carry its RL Zoo exploration noise (SB3's predict would return its mean)."""
    from stable_baselines3 import TD3

    from sb3_mbil.experts.zoo_training import zoo_exploration_noise

    model_zip = tmp_path / "td3-Pendulum-v1.zip"
    TD3("MlpPolicy", "Pendulum-v1", seed=0).save(model_zip)
    kw = dict(algo="td3", min_return=-1e9, n_eval_episodes=1, progress=False)
    det, _ = generate_demonstrations("Pendulum-v1", 1, str(model_zip), seed=3, **kw)
    sampled, _ = generate_demonstrations("Pendulum-v1", 1, str(model_zip), seed=3, sampled_actions=True, **kw)
    level = zoo_exploration_noise("Pendulum-v1", "td3")
    assert level == 0.05  # td3.yml's noise_std 0.1 on [-1, 1]
    assert sampled.metadata["expert_actions"] == "sampled" and "exploration noise" in sampled.metadata["sampling"]
    np.testing.assert_array_equal(det[0].observations[0], sampled[0].observations[0])
    assert not np.allclose(det[0].actions, sampled[0].actions)
    with pytest.raises(ValueError, match="env: expected an env with RL Zoo hyperparameters for td3"):
        zoo_exploration_noise("CartPole-v1", "td3")


@pytest.mark.parametrize("level", [0.0, 0.2, 1.0])
def test_noisy_actions_follow_their_definition(level):
    from sb3_mbil.experts.agents import noisy_actions

    rng = np.random.default_rng(0)
    expert = np.full(20_000, 2, dtype=np.int64)
    out = noisy_actions(expert, gym.spaces.Discrete(4), level, rng)
    assert out.dtype == expert.dtype
    # epsilon-greedy: the expert's action with probability 1 - eps + eps / n, each other one with eps / n
    assert abs(np.mean(out != 2) - level * 3 / 4) < 0.01
    box = gym.spaces.Box(np.array([-1.0, 0.0]), np.array([1.0, 4.0]), dtype=np.float32)
    mean = np.tile(np.array([0.0, 2.0], dtype=np.float32), (20_000, 1))
    noisy = noisy_actions(mean, box, level, rng)
    assert noisy.dtype == np.float32 and np.all(noisy >= box.low) and np.all(noisy <= box.high)
    if 0 < level < 0.3:  # little clipping: the std is level x (high - low) per dimension
        np.testing.assert_allclose(noisy.std(axis=0), level * (box.high - box.low), rtol=0.05)
    for bad in (-0.1, 1.5, float("nan"), True, "0.1"):
        with pytest.raises(ValueError, match="action_noise: expected a number in"):
            noisy_actions(mean, box, bad, rng)


def test_noisy_demonstrator_pool(tmp_path, dqn_zip):
    """--action-noise executes and records the noisy action, reproducibly for a seed, and says so."""
    kw = dict(algo="dqn", min_return=-1e9, n_eval_episodes=1, progress=False)
    det, _ = generate_demonstrations("CartPole-v1", 3, str(dqn_zip), seed=3, **kw)
    noisy, path = generate_demonstrations("CartPole-v1", 3, str(dqn_zip), seed=3, out=tmp_path / "n.npz",
                                          action_noise=0.5, **kw)
    again, _ = generate_demonstrations("CartPole-v1", 3, str(dqn_zip), seed=3, action_noise=0.5, **kw)
    meta = load_demonstrations(path).metadata
    assert (meta["expert_actions"], meta["action_noise"]) == ("noisy", 0.5)
    assert det.metadata["action_noise"] == 0.0
    np.testing.assert_array_equal(noisy[0].actions, again[0].actions)
    assert not all(np.array_equal(a.actions, b.actions) for a, b in zip(det, noisy))
    with pytest.raises(ValueError, match="action_noise: expected 0 with sampled_actions"):
        generate_demonstrations("CartPole-v1", 1, str(dqn_zip), seed=3, sampled_actions=True, action_noise=0.1, **kw)


def test_pools_of_sampled_actions_by_selector():
    from sb3_mbil.common.demonstrations import pool_name

    assert {f"{env_id}-sampled" for env_id in EXPERTS} <= set(available_pools())  # every benchmark env ships one
    for env_id in EXPERTS:
        assert pool_name(env_id, actions="sampled") == f"{env_id}-sampled"
        assert pool_name(env_id, EXPERTS[env_id].algo, actions="sampled") == f"{env_id}-sampled"
        d = load_demonstrations(env_id, actions="sampled")
        assert d.metadata["expert_actions"] == "sampled" and d.metadata["pool"] == f"{env_id}-sampled"
    with pytest.raises(ValueError, match=r"actions: expected one of \['deterministic', 'sampled'\], found 'noisy'"):
        load_demonstrations("CartPole-v1", actions="noisy")
    with pytest.raises(ValueError, match="actions: expected a shipped pool 'NoSuchEnv-v0-sampled'"):
        load_demonstrations("NoSuchEnv-v0", actions="sampled")


@pytest.mark.slow  # zoo training in subprocesses, 20-40 s each: run by CI with -m slow
def test_interrupted_zoo_training_resumes_from_its_checkpoint(tmp_path, monkeypatch):
    """An interrupted run (checkpoint + replay buffer, no final model) continues with rl_zoo3's -i."""
    import json

    from sb3_mbil.experts import train_zoo_expert

    monkeypatch.setenv("SB3_MBIL_CACHE", str(tmp_path))
    train_zoo_expert("CartPole-v1", "dqn", seed=0, n_timesteps=400, save_freq=200, n_evaluations=2)
    folder = tmp_path / "zoo" / "dqn-CartPole-v1-seed0-n400"
    run1 = folder / "dqn" / "CartPole-v1_1"
    assert (run1 / "rl_model_200_steps.zip").is_file() and (run1 / "rl_model_replay_buffer_200_steps.pkl").is_file()
    # interrupt: as if the session ended while writing the checkpoint at 400 steps (model, no replay buffer)
    (run1 / "CartPole-v1.zip").unlink()
    (run1 / "rl_model_replay_buffer_400_steps.pkl").unlink()
    expert = train_zoo_expert("CartPole-v1", "dqn", seed=0, n_timesteps=400, save_freq=200, n_evaluations=2)
    run2 = folder / "dqn" / "CartPole-v1_2"
    assert (run2 / "CartPole-v1.zip").is_file()
    assert json.loads((folder / "progress.json").read_text())["steps_before"]["CartPole-v1_2"] == 200
    log = folder.with_suffix(".log").read_text()
    assert "Loading pretrained agent" in log and "Loading replay buffer" in log
    # the continuation trains from its first step (no second warm-up of random actions)
    assert DQN.load(run2 / "CartPole-v1.zip").learning_starts == 0
    assert DQN.load(run1 / "rl_model_200_steps.zip").learning_starts > 0
    assert expert.source == "zoo:dqn seed=0"


@pytest.mark.slow  # zoo training in subprocesses, 20-40 s each: run by CI with -m slow
def test_late_hyperparameters_take_over_at_their_checkpoints(tmp_path, monkeypatch):
    """``late_hyperparams=((steps, {name: value}), ...)``: each run stops at the checkpoint of the next switch and the
    training continues from it with that switch's settings added to the earlier ones; a session that ends between two
    runs does not take the first run's model for the end."""
    import json

    from sb3_mbil.experts import zoo_training

    monkeypatch.setenv("SB3_MBIL_CACHE", str(tmp_path))
    kwargs = dict(seed=0, n_timesteps=600, save_freq=200, n_evaluations=3)
    switches = ((200, {"learning_rate": 1e-5}), (400, {"gamma": 0.9}))
    with pytest.raises(ValueError, match="late_hyperparams: expected step counts that are multiples of save_freq"):
        zoo_training.train_zoo_expert("CartPole-v1", "dqn", late_hyperparams=((150, {"learning_rate": 1e-5}),), **kwargs)
    original = zoo_training._run_logged
    monkeypatch.setattr(zoo_training, "_run_logged", lambda *a: (original(*a), exec("raise KeyboardInterrupt"))[0])
    with pytest.raises(KeyboardInterrupt):  # the session ends right after the first run
        zoo_training.train_zoo_expert("CartPole-v1", "dqn", late_hyperparams=switches, **kwargs)
    monkeypatch.setattr(zoo_training, "_run_logged", original)
    folder = tmp_path / "zoo" / "dqn-CartPole-v1-seed0-n600"
    run1, run2, run3 = (folder / "dqn" / f"CartPole-v1_{i}" for i in (1, 2, 3))
    assert (run1 / "CartPole-v1.zip").is_file() and (run1 / "rl_model_replay_buffer_200_steps.pkl").is_file()
    assert not run2.exists()
    zoo_training.train_zoo_expert("CartPole-v1", "dqn", late_hyperparams=switches, **kwargs)
    progress = json.loads((folder / "progress.json").read_text())
    assert progress["steps_before"] == {"CartPole-v1_1": 0, "CartPole-v1_2": 200, "CartPole-v1_3": 400}
    first, second, third = (DQN.load(run / "CartPole-v1.zip") for run in (run1, run2, run3))
    assert first.policy.optimizer.param_groups[0]["lr"] != 1e-5 and first.gamma == second.gamma == 0.99
    assert second.policy.optimizer.param_groups[0]["lr"] == 1e-5  # it trained at the late rate
    assert third.policy.optimizer.param_groups[0]["lr"] == 1e-5 and third.gamma == 0.9  # both switches


def test_a_reward_set_from_the_start_trains_on_it_and_evaluates_on_the_env_as_it_is(tmp_path, monkeypatch):
    """A switch at 0 with ``env_kwargs`` (tried for Ant-v4's TD3: a healthy reward of 5): the training env pays the
    changed reward from the first step, and the zoo's evaluations stay on the env as it is (acceptance and the pool
    too)."""
    from stable_baselines3.common.save_util import load_from_pkl

    from sb3_mbil.experts import zoo_training

    monkeypatch.setenv("SB3_MBIL_CACHE", str(tmp_path))
    # CartPole-v1 pays 1 a step; Sutton and Barto's reward pays 0, and -1 on the step that ends an episode
    zoo_training.train_zoo_expert("CartPole-v1", "dqn", seed=0, n_timesteps=400, save_freq=200, n_evaluations=2,
                              late_hyperparams=((0, {"env_kwargs": {"sutton_barto_reward": True}}),))
    run = tmp_path / "zoo" / "dqn-CartPole-v1-seed0-n400" / "dqn" / "CartPole-v1_1"
    rewards = load_from_pkl(run / "rl_model_replay_buffer_400_steps.pkl").rewards[:400, 0]
    assert set(np.unique(rewards)) == {-1.0, 0.0}  # the changed reward, episodes ending on the way
    with np.load(run / "evaluations.npz") as ev:
        assert (ev["results"] > 0).all()  # evaluated on CartPole-v1's own reward


@pytest.mark.slow  # minutes under load: run by CI with -m slow
def test_a_carried_checkpoint_continues_the_training_on_an_empty_cache(tmp_path, monkeypatch):
    """Machines that start with an empty cache: the newest checkpoint, exported without its replay buffer to a folder
    that can be committed, is where the next machine's training continues (on a buffer its own policy refills)."""
    import json

    from stable_baselines3.common.save_util import load_from_pkl

    from sb3_mbil.experts import export_zoo_checkpoint, import_zoo_checkpoint, train_zoo_expert

    first, second, carried = tmp_path / "first", tmp_path / "second", tmp_path / "carried"
    monkeypatch.setenv("SB3_MBIL_CACHE", str(first))
    with pytest.raises(ValueError, match="checkpoint: expected a checkpoint"):
        export_zoo_checkpoint("CartPole-v1", "dqn", carried, n_timesteps=400)
    train_zoo_expert("CartPole-v1", "dqn", seed=0, n_timesteps=400, save_freq=200, n_evaluations=2)
    run1 = first / "zoo" / "dqn-CartPole-v1-seed0-n400" / "dqn" / "CartPole-v1_1"
    for name in ("CartPole-v1.zip", "rl_model_400_steps.zip", "rl_model_replay_buffer_400_steps.pkl"):
        (run1 / name).unlink()  # interrupted after its checkpoint at 200 steps
    (carried / "rl_model_100_steps.zip").parent.mkdir()
    (carried / "rl_model_100_steps.zip").write_bytes(b"older")  # an older carried checkpoint is replaced
    assert export_zoo_checkpoint("CartPole-v1", "dqn", carried, n_timesteps=400) == carried / "rl_model_200_steps.zip"
    assert sorted(p.name for p in carried.iterdir()) == ["rl_model_200_steps.zip"]  # no replay buffer

    monkeypatch.setenv("SB3_MBIL_CACHE", str(second))
    assert import_zoo_checkpoint("CartPole-v1", "dqn", carried, n_timesteps=400, refill_steps=150)
    folder = second / "zoo" / "dqn-CartPole-v1-seed0-n400"
    # the replay buffer is refilled by the checkpoint's own policy: 150 transitions of real CartPole steps
    buffer = load_from_pkl(folder / "dqn" / "CartPole-v1_1" / "rl_model_replay_buffer_200_steps.pkl")
    assert buffer.size() == 150 and np.isin(buffer.actions[:150], [0, 1]).all() and buffer.dones[:150].sum() >= 1
    going_on = ~buffer.dones[:149, 0].astype(bool)  # within an episode, each next state is the next step's state
    assert np.allclose(buffer.next_observations[:149][going_on], buffer.observations[1:150][going_on])
    expert = train_zoo_expert("CartPole-v1", "dqn", seed=0, n_timesteps=400, save_freq=200, n_evaluations=2)
    progress = json.loads((folder / "progress.json").read_text())
    assert progress["steps_before"] == {"CartPole-v1_1": 0, "CartPole-v1_2": 200}  # 200 steps left, not 400
    log = folder.with_suffix(".log").read_text()
    assert "Loading pretrained agent" in log and "Loading replay buffer" in log
    assert DQN.load(folder / "dqn" / "CartPole-v1_2" / "CartPole-v1.zip").learning_starts == 0  # no random warm-up
    assert expert.source == "zoo:dqn seed=0"
    # a cache at least as far (here: finished) is left alone; so is an empty carried folder
    assert not import_zoo_checkpoint("CartPole-v1", "dqn", carried, n_timesteps=400)
    assert not import_zoo_checkpoint("CartPole-v1", "dqn", tmp_path / "empty", n_timesteps=400)
    # the command line (the default run folder: the zoo's own budget)
    out = subprocess.run([sys.executable, "scripts/zoo_checkpoint.py", "import", "--env", "CartPole-v1", "--algo",
                          "dqn", "--dir", str(carried)], capture_output=True, text=True,
                         env={**os.environ, "SB3_MBIL_CACHE": str(tmp_path / "third")})
    assert out.returncode == 0 and "continues from" in out.stdout, out.stderr
    assert (tmp_path / "third" / "zoo" / "dqn-CartPole-v1-seed0" / "dqn" / "CartPole-v1_1" / "rl_model_200_steps.zip").is_file()


def test_resumable_checkpoints_are_whole_and_pruned(tmp_path):
    from sb3_mbil.common.callbacks import ResumableCheckpoint

    model = DQN("MlpPolicy", "CartPole-v1", learning_starts=0, buffer_size=1000, seed=0)
    model.learn(300, callback=ResumableCheckpoint(save_freq=50, save_path=str(tmp_path), keep=2))
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "rl_model_250_steps.zip", "rl_model_300_steps.zip",
        "rl_model_replay_buffer_250_steps.pkl", "rl_model_replay_buffer_300_steps.pkl",
    ]
    DQN.load(tmp_path / "rl_model_300_steps.zip").load_replay_buffer(tmp_path / "rl_model_replay_buffer_300_steps.pkl")
    with pytest.raises(ValueError, match="keep: expected an integer >= 1"):
        ResumableCheckpoint(save_freq=50, save_path=str(tmp_path), keep=0)


def test_stop_at_return_ends_zoo_training_early(tmp_path, monkeypatch, caplog):
    import logging

    from sb3_mbil.experts import train_zoo_expert

    monkeypatch.setenv("SB3_MBIL_CACHE", str(tmp_path))
    with caplog.at_level(logging.INFO, logger="sb3_mbil.experts"):
        train_zoo_expert("CartPole-v1", "dqn", seed=0, n_timesteps=2000, n_evaluations=10, stop_at_return=-1e9)
    log = (tmp_path / "zoo" / "dqn-CartPole-v1-seed0-n2000.log").read_text()
    assert "Stopping: mean return" in log and "at 200 steps" in log
    # training is not silent: each of rl_zoo3's evaluations is reported as progress
    assert any(r.getMessage().startswith("expert dqn on CartPole-v1: 200 / 2000 steps, evaluation return")
               for r in caplog.records), [r.getMessage() for r in caplog.records]


def test_the_stop_check_uses_the_acceptance_episode_count(monkeypatch):
    """Training stops where acceptance would pass: with a full-episode share, the stop check runs on as many
    episodes as acceptance (Walker2d-v4 once stopped at 20 of 20 to the time limit and then had 91% of 100)."""
    from sb3_mbil.experts import generate

    seen = {}

    def fake_train(env_id, algo, seed, n_timesteps, **kwargs):
        seen.update(kwargs)
        raise RuntimeError("stop here")

    monkeypatch.setattr(generate, "train_zoo_expert", fake_train)
    with pytest.raises(RuntimeError, match="stop here"):
        generate.get_expert("Walker2d-v4", source="zoo", algo="sac", n_eval_episodes=100)
    assert seen["stop_eval_episodes"] == 100 and seen["min_full_fraction"] == 0.95
    assert seen["max_timesteps"] == 2_000_000  # beyond the zoo's 1e6 steps, where the 95% rule needs it


def test_another_algorithms_training_settings_reach_the_zoo(monkeypatch):
    """``--algo tqc`` (or ``sac``) for Ant-v4 trains with its own entry of ``OTHER_SPECS`` (checkpoints, the 95% stop
    rule; SAC with its hyperparameter switches), not with the TD3 expert's; an algorithm with no entry trains with the
    zoo's settings alone; the acceptance threshold is the env's either way."""
    from sb3_mbil.experts import generate

    seen = []

    def fake_train(env_id, algo, seed, n_timesteps, **kwargs):
        seen.append((algo, kwargs))
        raise RuntimeError("stop here")

    monkeypatch.setattr(generate, "train_zoo_expert", fake_train)
    for algo in ("tqc", "sac", "td3", "ddpg"):
        with pytest.raises(RuntimeError, match="stop here"):
            generate.get_expert("Ant-v4", source="zoo", algo=algo, n_eval_episodes=100)
    (tqc, tqc_kwargs), (_, sac_kwargs), (_, td3_kwargs), (_, ddpg_kwargs) = seen
    assert tqc == "tqc" and tqc_kwargs["min_full_fraction"] == 0.95 and tqc_kwargs["save_freq"] == 25_000
    assert tqc_kwargs["late_hyperparams"] == ()
    assert sac_kwargs["late_hyperparams"] == ((1_350_000, {"learning_rate": 1e-4}), (1_525_000, {"gamma": 0.995}))
    assert td3_kwargs["min_full_fraction"] == 0.95 and td3_kwargs["late_hyperparams"] == ()
    assert ddpg_kwargs == {}
    assert generate.expert_spec("Ant-v4").algo == "td3" and generate.expert_spec("CartPole-v1", "ppo") is None


@pytest.mark.slow  # zoo training in subprocesses, 20-40 s each: run by CI with -m slow
def test_a_refused_run_that_stopped_early_continues_on_its_budget(tmp_path, monkeypatch):
    """Acceptance refused the model a stop check passed (Walker2d-v4: 20 of 20 episodes to the time limit, then 91%
    of 100): the run continues from its checkpoint on the remaining budget instead of starting a new seed."""
    import json

    from sb3_mbil.experts import zoo_training

    monkeypatch.setenv("SB3_MBIL_CACHE", str(tmp_path))
    kwargs = dict(seed=0, n_timesteps=2000, save_freq=200, n_evaluations=10, stop_at_return=-1e9)
    zoo_training.train_zoo_expert("CartPole-v1", "dqn", **kwargs)
    folder = tmp_path / "zoo" / "dqn-CartPole-v1-seed0-n2000"
    assert (folder / "dqn" / "CartPole-v1_1" / "CartPole-v1.zip").is_file()
    assert zoo_training.refuse_zoo_run("CartPole-v1", "dqn", 0, 2000)
    expert = zoo_training.train_zoo_expert("CartPole-v1", "dqn", **kwargs)
    progress = json.loads((folder / "progress.json").read_text())
    assert progress["refused"] == ["CartPole-v1_1"] and progress["steps_before"]["CartPole-v1_2"] == 200
    assert (folder / "dqn" / "CartPole-v1_2" / "CartPole-v1.zip").is_file() and expert.source == "zoo:dqn seed=0"
    assert "Loading pretrained agent" in folder.with_suffix(".log").read_text()
    # a run that used its whole budget cannot continue: the caller moves to the next seed
    zoo_training.train_zoo_expert("CartPole-v1", "dqn", seed=1, n_timesteps=200, save_freq=100, n_evaluations=2)
    assert not zoo_training.refuse_zoo_run("CartPole-v1", "dqn", 1, 200)


