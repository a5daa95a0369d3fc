"""d3rlpy's BC / DiscreteBC beside our BC on the same draws and the same evaluation (issue 17, peers).

    bash benchmarks/peers/make_venv.sh                      # once: d3rlpy in its own venv (it pins gymnasium 1.0.0)
    python -m benchmarks.peers.compare_d3rlpy --envs CartPole-v1 Acrobot-v1 LunarLander-v3 --n-trajectories 1 3 \\
        --seeds 0-4 --episodes 300 --csv results/peers.csv
    python -m benchmarks.peers.compare_d3rlpy --envs Hopper-v4 HalfCheetah-v4 --n-trajectories 1 --seeds 0-4 \\
        --episodes 10 --csv results/peers.csv

Both libraries train with our BC's zoo settings for the env (benchmarks.harness.peers); each row holds the return
over the evaluation episodes and the wall time of the updates, measured in the same run. Rows are appended; a rerun
skips the (library, env, N, seed) already in the CSV.
"""

import argparse
import logging

from benchmarks.harness.cli import parse_seeds, positive_int, run


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--envs", nargs="+", default=["CartPole-v1", "Acrobot-v1", "LunarLander-v3"])
    p.add_argument("--n-trajectories", nargs="+", type=positive_int, default=[1, 3])
    p.add_argument("--seeds", type=parse_seeds, default=list(range(5)))
    p.add_argument("--episodes", type=positive_int, default=300)
    p.add_argument("--python", default=".venv-d3rlpy/bin/python", help="the d3rlpy venv's interpreter")
    p.add_argument("--workdir", default="runs/peers", help="exported draws and d3rlpy's policies")
    p.add_argument("--csv", default="runs/peers.csv")
    a = p.parse_args(argv)
    from pathlib import Path

    if not Path(a.python).is_file():
        raise FileNotFoundError(f"--python: expected the d3rlpy venv's interpreter, found no file {a.python} "
                                "(make it with: bash benchmarks/peers/make_venv.sh)")
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    from benchmarks.harness.grid import git_commit
    from benchmarks.harness.peers import PEER_COLUMNS, PEER_KEY, run_pair
    from benchmarks.harness.results import append_rows, finished_keys

    commit = git_commit()
    for seed in a.seeds:
        for env in a.envs:
            for n in a.n_trajectories:
                done = finished_keys(a.csv, PEER_KEY)
                if any(k[1:] == (env, str(n), str(seed)) for k in done):
                    continue
                rows = run_pair(env, n, seed, a.python, a.workdir, n_episodes=a.episodes, commit=commit,
                                trainer=Path(__file__).resolve().parent / "d3rlpy_train.py")
                append_rows(a.csv, rows, PEER_COLUMNS)  # both libraries' rows land together
                logging.info("%s N=%d seed=%d: %s", env, n, seed,
                             ", ".join(f"{r['library']} {r['mean_return']:.1f} ({1e3 * r['seconds_per_update']:.2f} ms"
                                       "/update)" for r in rows))
    print(f"results in {a.csv}")


if __name__ == "__main__":
    run(main)
