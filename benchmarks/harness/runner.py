"""Run a grid as Ray tasks (local Ray by default, or a cluster with ``address``), one torch thread each.

The driver appends each row to the CSV as soon as its task finishes; rows already in the CSV are
skipped, so an interrupted grid resumes and loses nothing.
"""

from __future__ import annotations

import logging
import os
from pathlib import Path
from typing import Any

from benchmarks.harness.grid import (
    KEY_COLUMNS,
    RESULT_COLUMNS,
    Run,
    check_grid_settings,
    git_commit,
    run_cell_lockstep,
    run_one,
    settings_column,
)
from benchmarks.harness.results import add_columns, append_row, append_rows, finished_keys, read_result_rows

logger = logging.getLogger("benchmarks.harness")


def pending(runs: list[Run], csv_path: str) -> list[Run]:
    done = finished_keys(csv_path, KEY_COLUMNS)
    return [r for r in runs if r.key() not in done]


def _pool(pool: str | dict[str, str] | None, run: Run) -> str | None:
    """One pool for every run, or one per env (``{env: pool}``, e.g. each env's second expert)."""
    return pool.get(run.env) if isinstance(pool, dict) else pool


def reuse_rows(runs: list[Run], csv_path: str, source: str, n_episodes: int = 300, overrides: dict[str, Any] | None = None,
               pool: str | dict[str, str] | None = None, protocol: str = "full") -> int:
    """Copy into ``csv_path`` the rows of ``source`` (another grid's file) for the pending runs that would repeat
    them: the same key and number of evaluation episodes, the same data (:func:`benchmarks.harness.protocol.same_data`: AVRIL, ValueDICE and DSFN see
    whole trajectories under ``full`` and ``published``) and the settings the source row records are the ones the
    run would have under the source's protocol now. A copied row keeps its result and its commit; its ``protocol``
    and ``settings`` are this grid's, and ``reused_from`` names the source file. Returns the number of rows copied."""
    from benchmarks.harness.protocol import same_data

    todo = pending(runs, csv_path)
    by_key = {tuple(r[c] for c in KEY_COLUMNS): r for r in read_result_rows(source)}
    copied = []
    for run in todo:
        row = by_key.get(run.key())
        if row is None or row.get("reused_from") or int(row["n_episodes"]) != n_episodes:
            continue
        run_pool = _pool(pool, run)
        source_protocol = row.get("protocol") or "full"
        if not same_data(run.algo, run.env, source_protocol, protocol):
            continue
        if row["settings"] != settings_column(run.algo, run.env, overrides, run_pool, source_protocol):
            continue
        copied.append({**row, "protocol": protocol, "settings": settings_column(run.algo, run.env, overrides, run_pool,
                                                                                protocol), "reused_from": Path(source).name})
    if copied:
        add_columns(csv_path, RESULT_COLUMNS)
        append_rows(csv_path, copied, RESULT_COLUMNS)
        logger.info("%d rows reused from %s", len(copied), source)
    return len(copied)


def run_local(runs: list[Run], csv_path: str, n_episodes: int = 300, overrides: dict[str, Any] | None = None,
              pool: str | dict[str, str] | None = None, protocol: str = "full", lockstep: bool = False) -> int:
    """Without Ray, one run after the other (``lockstep``: one cell after the other, its seeds in lockstep)."""
    todo, commit = pending(runs, csv_path), git_commit()
    check_grid_settings(todo, csv_path, overrides, pool, protocol)
    add_columns(csv_path, RESULT_COLUMNS)  # a file from before a column keeps its rows and gains the column
    for group in (cells(todo) if lockstep else [[run] for run in todo]):
        if lockstep:
            rows = run_cell_lockstep(group, n_episodes, overrides, commit, pool=_pool(pool, group[0]), protocol=protocol)
        else:
            rows = [run_one(group[0], n_episodes, overrides, commit, pool=_pool(pool, group[0]), protocol=protocol)]
        for row in rows:
            append_row(csv_path, row, RESULT_COLUMNS)
            logger.info("%s", row)
    return len(todo)


def cells(runs: list[Run]) -> list[list[Run]]:
    """The runs grouped by (algo, env, N) cell, in the order the cells first appear."""
    groups: dict[tuple, list[Run]] = {}
    for run in runs:
        groups.setdefault((run.algo, run.env, run.n_trajectories), []).append(run)
    return list(groups.values())


def _one_row(*args, **kwargs) -> list[dict[str, Any]]:
    return [run_one(*args, **kwargs)]


def run_ray(runs: list[Run], csv_path: str, n_episodes: int = 300, overrides: dict[str, Any] | None = None,
            address: str | None = None, num_cpus: int | None = None, pool: str | dict[str, str] | None = None,
            protocol: str = "full", lockstep: bool = False) -> int:
    """The grid as Ray tasks (``lockstep``: a task per (algo, env, N) cell, its seeds in lockstep); returns the number
    of runs done now."""
    import ray

    todo, commit = pending(runs, csv_path), git_commit()
    if not todo:
        return 0
    check_grid_settings(todo, csv_path, overrides, pool, protocol)
    add_columns(csv_path, RESULT_COLUMNS)
    env_vars = {"OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "PYTHONWARNINGS": "ignore"}
    # the harness is not installed: Ray ships this checkout's benchmarks package to every worker
    runtime_env = {"env_vars": env_vars, "py_modules": [str(Path(__file__).resolve().parents[1])],
                   "excludes": ["tests/", "runs/", "__pycache__/"]}
    if address:
        ray.init(address=address, runtime_env=runtime_env)
    else:
        # a new local instance, never a cluster that `ray start` left on this machine (ray.init would join it)
        ray.init(address="local", num_cpus=num_cpus or os.cpu_count(), include_dashboard=False, runtime_env=runtime_env,
                 log_to_driver=False)
    if lockstep:
        task = ray.remote(num_cpus=1, max_retries=1)(run_cell_lockstep)
        futures = {task.remote(group, n_episodes, overrides, commit, pool=_pool(pool, group[0]), protocol=protocol): group
                   for group in cells(todo)}
    else:
        task = ray.remote(num_cpus=1, max_retries=1)(_one_row)
        futures = {task.remote(run, n_episodes, overrides, commit, pool=_pool(pool, run), protocol=protocol): [run]
                   for run in todo}
    done = 0
    try:
        while futures:
            ready, _ = ray.wait(list(futures), num_returns=1)
            group = futures.pop(ready[0])
            try:
                rows = ray.get(ready[0])
            except Exception as e:  # one failed run (or cell) must not lose the others
                logger.error("run %s failed: %s", group if len(group) > 1 else group[0], e)
                continue
            for run, row in zip(group, rows):
                append_row(csv_path, row, RESULT_COLUMNS)
                done += 1
                logger.info("[%d/%d] %s %s N=%d seed=%d: %.1f", done, len(todo), run.algo, run.env,
                            run.n_trajectories, run.seed, row["mean_return"])
    finally:
        ray.shutdown()
    return done
