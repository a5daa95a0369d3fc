"""Figure 3 layout, a table env x N per algorithm, and normalised aggregate scores with bootstrap CIs.

    python -m benchmarks.plot_results --csv results/classic_control.csv --out results/classic_control.png --overwrite
"""

import argparse

from benchmarks.harness.cli import check_output, emit, positive_int, run
from benchmarks.harness.report import aggregate, paired, plot, probability_of_improvement, read_rows, table


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--csv", default="results/classic_control.csv")
    p.add_argument("--out", default="results/classic_control.png")
    p.add_argument("--markdown", default=None, help="also write the tables to this markdown file")
    p.add_argument("--overwrite", action="store_true", help="replace output files that are committed to git")
    p.add_argument("--reps", type=positive_int, default=2000, help="bootstrap repetitions of the confidence intervals")
    a = p.parse_args(argv)
    check_output(a.out, a.overwrite, "--out")
    check_output(a.markdown, a.overwrite, "--markdown")
    try:
        rows = read_rows(a.csv)
    except (ValueError, FileNotFoundError) as e:
        p.error(f"--csv: {e}")
    plot(rows, a.out)
    commits = sorted({r.get("commit", "") for r in rows})
    algos = sorted({r["algo"] for r in rows})
    lines = [f"Results of {len(rows)} runs from `{a.csv}` (commits: {', '.join(commits)}); mean +- std over seeds "
             "(number of seeds), each seed the average return of its evaluation episodes.", table(rows)]
    lines += [paired(rows, algo, "bc") for algo in algos if algo != "bc" and "bc" in algos]
    lines.append("\nNormalised score (0 = random, 1 = expert), over all (env, N) cells with results for every algorithm; "
                 "95% stratified bootstrap confidence intervals (rliable):\n")
    for algo, s in aggregate(rows, reps=a.reps).items():
        lines.append(f"- {algo}: IQM {s['iqm'][0]:.3f} [{s['iqm'][1]:.3f}, {s['iqm'][2]:.3f}], "
                     f"mean {s['mean'][0]:.3f} [{s['mean'][1]:.3f}, {s['mean'][2]:.3f}]")
    improvement = probability_of_improvement(rows, "bc", reps=a.reps)
    if improvement:
        lines.append("\nProbability of improvement over BC (rliable: the chance that a run of the algorithm beats a run "
                     "of BC on the same (env, N) task, averaged over the tasks; 0.5 = level), 95% stratified bootstrap interval:\n")
        for algo, (point, lo, hi) in improvement.items():
            lines.append(f"- {algo}: {point:.3f} [{lo:.3f}, {hi:.3f}]")
    lines.append(f"\nPlot: `{a.out}`; made with `python -m benchmarks.plot_results --csv {a.csv} --out {a.out}`.")
    text = "\n".join(lines)
    emit(text, a.markdown)


if __name__ == "__main__":
    run(main)
