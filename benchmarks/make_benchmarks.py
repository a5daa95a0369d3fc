"""Regenerate BENCHMARKS.md from the committed result files (benchmarks.harness.page) and docs/benchmarks_notes.md.
With --overwrite the page's figures are redrawn too, each beside its CSV (results/x.csv -> results/x.png).

    python -m benchmarks.make_benchmarks --overwrite
"""

import argparse

from benchmarks.harness.cli import check_output, positive_int, run


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", default="BENCHMARKS.md")
    p.add_argument("--notes", default="docs/benchmarks_notes.md", help="prose included at the top of the page")
    p.add_argument("--reps", type=positive_int, default=2000, help="bootstrap repetitions of the intervals")
    p.add_argument("--overwrite", action="store_true", help="replace output files that are committed to git")
    a = p.parse_args(argv)
    check_output(a.out, a.overwrite, "--out")
    from benchmarks.harness.page import benchmarks_page
    from benchmarks.harness.results import write_text

    write_text(a.out, benchmarks_page(reps=a.reps, notes=a.notes, plots=a.overwrite))
    print(f"wrote {a.out}")


if __name__ == "__main__":
    run(main)
