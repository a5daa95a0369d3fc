"""Models to the Hub, offline: ``python -m rl_zoo3.push_to_hub --algo <ours>`` and ``huggingface_sb3.package_to_hub``
against a stand-in for the hub API (tests/hub_standin); the uploaded zip loads and the model card names the expert
pool, N and the seed of the draw."""

import os
import subprocess
import sys
from pathlib import Path

import gymnasium as gym

from sb3_mbil import MBILC, load_demonstrations

HERE = Path(__file__).resolve().parent


def run(args, cwd, env=None):
    return subprocess.run([sys.executable, *args], cwd=cwd, capture_output=True, text=True, timeout=600,
                          env={**os.environ, "OMP_NUM_THREADS": "1", **(env or {})})


def test_rl_zoo_push_to_hub(tmp_path):
    train = run(["-m", "rl_zoo3.train", "--algo", "bc", "--env", "CartPole-v1", "-f", "logs", "-n", "50", "--seed", "7",
                 "--num-threads", "1", "--hyperparams", "n_expert_trajectories:3"], tmp_path)
    assert train.returncode == 0, train.stderr[-3000:]
    hub = tmp_path / "hub"
    push = run(["-m", "rl_zoo3.push_to_hub", "--algo", "bc", "--env", "CartPole-v1", "-f", "logs", "-orga", "someone",
                "--no-render", "-n", "10"], tmp_path,
               env={"PYTHONPATH": str(HERE / "hub_standin"), "SB3_MBIL_HUB_STANDIN": str(hub)})
    assert push.returncode == 0, push.stderr[-3000:]
    repo = hub / "someone" / "bc-CartPole-v1"
    card = (repo / "README.md").read_text()
    for fact in ("'expert_pool', 'CartPole-v1'", "'n_expert_trajectories', 3", "'expert_seed', 7"):
        assert fact in card, card
    from sb3_mbil import BC

    model = BC.load(repo / "bc-CartPole-v1.zip")
    assert model.expert_info["draw_seed"] == 7 and model.expert_info["n_trajectories"] == 3


def test_huggingface_sb3_package_to_hub(tmp_path):
    import sys as _sys

    _sys.path.insert(0, str(HERE / "hub_standin"))
    try:
        import sitecustomize as standin  # noqa: F401  (the stand-in module, not the interpreter's)
    finally:
        _sys.path.pop(0)
    standin.install(tmp_path / "hub")
    from huggingface_sb3 import package_to_hub

    data = load_demonstrations("CartPole-v1").sample(2, seed=11)
    model = MBILC("MlpPolicy", "CartPole-v1", expert_data=data, model_max_steps=20, seed=0).learn(20)
    package_to_hub(model=model, model_name="mbil_c-CartPole-v1", model_architecture="MBILC", env_id="CartPole-v1",
                   eval_env=gym.make("CartPole-v1", render_mode="rgb_array"), repo_id="someone/mbil_c-CartPole-v1", n_eval_episodes=2,
                   video_length=0)
    repo = tmp_path / "hub" / "someone" / "mbil_c-CartPole-v1"
    card = (repo / "README.md").read_text()
    assert "## Expert data (sb3_mbil)" in card
    assert "- expert pool: `CartPole-v1`" in card and "- N (expert trajectories): 2" in card and "- seed of the draw: 11" in card
    assert MBILC.load(repo / "mbil_c-CartPole-v1.zip").expert_info["pool_indices"] == model.expert_info["pool_indices"]
