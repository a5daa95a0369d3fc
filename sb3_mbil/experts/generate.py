"""Expert agents from the RL Zoo and expert demonstrations generated with them.

Sources of an expert:

* ``"hub"``: the RL Zoo's pretrained agent ``sb3/<algo>-<env>`` on the Hugging Face Hub, through
  ``huggingface_sb3``; a copy already in the local hub cache is used without the network. When the
  hub cannot be reached (checked in about a second), one log line says so and the local zoo
  training below is used instead.
* ``"zoo"``: train the same agent locally with rl_zoo3's own shipped hyperparameters, through
  rl_zoo3's own training command (one torch thread), keeping the best checkpoint of its
  ``EvalCallback``. Runs are cached by (algo, env, seed), so a second call reuses them.
* a path to a saved SB3 model (``.zip``), with ``--algo``.

An expert is accepted only when its mean return over ``n_eval_episodes`` reaches the env's
threshold; a zoo-trained expert below it is retrained with the next seed.
"""

from __future__ import annotations

import json
import logging
import os
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from sb3_mbil.common.demonstrations import Demonstrations, Trajectory
from sb3_mbil.experts.agents import DETERMINISTIC_ACTORS, VALUE_BASED, Expert, algo_of, load_expert_file, load_hub_expert, noisy_actions
from sb3_mbil.experts.specs import EXPERTS, expert_spec
from sb3_mbil.experts.zoo_training import refuse_zoo_run, train_zoo_expert, zoo_exploration_noise
from sb3_mbil.version import __version__


logger = logging.getLogger("sb3_mbil.experts")


# ---------------------------------------------------------------------- rollouts
def rollout(expert: Expert, n_episodes: int, seed: int, n_envs: int = 16, progress: bool = False,
            env_kwargs: dict[str, Any] | None = None) -> Demonstrations:
    """Run the expert for ``n_episodes`` (episode i reset with seed + i); raw observations are stored."""
    envs = [gym.make(expert.env_id, **(env_kwargs or {})) for _ in range(min(n_envs, n_episodes))]
    results: dict[int, Trajectory] = {}
    state: list[dict | None] = [None] * len(envs)
    next_ep = 0
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=n_episodes, desc=f"{expert.env_id} episodes", unit="ep")

    def start(k: int) -> None:
        nonlocal next_ep
        if next_ep >= n_episodes:
            state[k] = None
            return
        obs, _ = envs[k].reset(seed=seed + next_ep)
        state[k] = {"ep": next_ep, "obs": [obs], "act": [], "ret": 0.0}
        next_ep += 1

    for k in range(len(envs)):
        start(k)
    while any(s is not None for s in state):
        live = [k for k, s in enumerate(state) if s is not None]
        actions = expert.act(np.stack([state[k]["obs"][-1] for k in live]))
        for k, action in zip(live, actions):
            s = state[k]
            obs, reward, terminated, truncated, _ = envs[k].step(action)
            s["obs"].append(obs)
            s["act"].append(action)
            s["ret"] += float(reward)
            if terminated or truncated:
                results[s["ep"]] = Trajectory(
                    np.array(s["obs"]), np.array(s["act"]), terminated=terminated, truncated=truncated, episode_return=s["ret"]
                )
                if bar is not None:
                    bar.update(1)
                start(k)
    if bar is not None:
        bar.close()
    return Demonstrations([results[i] for i in range(n_episodes)], {"env_id": expert.env_id})


def evaluate_expert(expert: Expert, n_episodes: int = 100, seed: int = 10**6) -> tuple[float, float, float]:
    """Mean and std of the expert's return over ``n_episodes`` (seeds apart from the pool's), and the share of the
    episodes that ran to the time limit (cut by it, not ended in a terminal state)."""
    episodes = rollout(expert, n_episodes, seed)
    returns = episodes.episode_returns
    full = np.mean([t.truncated and not t.terminated for t in episodes])
    return float(returns.mean()), float(returns.std()), float(full)


