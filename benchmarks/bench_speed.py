"""An algorithm's wall time (its set-up, e.g. MBIL's flow fitting, and its updates separately) against BC's,
on the same data, in one run.

    python -m benchmarks.bench_speed --env LunarLander-v3 --n-trajectories 1 15 --steps 2000 --out results/speed.csv --overwrite
    python -m benchmarks.bench_speed --algo edm --env LunarLander-v3 --n-trajectories 1 --out results/speed_edm.csv --overwrite
"""

import argparse
import csv
import io

from sb3_mbil import ALGORITHMS, load_demonstrations
from benchmarks.harness.cli import check_output, positive_int, run, seed
from benchmarks.harness.grid import git_commit
from benchmarks.harness.results import write_text
from benchmarks.speed import measure_speed


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--algo", default="mbil", choices=sorted(ALGORITHMS), help="algorithm of sb3_mbil.ALGORITHMS")
    p.add_argument("--env", default="LunarLander-v3")
    p.add_argument("--n-trajectories", type=positive_int, nargs="+", default=[1, 3, 7, 10, 15])
    p.add_argument("--budget", type=positive_int, default=10_000, help="policy updates of a full run (for the total ratio)")
    p.add_argument("--steps", type=positive_int, default=2000, help="policy updates per timing block")
    p.add_argument("--repeats", type=positive_int, default=3, help="interleaved timing blocks (medians reported)")
    p.add_argument("--seed", type=seed, default=0)
    p.add_argument("--out", default=None, help="CSV to write (whole, atomically)")
    p.add_argument("--overwrite", action="store_true", help="replace output files that are committed to git")
    a = p.parse_args(argv)
    check_output(a.out, a.overwrite, "--out")
    rows, commit = [], git_commit()
    for n in a.n_trajectories:
        demos = load_demonstrations(a.env).sample(n, seed=a.seed)
        row = {"n_trajectories": n, **measure_speed(a.env, demos, a.steps, a.repeats, a.seed, algo=a.algo, budget=a.budget), "commit": commit}
        rows.append(row)
        print(", ".join(f"{k}={v}" for k, v in row.items()), flush=True)
    if a.out:
        buf = io.StringIO(newline="")
        w = csv.DictWriter(buf, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
        write_text(a.out, buf.getvalue())


if __name__ == "__main__":
    run(main)
