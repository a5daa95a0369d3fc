"""Peers side by side: d3rlpy's BC / DiscreteBC on the same draws, with the same evaluation, as our BC.

d3rlpy pins gymnasium 1.0.0, so it runs in its own venv (``benchmarks/peers/make_venv.sh``) on draws exported here
(:func:`export_draw`); its policy comes back through its own TorchScript export (``save_policy``) and is scored by
our evaluation harness (:class:`TorchScriptPolicy`). Both libraries train with our BC's zoo settings for the env
(network, batch size, learning rate, number of updates, standardised inputs where ours standardises); everything
else is each library's default (ours: the tuned weight decay; d3rlpy's DiscreteBC: its logit penalty beta 0.5). The
wall time of the updates alone is measured for both in the same run, one after the other.
"""

from __future__ import annotations

import json
import subprocess
import time
from pathlib import Path
from typing import Any

import numpy as np
import torch as th
from gymnasium import spaces

from sb3_mbil.common.demonstrations import Demonstrations

REPO = Path(__file__).resolve().parents[2]
TRAINER = REPO / "benchmarks" / "peers" / "d3rlpy_train.py"
PEER_COLUMNS = ["library", "algo", "env", "n_trajectories", "seed", "mean_return", "std_return", "n_episodes",
                "updates", "fit_seconds", "seconds_per_update", "settings", "commit"]
PEER_KEY = ("library", "env", "n_trajectories", "seed")


def export_draw(demos: Demonstrations, path: str | Path) -> Path:
    """The draw as flat arrays in d3rlpy's MDPDataset layout: one row per step (s, a), reward 0, and each episode's
    last step flagged ``terminals`` (it ended in a terminal state) or ``timeouts`` (any other end), written whole."""
    from sb3_mbil.common.files import atomic_write

    obs, act, terminals, timeouts = [], [], [], []
    for traj in demos:
        n = len(traj)
        obs.append(traj.observations[:n].reshape(n, -1).astype(np.float32))
        act.append(traj.actions)
        end = np.zeros(n, dtype=np.float32)
        end[-1] = 1.0
        terminals.append(end * traj.terminated)
        timeouts.append(end * (not traj.terminated))
    arrays = {"observations": np.concatenate(obs), "actions": np.concatenate(act),
              "terminals": np.concatenate(terminals), "timeouts": np.concatenate(timeouts)}
    arrays["rewards"] = np.zeros(len(arrays["actions"]), dtype=np.float32)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_write(path) as tmp, open(tmp, "wb") as f:
        np.savez(f, **arrays)
    return path


class TorchScriptPolicy:
    """A TorchScript policy (observations -> actions) behind SB3's ``predict``, for our evaluation harness."""

    def __init__(self, path: str | Path, action_space: spaces.Space):
        self.module = th.jit.load(str(path), map_location="cpu")
        self.module.eval()
        self.action_space = action_space

    def predict(self, observation, state=None, episode_start=None, deterministic: bool = True):
        obs = th.as_tensor(np.asarray(observation, dtype=np.float32)).reshape(len(observation), -1)
        with th.no_grad():
            out = self.module(obs).cpu().numpy()
        if isinstance(self.action_space, spaces.Discrete):
            return out.reshape(len(obs)).astype(np.int64), state
        out = out.reshape(len(obs), *self.action_space.shape)
        return np.clip(out, self.action_space.low, self.action_space.high), state


def matched_settings(env_id: str) -> dict[str, Any]:
    """Our BC's zoo settings for the env, the ones both libraries share."""
    from benchmarks.harness.grid import tuned_settings

    s = tuned_settings("bc", env_id)
    kwargs = s.get("policy_kwargs") or {}
    lr = s.get("learning_rate", 1e-3)
    linear_decay = callable(lr)  # rl_zoo3's "lin_<lr>": d3rlpy gets the same linear decay (d3rlpy_train.py)
    activation_fn = kwargs.get("activation_fn", th.nn.ReLU)
    activation = {th.nn.ReLU: "relu", th.nn.ELU: "elu"}.get(activation_fn)
    if activation is None:
        raise ValueError(f"policy_kwargs.activation_fn of bc's zoo entry for {env_id}: expected nn.ReLU or nn.ELU (the "
                         f"activations d3rlpy_train.py matches), found {activation_fn!r}")
    return {"hidden": list(kwargs.get("net_arch", [64, 64])), "activation": activation,
            "batch_size": int(s.get("batch_size", 64)),
            "learning_rate": float(lr(1.0) if linear_decay else lr), "linear_decay": linear_decay,
            "weight_decay": float(s.get("weight_decay", 0.0)),
            "steps": int(float(s["n_timesteps"])), "standardize": bool(kwargs.get("normalize_observations", False))}


