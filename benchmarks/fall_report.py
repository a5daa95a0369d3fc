"""Where one-trajectory clones fall (benchmarks.harness.falls): per episode, its length, whether it fell, and the
step at which the clone left the expert's states; one row per episode, appended per run (resumable).

    python -m benchmarks.fall_report --envs Walker2d-v4 --seeds 100-102 --updates 50000 --csv results/tuning/falls.csv
    python -m benchmarks.fall_report --table results/tuning/falls.csv
"""

import argparse
import json
import logging

from benchmarks.harness.cli import parse_seeds, positive_int, run


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--envs", nargs="+", default=["Walker2d-v4"])
    p.add_argument("--seeds", type=parse_seeds, default=[100, 101, 102])
    p.add_argument("--updates", type=positive_int, default=50_000)
    p.add_argument("--episodes", type=positive_int, default=20)
    p.add_argument("--variants", default='{"bc": ["bc", {}]}',
                   help='JSON {"name": ["algo", {settings}]}: the zoo settings of algo, overridden by settings')
    p.add_argument("--csv", default="runs/falls.csv")
    p.add_argument("--table", default=None, help="print the table of this CSV and exit")
    a = p.parse_args(argv)
    from benchmarks.harness.falls import FALL_COLUMNS, FallRun, fall_table, run_falls
    from benchmarks.harness.results import append_rows, finished_keys, read_result_rows

    if a.table:
        print(fall_table(read_result_rows(a.table)))
        return
    from benchmarks.harness.curves import parse_variants

    variants = parse_variants(a.variants)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    done = finished_keys(a.csv, ("algo", "env", "seed"))
    for seed in a.seeds:
        for env in a.envs:
            for name in variants:
                if (name, env, str(seed)) in done:
                    continue
                rows = run_falls(FallRun(name, env, seed), variants, a.updates, a.episodes)
                append_rows(a.csv, rows, FALL_COLUMNS)
                logging.getLogger("benchmarks.harness").info("%s %s seed %d: %s", name, env, seed, json.dumps([(r["length"], r["left_at"]) for r in rows]))
    print(fall_table(read_result_rows(a.csv)))


if __name__ == "__main__":
    run(main)
