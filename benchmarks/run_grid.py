"""The paper's classic-control grid (Figure 3) for any of our algorithms, on Ray.

    python -m benchmarks.run_grid --algos mbil bc --envs CartPole-v1 Acrobot-v1 LunarLander-v3 \\
        --n-trajectories 1 3 7 10 15 --seeds 0-9 --episodes 300 --csv results/classic_control.csv

Ray starts locally by default; --address sends the same grid to a Ray cluster; --local runs
without Ray. Finished rows are skipped, so rerunning resumes an interrupted grid. Rows go to
runs/classic_control.csv unless --csv names another file (rows are appended, never rewritten).
Your own data: --pool my_demos.npz (or minari:<dataset id>) with one env. Each env's second expert (another RL Zoo
algorithm, sb3_mbil.experts.SECOND_EXPERTS): --second-expert. The published baselines' subsampled data:
--protocol published (benchmarks.harness.protocol).
"""

import argparse
import logging

from sb3_mbil import ALGORITHMS
from benchmarks.harness.cli import check_appendable, overrides_json, parse_seeds, positive_int, run


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--algos", nargs="+", default=["mbil", "bc"], choices=sorted(ALGORITHMS),
                   help="algorithms of sb3_mbil.ALGORITHMS")
    p.add_argument("--envs", nargs="+", default=["CartPole-v1", "Acrobot-v1", "LunarLander-v3"])
    p.add_argument("--n-trajectories", nargs="+", type=positive_int, default=[1, 3, 7, 10, 15])
    p.add_argument("--seeds", type=parse_seeds, default=list(range(10)), help="e.g. 0-9 or 0,3,5")
    p.add_argument("--episodes", type=positive_int, default=300)
    p.add_argument("--csv", default="runs/classic_control.csv", help="CSV the rows are appended to")
    p.add_argument("--pool", default=None,
                   help="draw the trajectories from this pool (.npz, shipped pool name or minari:<dataset id>) "
                        "instead of each env's shipped pool; one env only")
    p.add_argument("--second-expert", action="store_true",
                   help="draw from each env's second expert pool (another RL Zoo algorithm) instead of the first")
    p.add_argument("--protocol", default="full", choices=["full", "published", "published_next"],
                   help="full trajectories, every k-th step at each algorithm's published rate, or (a control) every "
                        "k-th step and its next step")
    p.add_argument("--overrides", type=overrides_json, default=None, help='JSON settings per algorithm replacing the tuned ones, e.g. \'{"mbil": {"alpha": 0.1}}\'')
    p.add_argument("--reuse", default=None, metavar="CSV",
                   help="first copy the rows of another grid's CSV whose runs these would repeat: the same key, data and "
                        "settings (AVRIL, ValueDICE and DSFN see whole trajectories under full and published)")
    p.add_argument("--address", default=None, help="Ray cluster address (default: start Ray locally)")
    p.add_argument("--num-cpus", type=positive_int, default=None, help="local Ray: CPUs to use")
    p.add_argument("--local", action="store_true", help="run without Ray, one run after the other")
    p.add_argument("--lockstep", action="store_true",
                   help="train the seeds of each (algo, env, N) cell in one process as one batched network "
                        "(sb3_mbil.learn_lockstep; BC, MBIL, MBIL-C, RCAL, IQ-Learn on Discrete actions; each seed's "
                        "row as its own run's, train_seconds the cell's share); the other algorithms run seed by seed")
    a = p.parse_args(argv)
    check_appendable(a.csv, "--csv")
    if a.pool is not None and len(a.envs) != 1:
        raise ValueError(f"--pool: expected one env with a pool of your own, found --envs {' '.join(a.envs)}")
    if a.pool is not None and a.second_expert:
        raise ValueError("--pool, --second-expert: expected one of them, found both")
    pool = a.pool
    if a.second_expert:
        from sb3_mbil.common.demonstrations import pool_name
        from sb3_mbil.experts import SECOND_EXPERTS

        missing = [e for e in a.envs if e not in SECOND_EXPERTS]
        if missing:
            raise ValueError(f"--second-expert: expected envs with a second expert {sorted(SECOND_EXPERTS)}, found {missing}")
        pool = {e: pool_name(e, SECOND_EXPERTS[e]) for e in a.envs}
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    from benchmarks.harness.grid import make_grid
    from benchmarks.harness.runner import reuse_rows, run_local, run_ray

    grid = make_grid(a.algos, a.envs, a.n_trajectories, a.seeds)
    if a.reuse:
        n = reuse_rows(grid, a.csv, a.reuse, a.episodes, a.overrides, pool=pool, protocol=a.protocol)
        print(f"{n} rows reused from {a.reuse}")
    if a.local:
        n = run_local(grid, a.csv, a.episodes, a.overrides, pool=pool, protocol=a.protocol, lockstep=a.lockstep)
    else:
        n = run_ray(grid, a.csv, a.episodes, a.overrides, a.address, a.num_cpus, pool=pool, protocol=a.protocol,
                    lockstep=a.lockstep)
    print(f"{n} runs done now; results in {a.csv}")


if __name__ == "__main__":
    run(main)
