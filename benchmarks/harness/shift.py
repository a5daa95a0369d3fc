"""Distribution shift at evaluation: perturbed initial states, noisy observations, noisy actions.

The paper's appendix claims MBIL handles distribution shift better than other strictly batch methods.
This harness trains a policy once (the algorithm's zoo settings, N expert trajectories drawn with the
run's seed) and evaluates it under each kind of shift at each level, the level being a fraction of each
dimension's standard deviation in the expert pool:

* ``initial``: the initial state is moved by Gaussian noise of ``level * std`` (observation units)
  before the first observation (MuJoCo: qpos/qvel through ``set_state``; LunarLander: the lander's
  linear and angular velocity, the state the env lets one set without re-building bodies);
* ``observation``: the policy sees ``s + N(0, (level * std_s)^2)`` at every step (the env does not);
* ``action``: Box: the env receives ``a + N(0, (level * std_a)^2)``, clipped to the bounds; Discrete:
  a uniformly random action with probability ``level``.

Returns are the env's own rewards of the true (unperturbed-observation) episode.
"""

from __future__ import annotations

import itertools
import math
import time
from dataclasses import asdict, dataclass
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

SHIFT_KINDS = ("initial", "observation", "action")
SHIFT_LEVELS = (0.0, 0.01, 0.03, 0.1)
SHIFT_COLUMNS = ["algo", "env", "seed", "kind", "level", "mean_return", "std_return", "n_episodes", "n_trajectories",
                 "settings", "commit"]
SHIFT_KEY = ("algo", "env", "seed")


def perturb_initial_state(env: gym.Env, noise: np.ndarray) -> np.ndarray:
    """Move the state of a freshly reset env by ``noise`` (observation units); return the new observation."""
    base = env.unwrapped
    noise = np.asarray(noise, dtype=np.float64).reshape(-1)
    if hasattr(base, "set_state") and hasattr(base, "init_qpos"):  # MuJoCo: obs = (qpos[k:], qvel)
        nq, nv = base.model.nq, base.model.nv
        n_pos = len(noise) - nv
        if not 0 < n_pos <= nq:
            raise ValueError(f"env: expected a MuJoCo observation of qpos[k:] and qvel (no contact forces), found "
                             f"{len(noise)} dimensions for nq={nq}, nv={nv}")
        qpos, qvel = base.data.qpos.copy(), base.data.qvel.copy()
        qpos[nq - n_pos:] += noise[:n_pos]
        qvel += noise[n_pos:]
        base.set_state(qpos, qvel)
        return base._get_obs()
    if type(base).__name__ == "LunarLander":
        from gymnasium.envs.box2d import lunar_lander as ll

        half_w, half_h = ll.VIEWPORT_W / ll.SCALE / 2, ll.VIEWPORT_H / ll.SCALE / 2
        lander = base.lander
        vx, vy = lander.linearVelocity
        lander.linearVelocity = (float(vx + noise[2] * ll.FPS / half_w), float(vy + noise[3] * ll.FPS / half_h))
        lander.angularVelocity = float(lander.angularVelocity + noise[5] * ll.FPS / 20.0)
        pos, vel = lander.position, lander.linearVelocity
        return np.array([
            (pos.x - half_w) / half_w, (pos.y - (base.helipad_y + ll.LEG_DOWN / ll.SCALE)) / half_h,
            vel.x * half_w / ll.FPS, vel.y * half_h / ll.FPS, lander.angle, 20.0 * lander.angularVelocity / ll.FPS,
            1.0 if base.legs[0].ground_contact else 0.0, 1.0 if base.legs[1].ground_contact else 0.0,
        ], dtype=np.float32)
    raise ValueError(f"env: expected a MuJoCo env or LunarLander for initial-state shift, found {type(base).__name__}")