def run_pair(env_id: str, n_trajectories: int, seed: int, python: str, workdir: str | Path, n_episodes: int = 300,
             n_eval_envs: int = 20, trainer: str | Path = TRAINER, pool: str | None = None,
             commit: str | None = None) -> list[dict[str, Any]]:
    """d3rlpy's BC and ours on the draw ``sample(n_trajectories, seed)``, each scored on the same ``n_episodes``
    evaluation episodes (seeded ``1_000_000 + seed``, as the grid); returns one row per library."""
    import gymnasium as gym

    from sb3_mbil import BC, load_demonstrations
    from benchmarks.harness.grid import git_commit, tuned_settings
    from sb3_mbil.common.evaluation import evaluate

    th.set_num_threads(1)
    commit = commit or git_commit()
    demos = load_demonstrations(pool or env_id).sample(n_trajectories, seed=seed)
    action_space = gym.make(env_id).action_space
    discrete = isinstance(action_space, spaces.Discrete)
    shared = matched_settings(env_id)
    run_dir = Path(workdir) / f"{env_id}-N{n_trajectories}-seed{seed}"
    data = export_draw(demos, run_dir / "draw.npz")
    cmd = [str(python), str(trainer), "--data", str(data), "--out-dir", str(run_dir), "--hidden",
           *map(str, shared["hidden"]), "--activation", shared["activation"], "--batch-size", str(shared["batch_size"]), "--learning-rate",
           str(shared["learning_rate"]), "--steps", str(shared["steps"]), "--seed", str(seed)]
    cmd += ["--discrete"] if discrete else []
    cmd += ["--standardize"] if shared["standardize"] else []
    cmd += ["--linear-decay"] if shared["linear_decay"] else []
    cmd += ["--weight-decay", str(shared["weight_decay"])]
    out = subprocess.run(cmd, capture_output=True, text=True)
    if out.returncode != 0:
        raise RuntimeError(f"d3rlpy training failed (exit {out.returncode}): {out.stderr.strip()[-1500:]}")
    fit = json.loads((run_dir / "fit.json").read_text())
    peer = TorchScriptPolicy(run_dir / "policy.pt", action_space)
    eval_seed = 1_000_000 + seed
    rows = []
    returns = evaluate(peer, env_id, n_episodes, seed=eval_seed, n_envs=n_eval_envs)
    rows.append({"library": f"d3rlpy {fit.get('d3rlpy', '?')}", "algo": fit.get("algo", "?"), "updates": fit["steps"],
                 "fit_seconds": round(fit["fit_seconds"], 2), "settings": repr(sorted(shared.items())),
                 "returns": returns})
    settings = tuned_settings("bc", env_id)
    steps = int(float(settings.pop("n_timesteps")))
    model = BC("MlpPolicy", env_id, expert_data=demos, seed=seed, **settings)
    model.learn(0)
    t0 = time.perf_counter()
    model.learn(steps, reset_num_timesteps=False, log_interval=-1)
    ours = time.perf_counter() - t0
    returns = evaluate(model, env_id, n_episodes, seed=eval_seed, n_envs=n_eval_envs)
    rows.append({"library": "sb3_mbil", "algo": "BC", "updates": steps, "fit_seconds": round(ours, 2),
                 "settings": repr(sorted({**settings, "n_timesteps": steps}.items())), "returns": returns})
    for row in rows:
        r = row.pop("returns")
        row.update(env=env_id, n_trajectories=n_trajectories, seed=seed, mean_return=float(np.mean(r)),
                   std_return=float(np.std(r)), n_episodes=len(r), commit=commit,
                   seconds_per_update=row["fit_seconds"] / max(row["updates"], 1))
    return rows
