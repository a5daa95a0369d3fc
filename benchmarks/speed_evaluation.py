"""Time of one evaluation, SB3's ``evaluate_policy`` (every env stepped until the last episode ends) against
``sb3_mbil.common.evaluation.evaluate`` (an env that has run its episodes is not stepped again): the same returns.

    python -m benchmarks.speed_evaluation --env LunarLander-v3 --way ours|sb3 [--episodes 100 --envs 20]
    python -m benchmarks.speed_evaluation --env LunarLander-v3 --way both --repeats 5 --csv results/speed_evaluation.csv

``--way both`` times the two in one process, in turn (ours, sb3, ours, ...), CPU seconds of the evaluation alone,
and appends one row per pair (both times, their ratio, the returns' equality) to ``--csv``.

The policy is a BC trained for 2 000 updates on one trajectory of the env's pool (seed 0), cached in
``runs/speed_evaluation/``; time two invocations side by side with any whole-process timer.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch as th


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--env", required=True)
    p.add_argument("--way", choices=("ours", "sb3", "both"), required=True)
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--csv", default=None)
    p.add_argument("--episodes", type=int, default=100)
    p.add_argument("--envs", type=int, default=20)
    p.add_argument("--pool", default=None, help="pool to draw the trajectory from (default: the env's)")
    a = p.parse_args(argv)
    th.set_num_threads(1)
    from sb3_mbil import BC, load_demonstrations
    from sb3_mbil.common.evaluation import evaluate

    path = Path("runs/speed_evaluation") / f"bc-{a.env}-{a.pool or 'pool'}.zip"
    if path.is_file():
        model = BC.load(path, safe=True)
    else:
        model = BC("MlpPolicy", a.env, expert_data=load_demonstrations(a.pool or a.env).sample(1, seed=0), seed=0)
        model.learn(2000).save(path)
    def ours():
        return evaluate(model, a.env, a.episodes, seed=0, n_envs=a.envs)

    def sb3():
        from stable_baselines3.common.evaluation import evaluate_policy
        from stable_baselines3.common.monitor import Monitor
        from stable_baselines3.common.vec_env import DummyVecEnv

        env = DummyVecEnv([lambda: Monitor(gym.make(a.env)) for _ in range(a.envs)])
        env.seed(0)
        returns, _ = evaluate_policy(model, env, n_eval_episodes=a.episodes, deterministic=True,
                                     return_episode_rewards=True)
        return np.asarray(returns)

    if a.way != "both":
        returns = ours() if a.way == "ours" else sb3()
        print(f"{a.way}: {len(returns)} episodes, mean return {np.mean(returns):.6f}")
        return
    import time

    from benchmarks.harness.grid import git_commit
    from benchmarks.harness.results import append_rows

    columns = ["env", "episodes", "envs", "repeat", "ours_cpu_s", "sb3_cpu_s", "ratio", "same_returns", "commit"]
    commit, ratios = git_commit(), []
    for r in range(a.repeats):
        t0 = time.process_time()
        mine = ours()
        t1 = time.process_time()
        theirs = sb3()
        t2 = time.process_time()
        ratios.append((t1 - t0) / (t2 - t1))
        row = {"env": a.env, "episodes": a.episodes, "envs": a.envs, "repeat": r, "ours_cpu_s": round(t1 - t0, 3),
               "sb3_cpu_s": round(t2 - t1, 3), "ratio": round(ratios[-1], 4),
               "same_returns": bool(np.array_equal(mine, theirs)), "commit": commit}
        if a.csv:
            append_rows(a.csv, [row], columns)
        print(row, flush=True)
    print(f"{a.env}: ours / sb3 CPU time, median of {a.repeats} pairs: {np.median(ratios):.3f}")


if __name__ == "__main__":
    main()
