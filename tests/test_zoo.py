"""RL Zoo integration through the real command lines (subprocesses), and how the registration is installed."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import optuna
import pytest
import yaml

from sb3_mbil import ALGORITHMS

REPO = Path(__file__).resolve().parent.parent

TINY = {
    "mbil": ["--hyperparams", "flow_max_steps:40", "noise_grid:[0.1]", "flow_hidden:[32]"],
    "mbil_c": ["--hyperparams", "model_max_steps:40", "model_hidden:[32]"],
    "edm": ["--hyperparams", "sgld_steps:2", "sgld_buffer_size:100"],
    "dsfn": ["--hyperparams", "warm_start_steps:20", "dqn_steps:10", "sf_steps:10", "max_iterations:2"],
}
# the paper's discrete baselines are checked where their issue asks: LunarLander-v3
ZOO_ENV = {name: "CartPole-v1" if name in ("mbil", "mbil_c", "bc") else "LunarLander-v3" for name in ALGORITHMS}
ZOO_ENV["odice"] = "Hopper-v4"  # Box only: its zoo entries are the MuJoCo envs
# MuJoCo rendering needs an OpenGL platform these machines lack: videos are recorded for the classic-control envs
RENDERS = {"CartPole-v1", "LunarLander-v3"}


def run(args, cwd, timeout=600, env=None):
    return subprocess.run([sys.executable, *args], cwd=cwd, capture_output=True, text=True, timeout=timeout,
                          env={**os.environ, **(env or {})})


def test_interpreter_start_imports_neither_torch_nor_rl_zoo3(tmp_path):
    code = (
        "import sys; print(any(type(f).__name__ == 'ZooFinder' for f in sys.meta_path), "
        "[m for m in ('torch', 'rl_zoo3', 'sb3_mbil', 'stable_baselines3', 'numpy') if m in sys.modules])"
    )
    out = run(["-c", code], tmp_path)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "True []"


#: the default suite runs the zoo's train, enjoy and record_video for MBIL, MBIL-C and BC; the other algorithms' runs
#: (about 25 s each) are behind the slow marker, which CI runs too
DEFAULT_ZOO_RUNS = ("mbil", "mbil_c", "bc")


@pytest.mark.parametrize("algo", [a if a in DEFAULT_ZOO_RUNS else pytest.param(a, marks=pytest.mark.slow)
                                  for a in ALGORITHMS])
def test_train_enjoy_record_video(algo, tmp_path):
    env = ZOO_ENV[algo]
    train = run(["-m", "rl_zoo3.train", "--algo", algo, "--env", env, "-n", "60", "--eval-freq", "30",
                 "--eval-episodes", "1", "--num-threads", "1", "--seed", "0", "-f", "logs", *TINY.get(algo, [])], tmp_path)
    assert train.returncode == 0, train.stderr[-3000:]
    run_dir = tmp_path / "logs" / algo / f"{env}_1"
    assert (run_dir / "best_model.zip").is_file() and (run_dir / f"{env}.zip").is_file()
    config = dict(yaml.unsafe_load((run_dir / env / "config.yml").read_text()))
    assert config["expert_pool"] == env and config["n_expert_trajectories"] == 1
    assert "Eval num_timesteps=60" in train.stdout  # EvalCallback counts gradient steps
    if algo in ("bc", "mbil", "mbil_c"):  # the published comparison's ELU hidden layers on classic control
        assert config["policy_kwargs"] == "dict(activation_fn=nn.ELU)"

    enjoy = run(["-m", "rl_zoo3.enjoy", "--algo", algo, "--env", env, "-f", "logs", "--no-render", "-n", "30"],
                tmp_path)
    assert enjoy.returncode == 0, enjoy.stderr[-3000:]

    if env in RENDERS:
        video = run(["-m", "rl_zoo3.record_video", "--algo", algo, "--env", env, "-f", "logs", "-n", "20",
                     "-o", "videos"], tmp_path)
        assert video.returncode == 0, video.stderr[-3000:]
        assert list((tmp_path / "videos").glob("*.mp4"))


@pytest.mark.parametrize("algo", ["mbil", "bc"])
def test_mujoco_entry_trains_on_its_shipped_pool(algo, tmp_path):
    """The Figure 4 settings as a zoo user runs them: one Hopper-v4 trajectory drawn with the run's seed,
    inputs standardised with that trajectory's states (kept by save/load)."""
    from sb3_mbil import BC, MBIL, load_demonstrations

    train = run(["-m", "rl_zoo3.train", "--algo", algo, "--env", "Hopper-v4", "-n", "20", "--eval-freq", "-1",
                 "--num-threads", "1", "--seed", "3", "-f", "logs", *TINY.get(algo, [])], tmp_path)
    assert train.returncode == 0, train.stderr[-3000:]
    model = {"mbil": MBIL, "bc": BC}[algo].load(tmp_path / "logs" / algo / "Hopper-v4_1" / "Hopper-v4.zip")
    drawn = load_demonstrations("Hopper-v4").sample(1, seed=3).pairs()["observations"]
    assert model.policy.normalize_observations and bool(model.policy.obs_stats_set)
    np.testing.assert_allclose(model.policy.obs_mean.numpy(), drawn.mean(0), rtol=1e-5, atol=1e-5)
    assert model.num_timesteps == 20
    # the backbone (issue 19): a tanh-bounded mean, and the zoo's "lin_1e-3" decayed to 1e-3 / 20 at the last update
    assert model.policy.bounded_mean
    assert model.policy.optimizer.param_groups[0]["lr"] == pytest.approx(1e-3 / 20)


