"""Why expert episodes end (benchmarks/harness/falls.py and benchmarks/expert_falls.py)."""

import os
import subprocess
import sys
import gymnasium as gym
import numpy as np
from benchmarks.harness.cli import harness_env


def test_termination_causes_name_the_failed_health_check():
    """Why episodes end: the torso's height above or below its healthy range (Ant-v4's expert jumps out of it), or its
    angle; read from the last observation, checked against the env's own health check on real Hopper-v4 falls."""
    from benchmarks.harness.falls import termination_cause, termination_causes
    from sb3_mbil.common.demonstrations import Demonstrations, Trajectory

    ant, hopper = gym.make("Ant-v4"), gym.make("Hopper-v4")
    obs = np.zeros(ant.observation_space.shape)
    assert [termination_cause(ant, np.r_[z, obs[1:]]) for z in (1.05, 0.1, 0.5)] == ["height above", "height below",
                                                                                      "other"]
    assert termination_cause(hopper, np.r_[1.2, 0.3, np.zeros(9)]) == "angle"
    assert termination_cause(gym.make("HalfCheetah-v4"), np.zeros(17)) == "other"
    rng, trajs = np.random.default_rng(0), []
    for ep in range(3):  # random actions: Hopper falls within a few dozen steps
        o, _ = hopper.reset(seed=ep)
        observations, actions, terminated = [o], [], False
        while not terminated:
            a = rng.uniform(-1, 1, 3)
            o, _, terminated, truncated, _ = hopper.step(a)
            observations.append(o)
            actions.append(a)
            assert not truncated
        assert not hopper.unwrapped.is_healthy
        trajs.append(Trajectory(np.array(observations), np.array(actions), terminated=True))
    trajs.append(Trajectory(np.array(observations[:3]), np.array(actions[:2]), truncated=True))
    counts = termination_causes(Demonstrations(trajs), "Hopper-v4")
    assert sum(counts.values()) == 4 and counts["time limit"] == 1 and "other" not in counts


def test_expert_falls_command_line_counts_the_causes(tmp_path):
    """benchmarks/expert_falls.py on a real saved SAC model: an untrained Hopper-v4 falls at once, and the causes cover
    every episode."""
    import json

    from stable_baselines3 import SAC

    SAC("MlpPolicy", "Hopper-v4", seed=0, device="cpu").save(tmp_path / "hopper.zip")
    out = subprocess.run([sys.executable, "-m", "benchmarks.expert_falls", "--env", "Hopper-v4", "--model",
                          str(tmp_path / "hopper.zip"), "--episodes", "3"], capture_output=True, text=True,
                         cwd=os.path.dirname(os.path.dirname(__file__)), env=harness_env())
    assert out.returncode == 0, out.stderr[-2000:]
    report = json.loads(out.stdout.strip().splitlines()[-1])
    assert sum(report["causes"].values()) == 3 == len(report["lengths"]) and "time limit" not in report["causes"]
