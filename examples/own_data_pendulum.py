"""Imitate your own expert on Pendulum-v1: record its trajectories as plain arrays, train BC and MBIL-C on them,
compare them with the expert, save, load, and export the policy to ONNX.

    python examples/own_data_pendulum.py                 # about a minute on one core
    python examples/own_data_pendulum.py --steps 200     # a smoke run
"""

import argparse

import gymnasium as gym
import numpy as np
import torch as th
from stable_baselines3.common.evaluation import evaluate_policy

from sb3_mbil import BC, MBILC


def my_expert(obs):
    """Any controller of yours; here: swing up by pumping energy, then PD control near the top."""
    angle, omega = np.arctan2(obs[1], obs[0]), obs[2]
    if abs(angle) < 0.6:
        torque = -(10.0 * angle + 2.0 * omega)
    else:
        torque = 2.0 * np.sign(omega or 1.0) if 0.5 * omega**2 + 15.0 * np.cos(angle) < 15.0 else 0.0
    return np.clip([torque], -2.0, 2.0).astype(np.float32)


def record(n_episodes, seed=0):
    """One (observations, actions) pair per episode: T + 1 observations (the last next one included), T actions."""
    env, data, returns = gym.make("Pendulum-v1"), [], []
    for i in range(n_episodes):
        obs, _ = env.reset(seed=seed + i)
        observations, actions, total, done = [obs], [], 0.0, False
        while not done:
            action = my_expert(obs)
            obs, reward, terminated, truncated, _ = env.step(action)
            observations.append(obs)
            actions.append(action)
            total, done = total + reward, terminated or truncated
        data.append((np.array(observations), np.array(actions)))
        returns.append(total)
    return data, float(np.mean(returns))


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--trajectories", type=int, default=3)
    p.add_argument("--steps", type=int, default=10_000, help="gradient steps")
    p.add_argument("--episodes", type=int, default=10, help="evaluation episodes")
    p.add_argument("--out", default="pendulum_example", help="folder for the saved model and its ONNX export")
    a = p.parse_args()
    th.set_num_threads(1)
    data, expert_return = record(a.trajectories)
    print(f"expert: {expert_return:.1f} over the {a.trajectories} recorded episodes")
    for cls in (BC, MBILC):
        model = cls("MlpPolicy", "Pendulum-v1", expert_data=data, batch_size=256, seed=0,
                    policy_kwargs=dict(net_arch=[256, 256], normalize_observations=True, bounded_mean=True))
        model.learn(a.steps)
        mean, std = evaluate_policy(model, gym.make("Pendulum-v1"), n_eval_episodes=a.episodes, deterministic=True)
        print(f"{cls.__name__}: {mean:.1f} +- {std:.1f}")
    model.save(f"{a.out}/mbil_c.zip")
    model = MBILC.load(f"{a.out}/mbil_c.zip")
    try:
        from sb3_mbil import export_policy

        path = export_policy(model, f"{a.out}/mbil_c.onnx")
        print(f"saved {a.out}/mbil_c.zip and exported {path}")
    except ImportError as e:  # the export extra is optional
        print(f"saved {a.out}/mbil_c.zip ({e})")


if __name__ == "__main__":
    main()
