"""A MuJoCo env through the RL Zoo: train on one expert trajectory of the shipped Hopper-v4 pool with
``python -m rl_zoo3.train``, then load the trained model like any SB3 model and evaluate it.

    python examples/mujoco_zoo.py                                  # MBIL-C, the zoo's 50 000 gradient steps
    python examples/mujoco_zoo.py --algo bc --steps 2000 --episodes 2
"""

import argparse
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
from stable_baselines3.common.evaluation import evaluate_policy

from sb3_mbil import ALGORITHMS


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--algo", default="mbil_c", choices=sorted(ALGORITHMS))
    p.add_argument("--env", default="Hopper-v4")
    p.add_argument("--steps", type=int, default=None, help="gradient steps (default: the zoo's n_timesteps)")
    p.add_argument("--episodes", type=int, default=10)
    p.add_argument("--logs", default="logs")
    a = p.parse_args()
    cmd = [sys.executable, "-m", "rl_zoo3.train", "--algo", a.algo, "--env", a.env, "-f", a.logs, "--seed", "0",
           "--num-threads", "1", "--eval-freq", "-1", *(["-n", str(a.steps)] if a.steps else [])]
    print("$", " ".join(cmd[1:]))
    subprocess.run(cmd, check=True)
    runs = sorted(Path(a.logs, a.algo).glob(f"{a.env}_*"), key=lambda d: int(d.name.rsplit("_", 1)[1]))
    model = ALGORITHMS[a.algo].load(runs[-1] / f"{a.env}.zip")
    info = model.expert_info
    print(f"trained on {info['n_trajectories']} trajectory of the pool {info['pool']} (draw seed {info['draw_seed']})")
    mean, std = evaluate_policy(model, gym.make(a.env), n_eval_episodes=a.episodes, deterministic=True)
    print(f"{a.algo} on {a.env}: {mean:.1f} +- {std:.1f} over {a.episodes} episodes")


if __name__ == "__main__":
    main()
