"""Bad inputs and faults against the package, classified as clean errors, unclear ones or silent acceptances.

    python -m benchmarks.robustness_report [--markdown results/robustness.md --overwrite]
"""

import argparse

from benchmarks.harness.cli import check_output, emit, run


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--markdown", default=None, help="also write the table here")
    p.add_argument("--overwrite", action="store_true", help="replace output files that are committed to git")
    a = p.parse_args(argv)
    check_output(a.markdown, a.overwrite, "--markdown")
    import torch as th

    from benchmarks.harness.grid import git_commit
    from benchmarks.robustness import run_cases, table

    th.set_num_threads(1)
    text = f"Robustness at commit {git_commit()} (`python -m benchmarks.robustness_report`):\n\n" + table(run_cases())
    emit(text, a.markdown)


if __name__ == "__main__":
    run(main)
