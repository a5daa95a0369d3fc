"""Benchmark harness: algorithms x envs x number of expert trajectories x seeds, on Ray."""

from sb3_mbil.benchmark.grid import RESULT_COLUMNS, Run, make_grid, run_one
from sb3_mbil.benchmark.results import append_row, append_rows, finished_keys

__all__ = ["RESULT_COLUMNS", "Run", "append_row", "append_rows", "finished_keys", "make_grid", "run_one"]