def test_an_algorithm_without_its_own_sampler_is_refused_at_registration(monkeypatch):
    from sb3_mbil import zoo

    zoo.check_registration()  # every registered algorithm has its sampler, converter and hyperparameters
    monkeypatch.delitem(zoo.SAMPLERS, "rcal")
    with pytest.raises(RuntimeError, match=r"ALGORITHMS\['rcal'\]: expected an Optuna sampler"):
        zoo.check_registration()


@pytest.mark.parametrize("algo", list(ALGORITHMS))
def test_every_sampler_gives_constructor_arguments(algo):
    """Each algorithm's Optuna sampler proposes settings its constructor accepts."""
    import gymnasium as gym

    from sb3_mbil import zoo

    for seed in range(3):
        trial = optuna.create_study(sampler=optuna.samplers.RandomSampler(seed=seed)).ask()
        params = zoo.SAMPLERS[algo](trial, 2, 1, {})
        from sb3_mbil.experts.controllers import native_env

        ALGORITHMS[algo]("MlpPolicy", gym.make(native_env(ALGORITHMS[algo])), **params)


def test_dsfn_entries_train_their_whole_schedule():
    """A DSFN entry's n_timesteps is its schedule's length (shorter stops it mid-iteration; the zoo and the
    benchmark rows report it as the run's length)."""
    import inspect
    from types import SimpleNamespace

    from sb3_mbil import DSFN

    defaults = {k: p.default for k, p in inspect.signature(DSFN).parameters.items()}
    for env, entry in yaml.safe_load((REPO / "zoo_hyperparams" / "dsfn.yml").read_text()).items():
        names = ("warm_start_steps", "sf_steps", "dqn_steps", "max_iterations")
        schedule = SimpleNamespace(**{k: entry.get(k, defaults[k]) for k in names})
        assert float(entry["n_timesteps"]) == DSFN.schedule_steps.fget(schedule), env


def test_number_of_trajectories_is_a_hyperparameter(tmp_path):
    train = run(["-m", "rl_zoo3.train", "--algo", "bc", "--env", "Acrobot-v1", "-n", "5", "--eval-freq", "-1",
                 "--num-threads", "1", "--seed", "0", "-f", "logs", "--hyperparams", "n_expert_trajectories:3"], tmp_path)
    assert train.returncode == 0, train.stderr[-3000:]
    config = dict(yaml.unsafe_load((tmp_path / "logs/bc/Acrobot-v1_1/Acrobot-v1/config.yml").read_text()))
    assert config["n_expert_trajectories"] == 3


