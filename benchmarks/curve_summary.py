"""Summarise learning-curve CSVs (results/mujoco.csv, results/ablation.csv, results/tuning/mujoco.csv):
the final return per (env, variant) and, with --paired-against, every variant's difference to one
reference variant on the same seeds; with --draws, each seed's expert trajectory beside its finals.

    python -m benchmarks.curve_summary results/tuning/mujoco.csv --last 3 --paired-against bc
    python -m benchmarks.curve_summary results/mujoco.csv --paired-against bc --draws
    python -m benchmarks.curve_summary results/figure4.csv results/mujoco.csv --tags new old --variants bc \
        --envs Hopper-v4 HalfCheetah-v4 --paired-against bc@old
    python -m benchmarks.curve_summary results/tuning/baselines_hopper.csv results/tuning/bounded_mean.csv \
        --variants iq_learn valuedice odice bc bc_tanh --envs Hopper-v4 --until 20000 --last 1 --paired-against bc
"""

import argparse

from benchmarks.harness.cli import check_output, emit, positive_int, run


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("csv", nargs="+")
    p.add_argument("--last", type=positive_int, default=10, help="the final return is each seed's mean over its last LAST evaluations")
    p.add_argument("--paired-against", default=None, help="reference variant of the paired differences")
    p.add_argument("--draws", action="store_true", help="also the trajectories each seed drew (pool indices, mean return, steps)")
    p.add_argument("--heldout", action="store_true",
                   help="also: the return where the held-out BC loss was lowest (runs made with run_curves.py --holdout)")
    p.add_argument("--variants", nargs="+", default=None, help="only these variants (the CSVs' algo column)")
    p.add_argument("--tags", nargs="+", default=None,
                   help="one tag per CSV: its variants become VARIANT@TAG, so that files with the same variant names "
                        "(two backbones, two commits) are told apart and paired on the same seeds")
    p.add_argument("--envs", nargs="+", default=None, help="only these envs")
    p.add_argument("--until", type=positive_int, default=None,
                   help="only the evaluations up to this gradient step (compare runs of different lengths)")
    p.add_argument("--markdown", default=None, help="also write the tables here")
    p.add_argument("--overwrite", action="store_true", help="replace output files that are committed to git")
    a = p.parse_args(argv)
    check_output(a.markdown, a.overwrite, "--markdown")
    from benchmarks.harness.curves import curve_table, draw_table, heldout_table, paired_table, pool_experts
    from benchmarks.harness.results import read_result_rows

    if a.tags is not None and len(a.tags) != len(a.csv):
        p.error(f"--tags: expected one tag per CSV ({len(a.csv)}), found {len(a.tags)}")
    rows = []
    for k, path in enumerate(a.csv):
        try:
            file_rows = read_result_rows(path)
        except (ValueError, FileNotFoundError) as e:
            p.error(f"csv: {e}")
        if a.variants:
            file_rows = [r for r in file_rows if r["algo"] in a.variants]
        if a.tags:
            file_rows = [{**r, "algo": f"{r['algo']}@{a.tags[k]}"} for r in file_rows]
        rows += file_rows
    if a.envs:
        rows = [r for r in rows if r["env"] in a.envs]
    if a.until:
        rows = [r for r in rows if int(float(r["gradient_step"])) <= a.until]
    if not rows:
        p.error(f"csv: expected result rows, found none in {a.csv}" + (" for --variants/--envs/--until" if a.variants or a.envs or a.until else ""))
    try:
        expert = pool_experts(rows)
    except ValueError as e:
        p.error(str(e))
    commits = ", ".join(sorted({r["commit"] for r in rows}))
    text = f"From {', '.join(f'`{c}`' for c in a.csv)} (commits: {commits}); expert = mean return of the pool the runs drew from"
    text += (f"; evaluations up to gradient step {a.until}" if a.until else "") + ".\n\n"
    text += curve_table(rows, expert, last=a.last)
    if a.paired_against:
        text += "\n\n" + paired_table(rows, a.paired_against, last=a.last)
    if a.heldout:
        text += "\n\n" + heldout_table(rows)
    if a.draws:
        text += "\n\n" + draw_table(rows, last=a.last)
    emit(text, a.markdown)


if __name__ == "__main__":
    run(main)
