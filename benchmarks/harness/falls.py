"""Where one-trajectory clones fall: how far into an episode, and how long after they leave the expert's states.

A clone trained on one expert trajectory (a Figure 4 draw) is rolled out deterministically. For every step of every
episode we measure the distance of its state to the nearest state of the training trajectory, in units of the expert
states' std per dimension (root mean square over dimensions). What counts as "far" is calibrated on the expert
itself: the same distance, measured for the states of other trajectories of the pool (the expert from other initial
states), has a 95th percentile, ``threshold``. A clone has *left* the expert's states at the first step from which its
distance stays above ``threshold`` for ``patience`` steps. Per episode: the length, whether it fell (terminated before
the time limit), the step it left, and the steps from leaving to falling.

If clones fall soon after they leave, the failure is compounding error (the policy is wrong off the data); if they fall
while still near the expert's states, the policy is wrong on the data's neighbourhood itself.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np

FALL_COLUMNS = ["algo", "env", "seed", "episode", "length", "return", "fell", "left_at", "threshold", "median_distance",
                "settings", "commit"]


def nearest_distance(states: np.ndarray, reference: np.ndarray, scale: np.ndarray, chunk: int = 2048) -> np.ndarray:
    """For each row of ``states``, the RMS (over dimensions, in units of ``scale``) distance to the nearest row of
    ``reference``."""
    ref = reference / scale
    out = np.empty(len(states))
    ref_sq = (ref ** 2).sum(1)
    for i in range(0, len(states), chunk):
        x = states[i:i + chunk] / scale
        d2 = (x ** 2).sum(1)[:, None] + ref_sq[None, :] - 2.0 * x @ ref.T
        out[i:i + chunk] = np.sqrt(np.clip(d2.min(1), 0.0, None) / states.shape[1])
    return out


def left_at(distance: np.ndarray, threshold: float, patience: int) -> int | None:
    """The first step from which ``distance`` stays above ``threshold`` for ``patience`` steps (None: never)."""
    above = distance > threshold
    run = 0
    for t, a in enumerate(above):
        run = run + 1 if a else 0
        if run >= patience:
            return t - patience + 1
    return None


@dataclass(frozen=True)
class FallRun:
    variant: str
    env: str
    seed: int


def run_falls(run: FallRun, variants: dict[str, tuple[str, dict[str, Any]]], n_updates: int, n_episodes: int = 20,
              patience: int = 10, n_reference: int = 20) -> list[dict[str, Any]]:
    """Train ``run.variant`` on the seed's one-trajectory draw (the Figure 4 draw) and roll out ``n_episodes``
    deterministic episodes; one row per episode (:data:`FALL_COLUMNS`)."""
    import torch as th

    from sb3_mbil import ALGORITHMS, load_demonstrations
    from benchmarks.harness.curves import _resolved_settings, _settings_column, drawn_demonstrations
    from benchmarks.harness.grid import git_commit

    th.set_num_threads(1)
    algo, variant_settings = variants[run.variant]
    settings = _resolved_settings(algo, run.env, variant_settings)
    demos = drawn_demonstrations(run.env, run.seed, 1)
    train_states = demos[0].observations
    pool = load_demonstrations(run.env)
    scale = np.concatenate([t.observations for t in pool]).std(0).clip(min=1e-6)
    # the expert from other initial states: trajectories of the pool that are not the training one
    others = [t for t in pool if not np.array_equal(t.observations[0], train_states[0])][:n_reference]
    threshold = float(np.quantile(nearest_distance(np.concatenate([t.observations for t in others]), train_states, scale),
                                  0.95))
    model = ALGORITHMS[algo]("MlpPolicy", run.env, expert_data=demos, seed=run.seed, **settings)
    model.learn(n_updates)
    env = gym.make(run.env)
    commit = git_commit()
    rows = []
    for episode in range(n_episodes):
        obs, _ = env.reset(seed=2_000_000 + 1000 * run.seed + episode)
        states, total, terminated, truncated = [obs], 0.0, False, False
        while not (terminated or truncated):
            action, _ = model.predict(obs, deterministic=True)
            obs, reward, terminated, truncated, _ = env.step(action)
            states.append(obs)
            total += float(reward)
        distance = nearest_distance(np.asarray(states), train_states, scale)
        left = left_at(distance, threshold, patience)
        rows.append({"algo": run.variant, "env": run.env, "seed": run.seed, "episode": episode,
                     "length": len(states) - 1, "return": round(total, 1), "fell": bool(terminated),
                     "left_at": "" if left is None else left, "threshold": round(threshold, 4),
                     "median_distance": round(float(np.median(distance)), 4),
                     "settings": _settings_column(algo, settings, None, None), "commit": commit})
    env.close()
    return rows


def fall_table(rows: list[dict]) -> str:
    """Per (env, variant, seed): episodes, share fallen, median length, median step the clone left the expert's
    states, and the median steps from leaving to falling (fallen episodes that left first)."""
    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        groups.setdefault((r["env"], r["algo"], int(r["seed"])), []).append(r)
    header = ("| env | variant | seed | episodes | fell | median length | median step it left (episodes that left) "
              "| median steps from leaving to falling | threshold |")
    lines = [header, "|---|---|---|---|---|---|---|---|---|"]
    for (env, algo, seed), rs in sorted(groups.items()):
        fell = [str(r["fell"]) in ("True", "true", "1") for r in rs]
        lengths = [int(r["length"]) for r in rs]
        left = [int(r["left_at"]) for r in rs if str(r["left_at"]) != ""]
        gap = [int(r["length"]) - int(r["left_at"]) for r, f in zip(rs, fell) if f and str(r["left_at"]) != ""]
        lines.append(f"| {env} | {algo} | {seed} | {len(rs)} | {sum(fell)} | {np.median(lengths):.0f} | "
                     + (f"{np.median(left):.0f} ({len(left)})" if left else "never (0)") + " | "
                     + (f"{np.median(gap):.0f}" if gap else "-") + f" | {float(rs[0]['threshold']):.3f} |")
    return "\n".join(lines)


def termination_cause(env: gym.Env, observation: np.ndarray) -> str:
    """Which of a MuJoCo env's health checks a terminated episode's last observation fails (gymnasium's v4 locomotion
    envs, whose observation starts with the torso's height, then, for Hopper and Walker2d, its angle):
    ``"height above"``, ``"height below"``, ``"angle"`` or ``"other"``."""
    env = env.unwrapped
    z_range = getattr(env, "_healthy_z_range", None)
    if z_range is None or not getattr(env, "_exclude_current_positions_from_observation", False):
        return "other"
    z = float(observation[0])
    if z > z_range[1]:
        return "height above"
    if z < z_range[0]:
        return "height below"
    angle_range = getattr(env, "_healthy_angle_range", None)
    if angle_range is not None and not angle_range[0] < float(observation[1]) < angle_range[1]:
        return "angle"
    return "other"


def termination_causes(demos, env_id: str) -> dict[str, int]:
    """How many episodes of ``demos`` reached the time limit, and how many ended on each failed health check."""
    env = gym.make(env_id)
    counts: dict[str, int] = {}
    for traj in demos:
        cause = termination_cause(env, traj.observations[-1]) if traj.terminated else "time limit"
        counts[cause] = counts.get(cause, 0) + 1
    env.close()
    return counts