def get_expert(env_id: str, source: str = "hub", algo: str | None = None, seed: int = 0, min_return: float | None = None,
               n_eval_episodes: int = 100, max_attempts: int = 5, n_timesteps: int | None = None,
               min_full_fraction: float | None = None) -> tuple[Expert, dict]:
    """An accepted expert for ``env_id`` from ``source`` (``"hub"``, ``"zoo"`` or a model path).

    Returns the expert and an evaluation record. Raises ``ValueError`` when no expert reaches the
    return threshold, or runs the required share of its episodes to the time limit (``min_full_fraction``, by
    default the env's :class:`ExpertSpec`): a weak expert is never used silently.
    """
    first = EXPERTS.get(env_id)
    algo = algo or (first.algo if first else None)
    if algo is None:
        raise ValueError(f"algo: expected the RL Zoo algorithm of the expert for {env_id!r} (no default), found None")
    spec = expert_spec(env_id, algo)
    threshold = min_return if min_return is not None else (first.min_return if first else None)
    if threshold is None:
        logger.warning("no return threshold for %s: the expert is accepted whatever it scores (pass min_return)", env_id)
    zoo_kwargs = {"save_freq": spec.save_freq, "stop_at_return": spec.stop_at_return,
                  "n_evaluations": spec.n_evaluations, "min_full_fraction": spec.min_full_fraction,
                  "stop_eval_episodes": n_eval_episodes, "max_timesteps": spec.max_timesteps,
                  "late_hyperparams": spec.late_hyperparams} \
        if spec else {}
    min_full = min_full_fraction if min_full_fraction is not None else (spec.min_full_fraction if spec else 0.0)
    attempts = []
    attempt_seed = seed
    for _ in range(max_attempts):
        if source == "hub":
            try:
                expert = load_hub_expert(env_id, algo)
            except LookupError as e:
                logger.warning("Hugging Face Hub unavailable (%s): training the expert locally with rl_zoo3 instead", e)
                source = "zoo"
                expert = train_zoo_expert(env_id, algo, attempt_seed, n_timesteps, **zoo_kwargs)
        elif source == "zoo":
            expert = train_zoo_expert(env_id, algo, attempt_seed, n_timesteps, **zoo_kwargs)
        else:
            expert = load_expert_file(source, env_id, algo, Path(source).parent / env_id / "vecnormalize.pkl")
        t0 = time.time()
        mean, std, full = evaluate_expert(expert, n_eval_episodes)
        record = {"source": expert.source, "algo": algo, "seed": attempt_seed, "eval_mean_return": mean,
                  "eval_std_return": std, "eval_full_fraction": full, "eval_episodes": n_eval_episodes,
                  "min_return": threshold, "min_full_fraction": min_full, "eval_seconds": round(time.time() - t0, 1)}
        attempts.append(record)
        logger.info("expert %s: mean return %.1f +- %.1f over %d episodes, %.0f%% to the time limit (threshold %s, %.0f%%)",
                    expert.source, mean, std, n_eval_episodes, 100 * full, threshold, 100 * min_full)
        if (threshold is None or mean >= threshold) and full >= min_full:
            record["attempts"] = attempts[:-1]
            return expert, record
        if source != "zoo":
            break
        # a run that stopped early (its stop check passed) continues on its remaining budget; otherwise the next seed
        if not refuse_zoo_run(env_id, algo, attempt_seed, n_timesteps, zoo_kwargs.get("max_timesteps")):
            attempt_seed += 1
    raise ValueError(
        f"expert for {env_id}: expected a mean return >= {threshold} over {n_eval_episodes} episodes"
        + (f" with {min_full:.0%} of them to the time limit" if min_full else "")
        + f", found {json.dumps([(a['source'], round(a['eval_mean_return'], 1), a['eval_full_fraction']) for a in attempts])}"
    )


