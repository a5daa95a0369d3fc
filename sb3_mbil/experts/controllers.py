"""Hand-written experts: controllers that are not RL agents (another kind of expert to imitate).

``pendulum_controller``: Pendulum-v1 swing-up by energy pumping (full torque along the angular velocity while the
energy is below the upright's), then PD control near the top (return -140 +- 91 over 30 episodes; the env's dynamics
theta'' = 15 sin(theta) + 3 u give the energy 0.5 omega^2 + 15 cos(theta), 15 upright at rest).
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

from sb3_mbil.common.demonstrations import Demonstrations, Trajectory, load_demonstrations


def pendulum_controller(obs: np.ndarray) -> np.ndarray:
    """PD (torque -(10 angle + 2 omega)) within 0.6 rad of upright; elsewhere pump energy while it is below 15."""
    angle, omega = float(np.arctan2(obs[1], obs[0])), float(obs[2])
    if abs(angle) < 0.6:
        torque = -(10.0 * angle + 2.0 * omega)
    elif 0.5 * omega**2 + 15.0 * np.cos(angle) < 15.0:
        torque = 2.0 if omega >= 0 else -2.0
    else:
        torque = 0.0
    return np.clip([torque], -2.0, 2.0).astype(np.float32)


CONTROLLERS = {"Pendulum-v1": pendulum_controller}


def controller_demonstrations(env_id: str, n_trajectories: int, seed: int = 0) -> Demonstrations:
    """``n_trajectories`` episodes of the env's hand-written controller, episode ``i`` reset with ``seed + i``."""
    if env_id not in CONTROLLERS:
        raise ValueError(f"env_id: expected one of {sorted(CONTROLLERS)} (envs with a hand-written controller), found {env_id!r}")
    controller, env, trajs = CONTROLLERS[env_id], gym.make(env_id), []
    for i in range(n_trajectories):
        obs, _ = env.reset(seed=seed + i)
        observations, actions, ret, done = [obs], [], 0.0, False
        while not done:
            action = controller(obs)
            obs, reward, terminated, truncated, _ = env.step(action)
            observations.append(obs)
            actions.append(action)
            ret, done = ret + float(reward), terminated or truncated
        trajs.append(Trajectory(np.array(observations), np.array(actions), terminated, truncated, ret))
    env.close()
    return Demonstrations(trajs, {"env_id": env_id, "source": f"controller:{controller.__name__}",
                                  "seed": seed, "n_trajectories": n_trajectories})


def native_env(algo: type) -> str:
    """The env the checks run an algorithm on: CartPole-v1 when it takes Discrete actions, else Pendulum-v1."""
    return "CartPole-v1" if gym.spaces.Discrete in algo.supported_action_spaces else "Pendulum-v1"


def native_demo(algo: type, n_trajectories: int = 1):
    """Expert data for :func:`native_env`: the shipped CartPole-v1 pool, or the hand-written Pendulum-v1 controller."""
    if native_env(algo) == "CartPole-v1":
        return load_demonstrations("CartPole-v1").sample(n_trajectories, seed=0)
    return controller_demonstrations("Pendulum-v1", n_trajectories, seed=0)
