"""The examples run as a user runs them (short settings), and the algorithm pages in docs/ are up to date."""

import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent


def run(args, cwd):
    return subprocess.run([sys.executable, *args], cwd=cwd, capture_output=True, text=True, timeout=600)


def test_own_data_example(tmp_path):
    out = run([str(REPO / "examples" / "own_data_pendulum.py"), "--steps", "100", "--episodes", "2", "--out",
               str(tmp_path / "ex")], tmp_path)
    assert out.returncode == 0, out.stderr[-3000:]
    assert "expert:" in out.stdout and "BC:" in out.stdout and "MBILC:" in out.stdout
    assert (tmp_path / "ex" / "mbil_c.zip").is_file() and (tmp_path / "ex" / "mbil_c.onnx").is_file()


def test_mujoco_zoo_example(tmp_path):
    out = run([str(REPO / "examples" / "mujoco_zoo.py"), "--algo", "bc", "--steps", "100", "--episodes", "1"], tmp_path)
    assert out.returncode == 0, out.stderr[-3000:]
    assert "trained on 1 trajectory of the pool Hopper-v4 (draw seed 0)" in out.stdout
    assert "bc on Hopper-v4:" in out.stdout


def test_algorithm_pages_are_up_to_date(tmp_path):
    out = run([str(REPO / "scripts" / "make_docs.py"), "--out", str(tmp_path)], REPO)
    assert out.returncode == 0, out.stderr[-2000:]
    for page in tmp_path.iterdir():
        assert page.read_text() == (REPO / "docs" / "algorithms" / page.name).read_text(), (
            f"docs/algorithms/{page.name} is stale: run python scripts/make_docs.py")