def generate_demonstrations(env_id: str, n_trajectories: int, source: str = "hub", seed: int = 0, out: str | os.PathLike | None = None,
                            algo: str | None = None, min_return: float | None = None, n_eval_episodes: int = 100,
                            progress: bool = True, command: str | None = None,
                            sampled_actions: bool = False, action_noise: float = 0.0,
                            dqn_epsilon: float = 0.05) -> tuple[Demonstrations, Path | None]:
    """Get an accepted expert, roll it out ``n_trajectories`` times (episode i seeded ``seed + i``), save atomically.

    :param sampled_actions: record actions sampled from the expert's policy (torch seeded with
        ``seed``) instead of its deterministic actions; the acceptance test stays deterministic.
        A deterministic actor (TD3, DDPG) samples as it explores in its RL Zoo training: Gaussian noise at the zoo's
        ``noise_std`` on the action scaled to [-1, 1], clipped (:func:`zoo_exploration_noise`); SB3's
        ``predict(deterministic=False)`` returns its deterministic action.
    :param dqn_epsilon: with ``sampled_actions``, a value-based expert (DQN, QR-DQN), whose policy is greedy, samples
        epsilon-greedily at this epsilon (uniform over all actions, seeded with ``seed``, independently per episode),
        a setting whose return stays within 10% of the greedy one for the shipped DQN experts (docs/experts.md).
        SB3's own ``predict(deterministic=False)`` is not used for them: it draws one coin for the whole batch of
        envs from numpy's unseeded global generator, at the exploration rate the checkpoint happened to be saved with
    :param action_noise: a noisy demonstrator: the expert's deterministic action with noise at this level, executed
        and recorded (:func:`noisy_actions`; epsilon for Discrete actions, a share of the action range for Box);
        the noise generator is seeded with ``seed``
    """
    if not isinstance(n_trajectories, int) or n_trajectories < 1:
        raise ValueError(f"n_trajectories: expected a positive integer, found {n_trajectories!r}")
    noisy_actions(np.zeros(1), gym.spaces.Box(-1, 1, (1,)), action_noise, np.random.default_rng(0))  # checks the level
    if sampled_actions and action_noise:
        raise ValueError("action_noise: expected 0 with sampled_actions (noise goes on the deterministic action), "
                         f"found {action_noise!r}")
    expert, record = get_expert(env_id, source, algo, seed, min_return, n_eval_episodes)
    sampling = None
    if sampled_actions and algo_of(expert) in VALUE_BASED:
        action_noise, sampling = dqn_epsilon, f"epsilon-greedy over Q, epsilon={dqn_epsilon:g}"
        noisy_actions(np.zeros(1), gym.spaces.Box(-1, 1, (1,)), action_noise, np.random.default_rng(0))
    elif sampled_actions and algo_of(expert) in DETERMINISTIC_ACTORS:
        action_noise = zoo_exploration_noise(env_id, algo_of(expert))
        sampling = (f"the RL Zoo's exploration noise: Gaussian, std {2 * action_noise:g} on the action scaled to "
                    f"[-1, 1] ({action_noise:g} of the range), clipped")
    elif sampled_actions:
        import torch as th

        th.manual_seed(seed)
        expert.deterministic = False
        sampling = "the policy's own distribution"
    if action_noise:
        expert.action_noise = float(action_noise)
        expert.noise_rng = np.random.default_rng(seed)
    demos = rollout(expert, n_trajectories, seed, progress=progress)
    returns, lengths = demos.episode_returns, demos.episode_lengths
    import gymnasium
    import stable_baselines3

    demos.metadata.update({
        "env_id": env_id,
        "expert": record,
        "seed": seed,
        "n_trajectories": n_trajectories,
        "mean_return": float(returns.mean()),
        "std_return": float(returns.std()),
        "mean_length": float(lengths.mean()),
        "expert_actions": "sampled" if sampled_actions else ("noisy" if action_noise else "deterministic"),
        "action_noise": 0.0 if sampled_actions else float(action_noise),
        **({"sampling": sampling} if sampling else {}),
        "command": command,
        "versions": {"sb3_mbil": __version__, "gymnasium": gymnasium.__version__, "stable_baselines3": stable_baselines3.__version__},
        "created": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    })
    path = demos.save(out) if out is not None else None
    return demos, path
