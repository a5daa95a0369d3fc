"""Figure 3 layout, a table env x N per algorithm, and normalised aggregate scores with bootstrap CIs.

    python scripts/plot_results.py --csv results/classic_control.csv --out results/classic_control.png
"""

import argparse

from sb3_mbil.benchmark.report import aggregate, plot, read_rows, table


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--csv", default="results/classic_control.csv")
    p.add_argument("--out", default="results/classic_control.png")
    a = p.parse_args(argv)
    rows = read_rows(a.csv)
    plot(rows, a.out)
    print(table(rows))
    print("\nNormalised score (0 = random, 1 = expert), over all (env, N) cells; 95% stratified bootstrap CIs (rliable):")
    for algo, s in aggregate(rows).items():
        print(f"  {algo}: IQM {s['iqm'][0]:.3f} [{s['iqm'][1]:.3f}, {s['iqm'][2]:.3f}], "
              f"mean {s['mean'][0]:.3f} [{s['mean'][1]:.3f}, {s['mean'][2]:.3f}]")
    print(f"\nplot: {a.out}")


if __name__ == "__main__":
    main()
