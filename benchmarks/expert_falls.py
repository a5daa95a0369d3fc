"""Why an expert's episodes end early: roll a saved zoo model out deterministically and count the episodes that reach
the time limit and those that end on each failed health check of the env (torso height above or below its healthy
range, or its angle), from each terminated episode's last observation (benchmarks.harness.falls.termination_cause).

    python -m benchmarks.expert_falls --env Ant-v4 --model results/experts/sac-Ant-v4-seed0/rl_model_1700000_steps.zip
"""

import argparse
import json
import logging

from benchmarks.harness.cli import positive_int, run, seed


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--env", required=True)
    p.add_argument("--model", required=True, help="a saved RL Zoo model (.zip)")
    p.add_argument("--algo", default=None, help="its RL Zoo algorithm (default: the env's expert's)")
    p.add_argument("--episodes", type=positive_int, default=20)
    p.add_argument("--seed", type=seed, default=10**6, help="episode i is reset with seed + i (acceptance's seeds)")
    a = p.parse_args(argv)
    logging.basicConfig(level=logging.WARNING)
    from benchmarks.harness.falls import termination_causes
    from sb3_mbil.experts import EXPERTS, load_expert_file, rollout

    algo = a.algo or (EXPERTS[a.env].algo if a.env in EXPERTS else None)
    if algo is None:
        raise ValueError(f"--algo: expected the RL Zoo algorithm of the model (no default for {a.env!r}), found None")
    demos = rollout(load_expert_file(a.model, a.env, algo), a.episodes, a.seed)
    print(json.dumps({"env": a.env, "model": a.model, "episodes": a.episodes, "seed": a.seed,
                      "causes": termination_causes(demos, a.env),
                      "lengths": [len(t) for t in demos]}))


if __name__ == "__main__":
    run(main)
