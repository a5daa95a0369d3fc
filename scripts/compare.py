"""Train MBIL and BC on the same expert trajectories and print their returns beside the expert's.

    python scripts/compare.py --env CartPole-v1 --n-trajectories 1 --seed 0
"""

import argparse
import json

from sb3_mbil.experiments import compare


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--env", default="CartPole-v1")
    p.add_argument("--n-trajectories", type=int, default=1)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--steps", type=int, default=10_000, help="gradient steps per algorithm")
    p.add_argument("--eval-episodes", type=int, default=100)
    p.add_argument("--algos", nargs="+", default=["mbil", "bc"])
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    a = p.parse_args(argv)
    r = compare(a.env, a.n_trajectories, a.seed, a.steps, a.eval_episodes, tuple(a.algos))
    if a.json:
        print(json.dumps(r, indent=2))
        return
    print(f"{a.env}, {a.n_trajectories} expert trajectories (seed {a.seed}), {a.steps} gradient steps, "
          f"{a.eval_episodes} evaluation episodes")
    print(f"  {'expert':<8} {r['expert_pool_mean_return']:8.1f}   (pool mean; the drawn trajectories: {r['data_mean_return']:.1f})")
    for name, res in r["results"].items():
        print(f"  {name:<8} {res['mean_return']:8.1f} +- {res['std_return']:.1f}   (training {res['train_cpu_seconds']} CPU s)")


if __name__ == "__main__":
    main()
