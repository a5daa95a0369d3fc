"""Held-out validation in the harness: learning curves record the held-out loss; the weight-decay diagnostic."""

import csv
from benchmarks.harness.cli import harness_env


def test_learning_curves_record_the_held_out_loss(tmp_path):
    """run_curves --holdout: each evaluation row carries the held-out BC loss; curve_summary --heldout reads it."""
    import subprocess
    import sys

    out = subprocess.run([sys.executable, "-m", "benchmarks.run_curves", "--local", "--variants",
                          '{"bc": ["bc", {}]}', "--envs", "CartPole-v1", "--seeds", "0-1", "--updates", "40",
                          "--eval-every", "20", "--episodes", "2", "--holdout", "0.2", "--csv", "c.csv"],
                         capture_output=True, text=True, cwd=tmp_path, env=harness_env(), timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    with open(tmp_path / "c.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 4 and all(float(r["heldout_bc_loss"]) > 0 for r in rows)
    assert "('holdout_fraction', 0.2)" in rows[0]["settings"]
    summary = subprocess.run([sys.executable, "-m", "benchmarks.curve_summary", "c.csv", "--heldout"],
                             capture_output=True, text=True, cwd=tmp_path, env=harness_env(), timeout=300)
    assert summary.returncode == 0 and "return at the lowest held-out loss" in summary.stdout, summary.stderr[-2000:]
    bad = subprocess.run([sys.executable, "-m", "benchmarks.run_curves", "--envs", "CartPole-v1", "--updates", "5",
                          "--holdout", "1.5", "--csv", "d.csv"], capture_output=True, text=True, cwd=tmp_path, env=harness_env(), timeout=300)
    assert bad.returncode == 2 and "argument --holdout: expected a number in (0, 1)" in bad.stderr


def test_weight_decay_diagnostic_compares_the_decay_term_with_the_loss_gradient():
    """benchmarks.weight_decay: |lambda theta| / |grad L| per parameter group, on all expert pairs, during training."""
    from sb3_mbil import BC
    from sb3_mbil.experts.controllers import controller_demonstrations
    from benchmarks.weight_decay import decay_to_gradient

    demos = controller_demonstrations("Pendulum-v1", 1, seed=0)
    model = BC("MlpPolicy", "Pendulum-v1", expert_data=demos, seed=0, bc_loss="mse")
    rows = decay_to_gradient(model, updates=40, every=20, weight_decay=1e-3)
    assert [r["update"] for r in rows] == [0, 20, 40]
    assert rows[-1]["bc_loss"] < rows[0]["bc_loss"]
    for group in ("hidden weights", "biases", "output layer"):
        cell = rows[0][group]
        assert cell["grad"] > 0 and cell["decay"] > 0
        assert abs(cell["ratio"] - cell["decay"] / cell["grad"]) < 1e-12
