"""A real multi-node Ray cluster on this machine (a head node and two worker nodes, each its own raylet):
the grid is sent with --address, a worker node is killed mid-grid, the grid is rerun, and every row is in the
CSV exactly once."""

import csv
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SEEDS = "0-5"
FAST = json.dumps({"bc": {"n_timesteps": 300}})


def grid(address, csv_path, timeout=300):
    return subprocess.Popen(
        [sys.executable, "-m", "benchmarks.run_grid", "--algos", "bc", "--envs", "CartPole-v1",
         "--n-trajectories", "1", "--seeds", SEEDS, "--episodes", "20", "--csv", str(csv_path), "--overrides", FAST,
         "--address", address],
        cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
        env={**os.environ, "OMP_NUM_THREADS": "1"})


def rows(path):
    if not path.is_file():
        return []
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


@pytest.fixture
def cluster():
    from ray.cluster_utils import Cluster

    # a lost node is noticed after about a second (Ray's default health check takes tens of seconds)
    c = Cluster(initialize_head=True, head_node_args={
        "num_cpus": 0, "include_dashboard": False,
        "_system_config": {"health_check_initial_delay_ms": 0, "health_check_period_ms": 300,
                           "health_check_failure_threshold": 3}})
    workers = [c.add_node(num_cpus=1) for _ in range(2)]
    c.wait_for_nodes()
    yield c, workers
    c.shutdown()


@pytest.mark.slow  # minutes under load: run by CI with -m slow
def test_grid_on_a_cluster_survives_a_lost_worker(cluster, tmp_path):
    c, workers = cluster
    out = tmp_path / "grid.csv"
    proc = grid(c.address, out)
    deadline = time.time() + 240
    while len(rows(out)) < 1 and proc.poll() is None and time.time() < deadline:
        time.sleep(0.2)
    assert len(rows(out)) >= 1, proc.stdout.read() if proc.poll() is not None else "no row in time"
    t_kill = time.time()
    c.remove_node(workers[0], allow_graceful=False)  # a worker node dies mid-grid
    c.add_node(num_cpus=1)  # and a new one joins
    first_output, _ = proc.communicate(timeout=300)
    after_first = len(rows(out))
    print(f"first grid ended {time.time() - t_kill:.1f} s after the kill with {after_first} rows")
    rerun = grid(c.address, out)
    t_rerun = time.time()
    second_output, _ = rerun.communicate(timeout=300)
    print(f"rerun took {time.time() - t_rerun:.1f} s")
    assert rerun.returncode == 0, second_output
    keys = [(r["algo"], r["env"], r["n_trajectories"], r["seed"]) for r in rows(out)]
    assert sorted(keys) == sorted(("bc", "CartPole-v1", "1", str(s)) for s in range(6)), (first_output, second_output)
    assert len(set(keys)) == len(keys) == 6
    assert after_first >= 1
