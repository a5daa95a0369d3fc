"""Benchmark harness: algorithms x envs x number of expert trajectories x seeds, on Ray."""

from benchmarks.harness.grid import RESULT_COLUMNS, Run, make_grid, run_one
from benchmarks.harness.results import append_row, append_rows, finished_keys

__all__ = ["RESULT_COLUMNS", "Run", "append_row", "append_rows", "finished_keys", "make_grid", "run_one"]
