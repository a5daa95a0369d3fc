"""Distribution shift (the paper's appendix claim): train once per (variant, env, seed), evaluate under
perturbed initial states, observation noise and action noise at 1%, 3% and 10% of the expert's per-dimension std.

    python -m benchmarks.distribution_shift --envs LunarLander-v3 --seeds 0-4 --episodes 50 \\
        --csv results/shift.csv --markdown results/shift.md --plot results/shift.png --overwrite
    python -m benchmarks.distribution_shift --envs Hopper-v4 HalfCheetah-v4 --seeds 0-2 --episodes 10 --csv results/shift.csv

Variants default to BC, the paper's MBIL and MBIL-C at their zoo settings; resumable (rows of one trained model are
written together).
"""

import argparse

from benchmarks.harness.cli import check_output, parse_seeds, positive_int, run


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--envs", nargs="+", required=True)
    p.add_argument("--seeds", type=parse_seeds, default=list(range(5)))
    p.add_argument("--episodes", type=positive_int, default=50, help="evaluation episodes per (kind, level)")
    p.add_argument("--n-trajectories", type=positive_int, default=1)
    p.add_argument("--updates", type=positive_int, default=None, help="gradient updates (default: the zoo's n_timesteps)")
    p.add_argument("--variants", default=None, help='JSON {"name": ["algo", {settings}]} (default: bc, mbil, mbil_c)')
    p.add_argument("--csv", required=True)
    p.add_argument("--markdown", default=None)
    p.add_argument("--plot", default=None)
    p.add_argument("--report-only", action="store_true", help="only write the table and plot from the CSV")
    p.add_argument("--overwrite", action="store_true", help="replace output files that are committed to git")
    args = p.parse_args(argv)
    check_output(args.markdown, args.overwrite, "--markdown")
    check_output(args.plot, args.overwrite, "--plot")

    from benchmarks.harness.curves import parse_variants
    from benchmarks.harness.results import read_result_rows, write_text
    from benchmarks.harness.shift import plot_shift, run_shifts, shift_table

    variants = parse_variants(args.variants) if args.variants else {n: (n, {}) for n in ("bc", "mbil", "mbil_c")}
    if not args.report_only:
        run_shifts(variants, args.envs, args.seeds, args.csv, n_episodes=args.episodes,
                   n_trajectories=args.n_trajectories, n_updates=args.updates)
    rows = read_result_rows(args.csv)
    table = shift_table(rows)
    print(table)
    if args.markdown:
        write_text(args.markdown, table)
    if args.plot:
        plot_shift(rows, args.plot)


if __name__ == "__main__":
    run(main)