def test_optimize_two_workers_share_one_study(tmp_path):
    storage = f"sqlite:///{tmp_path / 'study.db'}"
    optuna.create_study(storage=storage, study_name="mbil-cartpole", direction="maximize")
    args = ["-m", "rl_zoo3.train", "--algo", "mbil", "--env", "CartPole-v1", "-optimize", "--storage", storage,
            "--study-name", "mbil-cartpole", "--n-trials", "1", "-n", "40", "--n-evaluations", "1", "--eval-episodes", "1",
            "--num-threads", "1", "--sampler", "random", "--pruner", "none", "--no-optim-plots", "-f", "logs",
            *TINY["mbil"]]
    workers = [subprocess.Popen([sys.executable, *args], cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                text=True) for _ in range(2)]
    for w in workers:
        _, err = w.communicate(timeout=600)
        assert w.returncode == 0, err[-3000:]
    study = optuna.load_study(study_name="mbil-cartpole", storage=storage)
    complete = [t for t in study.trials if t.state == optuna.trial.TrialState.COMPLETE]
    assert len(complete) == 2
    assert {"alpha", "beta", "noise", "flow_hidden", "learning_rate"} <= set(complete[0].params)


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--env", "Pendulum-v1"], "sb3_mbil: no hyperparameters for mbil on Pendulum-v1"),
        (["--env", "CartPole-v1", "--hyperparams", "expert_pool:'Acrobot-v1'"],
         "sb3_mbil: expert_pool: expected demonstrations of CartPole-v1, found a pool of Acrobot-v1"),
        (["--env", "CartPole-v1", "--hyperparams", "expert_pool:'NoSuchPool'"], "shipped pool name"),
        (["--env", "CartPole-v1", "--hyperparams", "n_expert_trajectories:0"],
         "sb3_mbil: n_expert_trajectories: expected an integer >= 1, found 0"),
        (["--env", "CartPole-v1", "--hyperparams", "n_expert_trajectories:'abc'"],
         "sb3_mbil: n_expert_trajectories: expected an integer >= 1, found 'abc'"),
        (["--env", "CartPole-v1", "--hyperparams", "n_expert_trajectories:5000"],
         "sb3_mbil: n_expert_trajectories: expected at most the 1000 trajectories"),
        (["--env", "CartPole-v1", "--hyperparams", "n_steps:128"], "sb3_mbil: hyperparameters n_steps: expected settings of MBIL"),
        (["--env", "CartPole-v1", "--hyperparams", "alpha:-1.0"], "sb3_mbil: alpha: expected a finite number >= 0, found -1.0"),
        (["--env", "CartPole-v1", "--hyperparams", "flow_hidden:64"], "sb3_mbil: flow_hidden: expected a list of 1 or more"),
        (["--env", "CartPole-v1", "-n", "-5"], "sb3_mbil: -n/--n-timesteps: expected a number of gradient steps >= 1, found -5"),
        (["--env", "CartPole-v1", "--hyperparams", "policy_kwargs:'dict(net_arhc=[32])'"],
         "sb3_mbil: policy_kwargs: expected keys among"),
        (["--env", "CartPole-v1", "--hyperparams", "policy_kwargs:'dict(net_arch=dict(pi=[32]))'"],
         "sb3_mbil: policy_kwargs.net_arch: expected a list of layer sizes (one network"),
        (["--env", "CartPole-v1", "--hyperparams", "expert_seed:-1"], "sb3_mbil: expert_seed: seed: expected None or an"),
        (["--env", "CartPole-v1", "--hyperparams", "learning_rate:'lin_abc'"],
         "sb3_mbil: learning_rate: expected a number or 'lin_<initial value>', found 'lin_abc'"),
    ],
)
def test_bad_input_stops_with_a_clear_message(tmp_path, extra, message):
    args = extra if "-n" in extra else ["-n", "5", *extra]
    out = run(["-m", "rl_zoo3.train", "--algo", "mbil", "-f", "logs", *args], tmp_path)
    assert out.returncode != 0
    assert message in out.stderr
    assert "Traceback" not in out.stderr


@pytest.mark.parametrize("editable", [False, True], ids=["install", "editable"])
def test_install_ships_the_registration(tmp_path, editable):
    """The wheel of `pip install .` and the PEP 660 wheel of `pip install -e .` put sb3_mbil_zoo.pth in
    site-packages; `pip uninstall` removes it. Built with this interpreter's setuptools and installed
    without an index: no network."""
    src = tmp_path / "src"
    shutil.copytree(REPO, src, ignore=shutil.ignore_patterns(".git", ".venv", "build", "*.egg-info", "__pycache__", "logs"))
    hook = "build_editable" if editable else "build_wheel"
    code = f"from setuptools import build_meta; print(build_meta.{hook}({str(tmp_path / 'dist')!r}))"
    (tmp_path / "dist").mkdir()
    built = subprocess.run([sys.executable, "-c", code], cwd=src, capture_output=True, text=True, timeout=600)
    assert built.returncode == 0, built.stderr[-3000:]
    wheel = tmp_path / "dist" / built.stdout.strip().splitlines()[-1]
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    py = venv / "bin" / "python"
    inst = subprocess.run([str(py), "-m", "pip", "install", "-q", "--no-deps", "--no-index", str(wheel)],
                          capture_output=True, text=True, timeout=600)
    assert inst.returncode == 0, inst.stderr[-3000:]
    purelib = subprocess.run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                             capture_output=True, text=True).stdout.strip()
    pth = Path(purelib) / "sb3_mbil_zoo.pth"
    assert pth.read_text().strip() == "import sb3_mbil_zoo_hook"
    check = subprocess.run([str(py), "-c", "import sys; print(any(type(f).__name__ == 'ZooFinder' for f in sys.meta_path))"],
                           capture_output=True, text=True, cwd=tmp_path)
    assert check.stdout.strip() == "True", check.stderr
    if not editable:
        assert (Path(purelib) / "sb3_mbil" / "zoo_hyperparams" / "mbil.yml").is_file()
        assert (Path(purelib) / "sb3_mbil" / "data" / "CartPole-v1.npz").is_file()
    subprocess.run([str(py), "-m", "pip", "uninstall", "-y", "-q", "sb3_mbil"], check=True, capture_output=True)
    assert not pth.exists()


def test_default_eval_freq_evaluates_short_runs(tmp_path):
    train = run(["-m", "rl_zoo3.train", "--algo", "bc", "--env", "CartPole-v1", "-n", "50", "--eval-episodes", "1",
                 "--num-threads", "1", "--seed", "0", "-f", "logs"], tmp_path)
    assert train.returncode == 0, train.stderr[-3000:]
    assert "Eval num_timesteps=5," in train.stdout and "Eval num_timesteps=50," in train.stdout
    assert (tmp_path / "logs/bc/CartPole-v1_1/best_model.zip").is_file()
