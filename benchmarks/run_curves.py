"""Learning curves with one expert trajectory: Figure 4 (MBIL vs BC with and without weight decay) or the
Figure 5 (alpha, beta) ablation. Evaluates every --eval-every gradient updates on --episodes episodes.

    python -m benchmarks.run_curves --figure 4 --envs Hopper-v4 Walker2d-v4 --seeds 0-4 --updates 50000 \\
        --csv results/mujoco.csv --plot results/mujoco.png --overwrite
    python -m benchmarks.run_curves --figure 5 --envs Walker2d-v4 --seeds 0-4 --updates 50000 \\
        --csv results/ablation.csv --plot results/ablation.png --overwrite
    python -m benchmarks.run_curves --variants '{"mbil_a0.01": ["mbil", {"alpha": 0.01}]}' --envs Hopper-v4 \\
        --seeds 100-102 --updates 50000 --eval-every 5000 --csv results/tuning/mujoco.csv
    python -m benchmarks.run_curves --figure 4 --envs Hopper-v4 --pool hopper-sampled.npz --seeds 100-102 \\
        --updates 50000 --eval-every 5000 --csv results/tuning/mujoco_sampled.csv    # another pool of the env: use its own CSV
"""

import argparse

from benchmarks.harness.cli import check_appendable, check_output, emit, fraction, parse_seeds, positive_int, run


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--figure", choices=["4", "5"], default="4")
    p.add_argument("--variants", default=None,
                   help='JSON {"name": ["algo", {settings}]} instead of the figure\'s variants (tuning runs)')
    p.add_argument("--only", nargs="+", default=None, metavar="VARIANT",
                   help="run only these of the figure's variants (e.g. --only bc bc_wd1e-3), in this order")
    p.add_argument("--envs", nargs="+", required=True)
    p.add_argument("--seeds", type=parse_seeds, default=list(range(5)))
    p.add_argument("--updates", type=positive_int, required=True, help="gradient updates per run")
    p.add_argument("--eval-every", type=positive_int, default=500)
    p.add_argument("--episodes", type=positive_int, default=10)
    p.add_argument("--n-trajectories", type=positive_int, default=1)
    p.add_argument("--pool", default=None,
                   help="draw the trajectories from this pool (.npz path or shipped name) instead of the env's shipped pool (a CSV of its own: runs resume by variant, env and seed); "
                        "one env only; recorded in the settings column")
    p.add_argument("--holdout", type=fraction, default=None,
                   help="hold out this share of the expert steps and record the held-out BC loss at each evaluation")
    p.add_argument("--csv", required=True)
    p.add_argument("--plot", default=None)
    p.add_argument("--last", type=positive_int, default=10, help="the final return is each seed's mean over its last LAST evaluations")
    p.add_argument("--markdown", default=None, help="also write the summary table (final return, drop from the best) here")
    p.add_argument("--address", default=None, help="Ray cluster address (default: local Ray)")
    p.add_argument("--num-cpus", type=positive_int, default=None)
    p.add_argument("--local", action="store_true", help="without Ray")
    p.add_argument("--overwrite", action="store_true", help="replace output files that are committed to git")
    a = p.parse_args(argv)
    check_appendable(a.csv, "--csv")
    check_output(a.plot, a.overwrite, "--plot")
    check_output(a.markdown, a.overwrite, "--markdown")
    from sb3_mbil import load_demonstrations
    from benchmarks.harness.curves import (
        ABLATION_VARIANTS,
        FIGURE4_VARIANTS,
        curve_table,
        parse_variants,
        plot_curves,
        run_curves,
    )

    if a.variants:
        try:
            variants = parse_variants(a.variants)
        except ValueError as e:
            p.error(str(e))
    else:
        variants = FIGURE4_VARIANTS if a.figure == "4" else ABLATION_VARIANTS
    if a.only:
        unknown = [v for v in a.only if v not in variants]
        if unknown:
            p.error(f"--only: expected variants among {sorted(variants)}, found {' '.join(unknown)}")
        variants = {v: variants[v] for v in a.only}
    if a.pool is not None:
        if len(a.envs) != 1:
            p.error(f"--pool: expected one env, found {len(a.envs)} ({' '.join(a.envs)})")
        try:
            pool_env = load_demonstrations(a.pool).metadata.get("env_id")
        except (ValueError, FileNotFoundError) as e:
            p.error(f"--pool: {e}")
        if pool_env != a.envs[0]:
            p.error(f"--pool: expected demonstrations of {a.envs[0]}, found a pool of {pool_env} ({a.pool})")
    n = run_curves(variants, a.envs, a.seeds, a.csv, a.updates, a.eval_every, a.episodes, a.n_trajectories, pool=a.pool,
                   use_ray=not a.local, address=a.address, num_cpus=a.num_cpus, holdout_fraction=a.holdout)
    print(f"{n} runs done now; results in {a.csv}")
    from benchmarks.harness.results import read_result_rows

    rows = [r for r in read_result_rows(a.csv) if r["env"] in a.envs and r["algo"] in variants]
    if a.pool is not None:  # only this pool's runs, against this pool's expert return
        rows = [r for r in rows if f"('expert_pool', {a.pool!r})" in r["settings"]]
    expert = {e: float(load_demonstrations(a.pool or e).episode_returns.mean()) for e in a.envs}
    experts = ", ".join(f"{e} {v:.1f}" for e, v in expert.items())
    text = (f"Results from `{a.csv}` (commits: {', '.join(sorted({r['commit'] for r in rows}))}); expert = mean return of "
            f"the pool {a.pool or '(shipped)'}: {experts}.\n\n" + curve_table(rows, expert, last=a.last))
    emit(text, a.markdown)
    if a.plot:
        plot_curves(rows, a.plot, expert)
        print(f"plot: {a.plot}")


if __name__ == "__main__":
    run(main)