class DistributionShift(gym.Wrapper):
    """One kind of shift at one level (see the module docstring)."""

    def __init__(self, env: gym.Env, kind: str, level: float, obs_std: np.ndarray, act_std: np.ndarray | None,
                 seed: int = 0):
        super().__init__(env)
        if kind not in SHIFT_KINDS:
            raise ValueError(f"kind: expected one of {SHIFT_KINDS}, found {kind!r}")
        if not (isinstance(level, (int, float)) and math.isfinite(level) and level >= 0):
            raise ValueError(f"level: expected a finite number >= 0, found {level!r}")
        self.kind, self.level = kind, float(level)
        self.obs_std = np.asarray(obs_std, dtype=np.float64).reshape(-1)
        self.act_std = None if act_std is None else np.asarray(act_std, dtype=np.float64).reshape(-1)
        self.rng = np.random.default_rng(seed)

    def _noisy(self, obs: np.ndarray) -> np.ndarray:
        if self.kind != "observation" or self.level == 0:
            return obs
        return (obs + self.rng.normal(size=obs.shape) * self.level * self.obs_std).astype(obs.dtype)

    def reset(self, **kwargs):
        obs, info = self.env.reset(**kwargs)
        if self.kind == "initial" and self.level > 0:
            obs = perturb_initial_state(self.env, self.rng.normal(size=self.obs_std.shape) * self.level * self.obs_std)
            obs = np.asarray(obs, dtype=self.observation_space.dtype)
        return self._noisy(obs), info

    def step(self, action):
        if self.kind == "action" and self.level > 0:
            if isinstance(self.action_space, spaces.Discrete):
                if self.rng.random() < self.level:
                    action = int(self.rng.integers(self.action_space.n))
            else:
                noisy = np.asarray(action, dtype=np.float64) + self.rng.normal(size=np.shape(action)) * self.level * self.act_std
                action = np.clip(noisy, self.action_space.low, self.action_space.high).astype(self.action_space.dtype)
        obs, reward, terminated, truncated, info = self.env.step(action)
        return self._noisy(obs), reward, terminated, truncated, info


def evaluate_under_shift(model, env_id: str, kind: str, level: float, obs_std, act_std, n_episodes: int = 50,
                         seed: int = 0, n_envs: int = 10) -> np.ndarray:
    """Returns of the deterministic policy over ``n_episodes`` episodes under one shift."""
    from stable_baselines3.common.evaluation import evaluate_policy
    from stable_baselines3.common.monitor import Monitor
    from stable_baselines3.common.vec_env import DummyVecEnv

    n_envs = max(1, min(n_envs, n_episodes))
    env = DummyVecEnv([lambda i=i: DistributionShift(Monitor(gym.make(env_id)), kind, level, obs_std, act_std,
                                                     seed=seed + 7919 * i) for i in range(n_envs)])
    env.seed(seed)
    returns, _ = evaluate_policy(model, env, n_eval_episodes=n_episodes, deterministic=True, return_episode_rewards=True)
    env.close()
    return np.asarray(returns, dtype=np.float64)


def expert_stds(env_id: str) -> tuple[np.ndarray, np.ndarray | None]:
    """Per-dimension standard deviations of the observations and (Box) actions in the env's shipped pool."""
    from sb3_mbil import load_demonstrations

    pairs = load_demonstrations(env_id).pairs()
    obs_std = pairs["observations"].reshape(len(pairs["observations"]), -1).std(0)
    acts = pairs["actions"]
    act_std = None if acts.dtype.kind in "iu" else acts.reshape(len(acts), -1).std(0)
    return obs_std, act_std


@dataclass(frozen=True)
class ShiftRun:
    variant: str
    env: str
    seed: int

    def key(self) -> tuple[str, ...]:
        return tuple(str(v) for v in asdict(self).values())


def run_shift(run: ShiftRun, variants: dict[str, tuple[str, dict[str, Any]]], n_episodes: int = 50,
              n_trajectories: int = 1, levels=SHIFT_LEVELS, kinds=SHIFT_KINDS, commit: str | None = None,
              n_updates: int | None = None) -> list[dict[str, Any]]:
    """Train one variant once and evaluate it under every (kind, level); one row per (kind, level)."""
    import torch as th

    from sb3_mbil import ALGORITHMS
    from benchmarks.harness.curves import drawn_demonstrations
    from benchmarks.harness.grid import git_commit, tuned_settings

    th.set_num_threads(1)
    algo, variant_settings = variants[run.variant]
    settings = tuned_settings(algo, run.env, variant_settings)
    steps = int(float(settings.pop("n_timesteps"))) if n_updates is None else n_updates
    settings.pop("n_timesteps", None)
    model = ALGORITHMS[algo]("MlpPolicy", run.env, expert_data=drawn_demonstrations(run.env, run.seed, n_trajectories),
                             seed=run.seed, **settings)
    t0 = time.perf_counter()
    model.learn(steps)
    obs_std, act_std = expert_stds(run.env)
    recorded = repr(sorted({"algo": algo, **settings, "n_timesteps": steps,
                            "train_seconds": round(time.perf_counter() - t0, 1)}.items()))
    rows = []
    clean = None
    for kind, level in itertools.product(kinds, levels):
        if level == 0 and clean is not None:
            returns = clean  # every kind at level 0 is the same unperturbed evaluation
        else:
            returns = evaluate_under_shift(model, run.env, kind, level, obs_std, act_std, n_episodes,
                                           seed=2_000_000 + 1000 * run.seed)
            clean = returns if level == 0 else clean
        rows.append({"algo": run.variant, "env": run.env, "seed": run.seed, "kind": kind, "level": level,
                     "mean_return": float(np.mean(returns)), "std_return": float(np.std(returns)),
                     "n_episodes": len(returns), "n_trajectories": n_trajectories, "settings": recorded,
                     "commit": commit or git_commit()})
    return rows


