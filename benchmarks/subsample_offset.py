"""Does where each trajectory's subsampling starts decide BC on the published protocol?

BC with its zoo settings on every 20th step of N drawn trajectories, each trajectory starting at step 0 (our
`published` protocol before 457e3a9, IQ-Learn's code and EDM's) or at its own random step in [0, 20) (the GAIL codes'
ExpertDataset), the same draws and seeds; one row per run appended to --csv. --pool draws from another pool than the
env's shipped one (e.g. one whose expert sampled its actions, as EDM's code recorded its PPO and A2C experts).

    python -m benchmarks.subsample_offset --env Acrobot-v1 --n-trajectories 3 10 --seeds 100-102 \
        --csv results/tuning/subsample_offset.csv
"""

import argparse
import json

from benchmarks.harness.cli import parse_seeds, positive_int, run


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--env", required=True)
    p.add_argument("--n-trajectories", type=positive_int, nargs="+", default=[3, 10])
    p.add_argument("--seeds", type=parse_seeds, default=[100, 101, 102], help="e.g. 100-102")
    p.add_argument("--every", type=positive_int, default=20)
    p.add_argument("--episodes", type=positive_int, default=30)
    p.add_argument("--pool", default=None, help="pool to draw from (.npz or shipped pool name; default: the env's)")
    p.add_argument("--overrides", type=json.loads, default={},
                   help='JSON settings replacing the zoo ones, e.g. \'{"weight_decay": 0}\'')
    p.add_argument("--csv", required=True)
    a = p.parse_args(argv)
    import torch

    torch.set_num_threads(1)
    from sb3_mbil import ALGORITHMS, load_demonstrations
    from benchmarks.harness.grid import git_commit, tuned_settings
    from benchmarks.harness.results import append_row
    from sb3_mbil.common.evaluation import evaluate

    commit = git_commit()
    overrides = a.overrides
    if not isinstance(overrides, dict):
        raise ValueError(f"--overrides: expected a JSON object of BC settings, found {overrides!r}")
    settings = tuned_settings("bc", a.env, overrides)
    steps = int(float(settings.pop("n_timesteps")))
    for n in a.n_trajectories:
        for s in a.seeds:
            draw = load_demonstrations(a.pool or a.env).sample(n, seed=s)
            for offset in (0, "random"):
                data = draw.subsample(a.every, offset, seed=s)
                model = ALGORITHMS["bc"]("MlpPolicy", a.env, expert_data=data, seed=s, **settings).learn(steps)
                returns = evaluate(model, a.env, a.episodes, seed=10**6 + s)
                row = {"env": a.env, "pool": a.pool or a.env, "n_trajectories": n, "seed": s, "offset": offset,
                       "every": a.every, "n_pairs": data.n_steps, "overrides": json.dumps(overrides, sort_keys=True),
                       "mean_return": float(returns.mean()), "n_episodes": a.episodes, "commit": commit}
                append_row(a.csv, row, list(row))
                print(row, flush=True)


if __name__ == "__main__":
    run(main)
