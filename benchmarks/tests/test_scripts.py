"""The command lines on a user's own data: any pool and env, one-line errors, the extra to install, committed
files left alone unless --overwrite."""

import subprocess
import sys
from pathlib import Path

from sb3_mbil import Demonstrations

REPO = Path(__file__).resolve().parents[2]


def script(*args, env=None, timeout=300):
    import os

    return subprocess.run([sys.executable, *args], cwd=REPO, capture_output=True, text=True, timeout=timeout,
                          env={**os.environ, **(env or {})})


def pendulum_pool(path):
    """A user's own demonstrations: a hand-written Pendulum-v1 controller, saved as .npz by the script."""
    out = script("scripts/generate_expert_data.py", "--env", "Pendulum-v1", "--n-trajectories", "3", "--source",
                 "controller", "--out", str(path))
    assert out.returncode == 0, out.stderr[-2000:]
    demos = Demonstrations.load(path)
    assert demos.metadata["source"] == "controller:pendulum_controller" and -400 < demos.episode_returns.mean() < -50
    return path


def test_compare_on_own_data_and_an_env_without_zoo_settings(tmp_path):
    pool = pendulum_pool(tmp_path / "mine.npz")
    out = script("-m", "benchmarks.compare", "--env", "Pendulum-v1", "--pool", str(pool), "--algos", "bc", "mbil_c",
                 "--steps", "30", "--eval-episodes", "2")
    assert out.returncode == 0, out.stderr[-3000:]
    assert f"mean of the pool {pool}" in out.stdout and "mbil_c" in out.stdout


def test_errors_are_one_line(tmp_path):
    missing = script("-m", "benchmarks.compare", "--env", "CartPole-v1", "--pool", str(tmp_path / "nope.npz"), "--steps", "5")
    assert missing.returncode == 1 and "Traceback" not in missing.stderr
    assert missing.stderr.strip() == f"compare.py: expert data file not found: {tmp_path / 'nope.npz'}"
    two = script("-m", "benchmarks.run_grid", "--envs", "CartPole-v1", "Acrobot-v1", "--pool", "x.npz", "--local")
    assert two.returncode == 1 and two.stderr.strip().startswith("run_grid.py: --pool: expected one env")


def test_a_missing_extra_is_named(tmp_path):
    fake = tmp_path / "site" / "ray"
    fake.mkdir(parents=True)
    (fake / "__init__.py").write_text("raise ModuleNotFoundError(\"No module named 'ray'\", name='ray')\n")
    out = script("-m", "benchmarks.run_grid", "--algos", "bc", "--envs", "CartPole-v1", "--n-trajectories", "1", "--seeds",
                 "0", "--csv", str(tmp_path / "r.csv"), env={"PYTHONPATH": str(tmp_path / "site")})
    assert out.returncode == 1 and "Traceback" not in out.stderr
    assert "run_grid.py: needs ray: pip install 'sb3_mbil[benchmark]'" in out.stderr


def test_committed_files_are_replaced_only_with_overwrite(tmp_path):
    committed = "results/classic_control_relu.png"
    before = (REPO / committed).read_bytes()
    out = script("-m", "benchmarks.plot_results", "--csv", "results/classic_control_relu.csv", "--out", committed)
    assert out.returncode == 1
    assert out.stderr.strip() == f"plot_results.py: --out: {committed} is a committed file; pass --overwrite to replace it"
    assert (REPO / committed).read_bytes() == before
    fresh = script("-m", "benchmarks.plot_results", "--csv", "results/classic_control_relu.csv", "--out", str(tmp_path / "p.png"),
                   "--reps", "50")
    assert fresh.returncode == 0, fresh.stderr[-2000:]
    assert (tmp_path / "p.png").read_bytes()[:4] == b"\x89PNG"


def test_misspelt_settings_and_unwritable_results_are_one_line_before_any_training(tmp_path):
    base = ["-m", "benchmarks.run_grid", "--algos", "bc", "--envs", "CartPole-v1", "--n-trajectories", "1", "--seeds", "0",
            "--episodes", "2", "--local"]
    cases = {
        ("--csv", str(tmp_path / "r.csv"), "--overrides", '{"bc": {"learnig_rate": 0.001}}'):
            "bc.learnig_rate: expected a setting of BC",
        ("--csv", str(tmp_path / "r.csv"), "--overrides", "[1, 2]"): 'expected an object {"algo": {settings}}',
        ("--csv", str(tmp_path / "r.csv"), "--overrides", '{"bc": {"policy_kwargs": {"net_arhc": [32]}}}'):
            "policy_kwargs: expected keys among",
        ("--csv", str(tmp_path / "a-file" / "r.csv")): "--csv: expected a results file that can be appended to",
    }
    (tmp_path / "a-file").write_text("not a folder")
    for args, message in cases.items():
        out = script(*base, *args)
        assert out.returncode != 0 and "Traceback" not in out.stderr, (args, out.stderr[-800:])
        assert message in out.stderr.strip().splitlines()[-1], (args, out.stderr[-800:])  # one line (after usage)
    assert not (tmp_path / "r.csv").exists()  # nothing trained, nothing written
    curves = script("-m", "benchmarks.run_curves", "--variants", '{"x": ["bc", {"learnig_rate": 1}]}', "--envs",
                    "CartPole-v1", "--seeds", "0", "--updates", "10", "--csv", str(tmp_path / "c.csv"))
    assert curves.returncode != 0 and "variants['x']: bc.learnig_rate: expected a setting of BC" in curves.stderr