def run_shifts(variants, envs, seeds, csv_path: str, **kwargs) -> int:
    """Every (variant, env, seed) not yet in the CSV, one after the other; rows of one run are written together."""
    from benchmarks.harness.grid import git_commit
    from benchmarks.harness.results import append_rows, finished_keys

    done = finished_keys(csv_path, SHIFT_KEY)
    todo = [ShiftRun(v, e, int(s)) for s, e, v in itertools.product(seeds, envs, variants)
            if ShiftRun(v, e, int(s)).key() not in done]
    commit = git_commit()
    for run in todo:
        append_rows(csv_path, run_shift(run, variants, commit=commit, **kwargs), SHIFT_COLUMNS)
    return len(todo)


def shift_table(rows: list[dict]) -> str:
    """Mean return over seeds (and its standard error) per env, kind, level and variant (markdown)."""
    cells: dict[tuple, list[float]] = {}
    for r in rows:
        cells.setdefault((r["env"], r["kind"], float(r["level"]), r["algo"]), []).append(float(r["mean_return"]))
    variants = sorted({k[3] for k in cells})
    lines = ["| env | shift | level | " + " | ".join(variants) + " |", "|---|---|---|" + "---|" * len(variants)]
    for env, kind, level in sorted({k[:3] for k in cells}, key=lambda k: (k[0], SHIFT_KINDS.index(k[1]), k[2])):
        out = []
        for v in variants:
            x = cells.get((env, kind, level, v))
            out.append("" if not x else f"{np.mean(x):.0f} +- {np.std(x, ddof=1) / np.sqrt(len(x)) if len(x) > 1 else 0:.0f} ({len(x)})")
        lines.append(f"| {env} | {kind} | {level:g} | " + " | ".join(out) + " |")
    return "\n".join(lines) + "\n"


def plot_shift(rows: list[dict], path: str) -> None:
    """Return against noise level, one panel per (env, kind), one line per variant (mean +- standard error)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    envs = sorted({r["env"] for r in rows})
    variants = sorted({r["algo"] for r in rows})
    fig, axes = plt.subplots(len(envs), len(SHIFT_KINDS), figsize=(4 * len(SHIFT_KINDS), 3 * len(envs)), squeeze=False)
    for (i, env), (j, kind) in itertools.product(enumerate(envs), enumerate(SHIFT_KINDS)):
        ax = axes[i][j]
        for v in variants:
            by_level: dict[float, list[float]] = {}
            for r in rows:
                if r["env"] == env and r["kind"] == kind and r["algo"] == v:
                    by_level.setdefault(float(r["level"]), []).append(float(r["mean_return"]))
            if not by_level:
                continue
            levels = sorted(by_level)
            mean = np.array([np.mean(by_level[lv]) for lv in levels])
            se = np.array([np.std(by_level[lv], ddof=1) / np.sqrt(len(by_level[lv])) if len(by_level[lv]) > 1 else 0
                           for lv in levels])
            x = np.arange(len(levels))
            ax.plot(x, mean, marker="o", label=v)
            ax.fill_between(x, mean - se, mean + se, alpha=0.2)
            ax.set_xticks(x, [f"{lv:g}" for lv in levels])
        ax.set_title(f"{env}: {kind}", fontsize=9)
        ax.set_xlabel("noise (share of the expert std)" if kind != "action" or "Lunar" not in env
                      else "noise (std share; Discrete: random-action probability)", fontsize=8)
        ax.set_ylabel("return")
    axes[0][0].legend(fontsize=8)
    fig.tight_layout()
    from sb3_mbil.common.files import atomic_write

    with atomic_write(path) as tmp:  # whole or not at all
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
