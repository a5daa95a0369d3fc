"""Peers side by side (benchmarks.harness.peers): the exported draw, the TorchScript round trip, one pair of rows.

The real peer needs d3rlpy in its own venv (benchmarks/peers/make_venv.sh); here a stand-in trainer with the same
command line and outputs exercises everything around it, with a real subprocess, real files and a real env."""

import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from sb3_mbil import load_demonstrations
from benchmarks.harness.peers import TorchScriptPolicy, export_draw, run_pair
from sb3_mbil.common.evaluation import evaluate

STANDIN = Path(__file__).resolve().parent / "peers_standin" / "d3rlpy_train.py"


def test_export_draw_flags_each_episode_end_once(tmp_path):
    demos = load_demonstrations("LunarLander-v3").sample(3, seed=0)
    with np.load(export_draw(demos, tmp_path / "d.npz")) as d:
        assert len(d["observations"]) == demos.n_steps == len(d["actions"]) == len(d["rewards"])
        ends = np.flatnonzero(d["terminals"] + d["timeouts"])
        np.testing.assert_array_equal(ends, np.cumsum(demos.episode_lengths) - 1)
        np.testing.assert_array_equal(d["terminals"][ends], [t.terminated for t in demos])
        np.testing.assert_array_equal(d["observations"][: len(demos[0])], demos[0].observations[:-1])


def test_a_pair_of_rows_from_the_same_draw_and_evaluation(tmp_path):
    rows = run_pair("CartPole-v1", 1, 0, sys.executable, tmp_path, n_episodes=3, n_eval_envs=3, trainer=STANDIN,
                    commit="test")
    assert [r["library"] for r in rows] == ["d3rlpy stand-in", "sb3_mbil"]
    assert all(r["env"] == "CartPole-v1" and r["n_episodes"] == 3 and r["commit"] == "test" for r in rows)
    assert rows[0]["updates"] == rows[1]["updates"] == 10_000  # both at our BC's zoo budget
    assert "('hidden', [64, 64])" in rows[0]["settings"] and "('batch_size', 64)" in rows[0]["settings"]
    assert "('activation', 'elu')" in rows[0]["settings"]  # bc.yml's classic-control ELU, passed to the peer
    assert rows[0]["seconds_per_update"] == 0.5 / 10_000
    peer = TorchScriptPolicy(tmp_path / "CartPole-v1-N1-seed0" / "policy.pt", gym.make("CartPole-v1").action_space)
    again = evaluate(peer, "CartPole-v1", 3, seed=1_000_000, n_envs=3)
    assert rows[0]["mean_return"] == float(np.mean(again))  # the same evaluation episodes


def test_matched_settings_carry_the_zoos_learning_rate_schedule():
    from benchmarks.harness.peers import matched_settings

    hopper = matched_settings("Hopper-v4")  # lin_1e-3 in bc.yml: d3rlpy decays its rate the same way
    assert hopper["learning_rate"] == pytest.approx(1e-3) and hopper["linear_decay"] and hopper["standardize"]
    assert matched_settings("CartPole-v1")["linear_decay"] is False
    assert matched_settings("CartPole-v1")["weight_decay"] == pytest.approx(1e-3)  # bc.yml: both libraries decay
    assert matched_settings("CartPole-v1")["activation"] == "elu" and hopper["activation"] == "relu"


def test_peers_section_pairs_each_library_with_ours_on_the_same_seeds(tmp_path):
    from benchmarks.harness.page import peers_section
    from benchmarks.harness.peers import PEER_COLUMNS
    from benchmarks.harness.results import append_rows

    path = tmp_path / "peers.csv"
    rows = [{"library": lib, "algo": "BC", "env": "LunarLander-v3", "n_trajectories": 1, "seed": seed,
             "mean_return": ret, "std_return": 0.0, "n_episodes": 10, "updates": 100, "fit_seconds": t,
             "seconds_per_update": t / 100, "settings": "", "commit": "abc"}
            for seed, (ours, theirs) in enumerate([(100.0, 130.0), (150.0, 170.0), (90.0, 80.0)])
            for lib, ret, t in (("sb3_mbil", ours, 1.0), ("d3rlpy 2.8.1", theirs, 2.0))]
    append_rows(str(path), rows, PEER_COLUMNS)
    text = peers_section(str(path))
    # differences +30, +20, -10: mean +13.3, above on 2 of 3; the speed ratio is 2.00
    assert "| LunarLander-v3 | 1 | d3rlpy 2.8.1 | 126.7 (3) | 20.00 | 2.00 | +13.3 [" in text
    assert "above on 2 of 3 |" in text
