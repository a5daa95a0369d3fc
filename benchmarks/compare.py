"""Train MBIL and BC on the same expert trajectories and print their returns beside the expert's.

    python -m benchmarks.compare --env CartPole-v1 --n-trajectories 1 --seed 0
    python -m benchmarks.compare --env Pendulum-v1 --pool my_demos.npz --n-trajectories 3 --algos bc mbil_c

Each algorithm uses its settings from zoo_hyperparams/ (gradient steps included) and is scored on
300 episodes: one run of the benchmark grid per algorithm.
"""

import argparse
import json

from sb3_mbil import ALGORITHMS
from benchmarks.harness.cli import positive_int, run, seed
from benchmarks.experiments import compare


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--env", default="CartPole-v1")
    p.add_argument("--n-trajectories", type=positive_int, default=1)
    p.add_argument("--seed", type=seed, default=0)
    p.add_argument("--eval-episodes", type=positive_int, default=300)
    p.add_argument("--steps", type=positive_int, default=None, help="override the gradient steps of the settings")
    p.add_argument("--algos", nargs="+", default=["mbil", "bc"], choices=sorted(ALGORITHMS),
                   help="algorithms of sb3_mbil.ALGORITHMS")
    p.add_argument("--pool", default=None,
                   help="draw the trajectories from this pool: a .npz file, a shipped pool name or minari:<dataset id> "
                        "(default: the env's shipped pool); an env without zoo settings runs with the defaults")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    a = p.parse_args(argv)
    r = compare(a.env, a.n_trajectories, a.seed, a.eval_episodes, tuple(a.algos), a.steps, pool=a.pool)
    if a.json:
        print(json.dumps(r, indent=2))
        return
    print(f"{a.env}, {a.n_trajectories} expert trajectories (seed {a.seed}), {a.eval_episodes} evaluation episodes")
    print(f"  {'expert':<8} {r['expert_pool_mean_return']:8.1f}   (mean of the pool {r['expert_pool']}; the drawn "
          f"trajectories: {r['data_mean_return']:.1f})")
    for name, res in r["results"].items():
        print(f"  {name:<8} {res['mean_return']:8.1f} +- {res['std_return']:.1f}   "
              f"({res['gradient_steps']} gradient steps, {res['train_seconds']} s training, commit {res['commit']})")


if __name__ == "__main__":
    run(main)
