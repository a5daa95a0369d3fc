"""Faults and bad inputs: every one a clear error naming what is wrong; no silent NaN, no lost model, no
corrupted results file."""

import os
import signal
import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest
import torch as th

from sb3_mbil import ALGORITHMS, BC, MBIL, Demonstrations, Trajectory, load_demonstrations
from sb3_mbil.experts.controllers import native_demo, native_env

FAST = {"mbil": dict(flow_max_steps=30, noise_grid=(0.1,), flow_hidden=(16,), flow_transforms=2),
        "mbil_c": dict(model_max_steps=30, model_hidden=(16,)),
        "edm": dict(sgld_steps=1, sgld_buffer_size=50),
        "dsfn": dict(warm_start_steps=5, dqn_steps=5, sf_steps=5, max_iterations=2)}


@pytest.fixture(scope="module")
def demo():
    return load_demonstrations("CartPole-v1").sample(1, seed=0)


def make(name, data, **kwargs):
    env = native_env(ALGORITHMS[name])
    return ALGORITHMS[name]("MlpPolicy", env, expert_data=data, seed=0, **{**FAST.get(name, {}), **kwargs})


# ---------------------------------------------------------------------------------------------- non-finite
@pytest.mark.parametrize("name", list(ALGORITHMS))
def test_data_that_would_overflow_float32_is_refused_when_given(name):
    native = native_demo(ALGORITHMS[name])[0]
    o, a = native.observations.copy(), native.actions
    o[:50, 1] = 1e30
    with pytest.raises(ValueError, match=r"observations: expected values of magnitude <= 1e\+15"):
        make(name, [(o, a)])


@pytest.mark.parametrize("name", list(ALGORITHMS))
def test_a_non_finite_loss_or_parameter_stops_training_naming_it(name):
    model = make(name, native_demo(ALGORITHMS[name])).learn(3)
    with th.no_grad():
        next(model.policy.parameters()).fill_(float("nan"))
    with pytest.raises(FloatingPointError, match=rf"{type(model).__name__}: .* (is nan|is not finite) .*gradient step 4"):
        model.learn(5, reset_num_timesteps=False)


def test_an_exploding_learning_rate_stops_mbil_with_its_term(demo):
    with pytest.raises(FloatingPointError, match=r"MBIL: train/balance_loss is inf at gradient step \d+"):
        make("mbil", demo, learning_rate=1e6).learn(300)


# ---------------------------------------------------------------------------------------------- files
@pytest.mark.parametrize("name", ["bc", "mbil"])
def test_a_failed_save_keeps_the_old_model_and_leaves_no_temporary(name, demo, tmp_path, monkeypatch):
    model = make(name, demo).learn(3)
    model.save(tmp_path / "m.zip")
    good = (tmp_path / "m.zip").read_bytes()
    import stable_baselines3.common.base_class as base_class

    def boom(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(base_class, "save_to_zip_file", boom)
    with pytest.raises(OSError, match="disk full"):
        model.save(tmp_path / "m.zip")
    assert (tmp_path / "m.zip").read_bytes() == good
    assert os.listdir(tmp_path) == ["m.zip"]


def test_a_killed_save_leaves_the_old_model_and_its_temporary_is_cleared_by_the_next_save(demo, tmp_path):
    BC("MlpPolicy", "CartPole-v1", expert_data=demo).save(tmp_path / "m.zip")
    good = (tmp_path / "m.zip").read_bytes()
    # a process killed while writing the temporary
    code = ("import os, signal, stable_baselines3.common.base_class as b\n"
            "from sb3_mbil import BC\n"
            "def die(path, *a, **k):\n"
            "    open(path, 'wb').write(b'half a zip'); os.kill(os.getpid(), signal.SIGKILL)\n"
            "b.save_to_zip_file = die\n"
            f"BC('MlpPolicy', 'CartPole-v1').save({str(tmp_path / 'm.zip')!r})\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, timeout=300)
    assert out.returncode == -signal.SIGKILL
    assert (tmp_path / "m.zip").read_bytes() == good  # the old model is intact
    assert len(list(tmp_path.glob(".m.zip.*.tmp"))) == 1  # what the killed process left
    BC.load(tmp_path / "m.zip").save(tmp_path / "m.zip")
    assert os.listdir(tmp_path) == ["m.zip"]


def test_a_killed_demonstrations_save_is_cleared_by_the_next_save(demo, tmp_path):
    (tmp_path / ".d.npz.999999999.tmp").write_bytes(b"x" * 1000)  # a temporary of a process that is gone
    (tmp_path / f".d.npz.{os.getpid()}.tmp.other").write_bytes(b"")  # not a temporary of ours: kept
    demo.save(tmp_path / "d.npz")
    assert sorted(os.listdir(tmp_path)) == sorted(["d.npz", f".d.npz.{os.getpid()}.tmp.other"])


# ---------------------------------------------------------------------------------------------- loading
def test_load_names_the_file_and_both_algorithms(demo, tmp_path):
    make("mbil", demo).learn(2).save(tmp_path / "mbil.zip")
    make("bc", demo).learn(2).save(tmp_path / "bc.zip")
    with pytest.raises(ValueError, match=r"mbil.zip: expected a model saved by BC, found one saved by sb3_mbil's MBIL"):
        BC.load(tmp_path / "mbil.zip")
    with pytest.raises(ValueError, match=r"bc.zip: expected a model saved by MBIL, found one saved by sb3_mbil's BC"):
        MBIL.load(tmp_path / "bc")
    from stable_baselines3 import DQN, PPO

    for sb3 in (PPO, DQN):
        sb3("MlpPolicy", "CartPole-v1").save(tmp_path / "sb3.zip")
        with pytest.raises(ValueError, match="sb3.zip: expected a model saved by BC, found one saved by another library"):
            BC.load(tmp_path / "sb3.zip")
    (tmp_path / "cut.zip").write_bytes((tmp_path / "bc.zip").read_bytes()[:-300])
    with pytest.raises(ValueError, match="cut.zip: expected a model zip saved by BC.save, found an unreadable file"):
        BC.load(tmp_path / "cut.zip")
    loaded = MBIL.load(tmp_path / "mbil.zip", env="CartPole-v1")  # an env id, as in the constructor
    assert loaded.env is not None and loaded.observation_space == gym.make("CartPole-v1").observation_space


def test_expert_data_is_checked_when_given(demo, tmp_path):
    bad = [(np.full((6, 4), np.nan), np.zeros(5, dtype=int))]
    with pytest.raises(ValueError, match="observations: expected finite"):
        BC("MlpPolicy", "CartPole-v1", expert_data=bad)
    model = BC("MlpPolicy", "CartPole-v1", expert_data=demo)
    with pytest.raises(ValueError, match="observations: expected finite"):
        model.set_expert_data(bad)
    model.save(tmp_path / "m.zip")
    with pytest.raises(ValueError, match="observations: expected finite"):
        BC.load(tmp_path / "m.zip", env="CartPole-v1", expert_data=bad)


# ---------------------------------------------------------------------------------------------- data files
def _write(tmp_path, **overrides):
    d = Demonstrations([Trajectory(np.zeros((4, 4), np.float32), np.zeros(3, np.int64))], {"env_id": "CartPole-v1"})
    path = d.save(tmp_path / "d.npz")
    with np.load(path) as f:
        arrays = {k: f[k] for k in f.files}
    arrays.update(overrides)
    np.savez_compressed(path, **arrays)
    return path


@pytest.mark.parametrize("overrides, message", [
    (dict(metadata_json=np.array("{not json")), "metadata_json: expected a JSON object, found unreadable JSON"),
    (dict(metadata_json=np.array("[1, 2]")), "metadata_json: expected a JSON object, found list"),
    (dict(n_observations=np.array(4)), "n_observations: expected an array with one entry per trajectory, found a 0-d"),
    (dict(n_actions=np.array([3.0])), "n_actions: expected a 1-d array of non-negative integers"),
    (dict(n_actions=np.array([-1])), "n_actions: expected a 1-d array of non-negative integers"),
    (dict(episode_returns=np.array([1.0, 2.0])), "episode_returns: expected 1 entries"),
    (dict(terminated=np.array([True, False])), "terminated: expected 1 entries"),
    (dict(terminated=np.array(["False"])), "terminated: expected booleans"),
    (dict(truncated=np.array([2])), "truncated: expected booleans"),
    (dict(format_version=np.array(99)), "format_version: expected an integer <= 2"),
])
def test_every_field_of_a_data_file_is_validated_with_its_path(tmp_path, overrides, message):
    path = _write(tmp_path, **overrides)
    with pytest.raises(ValueError, match=message) as e:
        load_demonstrations(path)
    assert str(path) in str(e.value)


def test_a_directory_is_not_reported_as_a_missing_file(tmp_path):
    with pytest.raises(ValueError, match="expected a .npz file, found a directory"):
        BC("MlpPolicy", "CartPole-v1", expert_data=tmp_path)


def test_observations_outside_the_observation_space_are_refused():
    obs = np.zeros((6, 4), np.float32)
    obs[2, 0] = 9.0  # CartPole's cart position lies in [-4.8, 4.8]
    with pytest.raises(ValueError, match=r"observations: expected values within the observation space bounds .* found 9.0"):
        BC("MlpPolicy", "CartPole-v1", expert_data=[(obs, np.zeros(5, np.int64))])


def test_data_recorded_on_another_env_is_warned_about(tmp_path):
    d = load_demonstrations("CartPole-v1").sample(1, seed=0)
    d = Demonstrations(list(d), {**d.metadata, "env_id": "CartPole-v0"})
    with pytest.warns(UserWarning, match="recorded on CartPole-v0 .* used with CartPole-v1"):
        BC("MlpPolicy", "CartPole-v1", expert_data=d)


# ---------------------------------------------------------------------------------------------- round three
def test_values_of_the_wrong_type_are_refused_or_kept_exactly(demo, tmp_path):
    with pytest.raises(ValueError, match="episode_return: expected a number"):
        Trajectory(np.zeros((3, 4)), np.zeros(2, dtype=np.int64), episode_return="abc")
    pool = load_demonstrations("CartPole-v1")
    for n in (True, np.bool_(True)):
        with pytest.raises(ValueError, match=r"n: expected an integer in \[1, 1000\]"):
            pool.sample(n)
    for seed in (-1, True, 1.5, "5", 2**70):
        with pytest.raises(ValueError, match="seed: expected None or an integer >= 0"):
            pool.sample(2, seed=seed)
        with pytest.raises(ValueError, match="seed: expected"):
            pool.sample(2, seed=0).subsample(2, seed=seed)
    drawn = pool.sample(np.int64(2), seed=np.int64(5))
    assert drawn.metadata["sampled"]["indices"] == pool.sample(2, seed=5).metadata["sampled"]["indices"]
    drawn.metadata["user_value"] = np.float32(0.5)
    again = Demonstrations.load(drawn.save(tmp_path / "d.npz"))
    assert again.metadata["sampled"]["seed"] == 5 and type(again.metadata["sampled"]["seed"]) is int
    assert again.metadata["user_value"] == 0.5
    model = BC("MlpPolicy", "CartPole-v1", expert_data=drawn)
    model.save(tmp_path / "m.zip")
    info = BC.load(tmp_path / "m.zip", safe=True).expert_info
    assert info["draw_seed"] == 5 and type(info["draw_seed"]) is int


def test_expert_data_cannot_change_under_a_running_update(demo):
    from stable_baselines3.common.callbacks import BaseCallback

    class Swap(BaseCallback):
        def _on_step(self):
            if self.n_calls == 2:
                self.model.set_expert_data(load_demonstrations("CartPole-v1").sample(1, seed=3))
            return True

    model = make("mbil", demo)
    with pytest.raises(ValueError, match="expert_data: expected no change while learn trains on the data"):
        model.learn(5, callback=Swap())
    model.set_expert_data(load_demonstrations("CartPole-v1").sample(1, seed=3))  # between learns: fine
    model.learn(2)


def _rewrite_zip(src, dst, change):
    import zipfile

    with zipfile.ZipFile(src) as a, zipfile.ZipFile(dst, "w") as b:
        for name in a.namelist():
            content = change(name, a.read(name))
            if content is not None:
                b.writestr(name, content)
    return dst


def test_loading_says_what_is_wrong_with_a_zip(demo, tmp_path):
    import json
    import warnings
    import zipfile

    BC("MlpPolicy", "CartPole-v1", expert_data=demo).save(tmp_path / "b.zip")

    def older_and_newer(name, content):
        if name == "data":
            data = json.loads(content)
            del data["weight_decay"]
            return json.dumps({**data, "future_knob": 3})
        return b"9.9.9" if name == "_stable_baselines3_version" else content

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        BC.load(_rewrite_zip(tmp_path / "b.zip", tmp_path / "c.zip", older_and_newer))
    text = " | ".join(str(w.message) for w in caught)
    assert "newer than the installed" in text and "the zip has no ['weight_decay']" in text and "['future_knob']" in text
    garbage = _rewrite_zip(tmp_path / "b.zip", tmp_path / "g.zip", lambda n, c: b"\x00" * 9 if n == "policy.pth" else c)
    with pytest.raises(ValueError, match="policy.pth: expected torch weights"):
        BC.load(garbage)
    BC("MlpPolicy", "CartPole-v1", expert_data=demo, policy_kwargs=dict(net_arch=[8])).save(tmp_path / "small.zip")
    other = zipfile.ZipFile(tmp_path / "small.zip").read("policy.pth")
    mismatch = _rewrite_zip(tmp_path / "b.zip", tmp_path / "x.zip", lambda n, c: other if n == "policy.pth" else c)
    with pytest.raises(ValueError, match="expected weights that fit the networks BC builds"):
        BC.load(mismatch)
    make("mbil", demo).save(tmp_path / "mbil.zip")
    relabelled = _rewrite_zip(tmp_path / "mbil.zip", tmp_path / "r.zip", lambda n, c: json.dumps(
        {**json.loads(c), "algorithm": "BC"}) if n == "data" else c)
    with pytest.raises(ValueError, match="expected weights that fit the networks BC builds"):
        BC.load(relabelled)


@pytest.mark.skipif(th.cuda.is_available(), reason="checks the CPU fallback")
def test_cuda_without_a_gpu_is_said(demo, tmp_path):
    with pytest.warns(UserWarning, match="torch sees no CUDA device"):
        BC("MlpPolicy", "CartPole-v1", expert_data=demo, device="cuda").save(tmp_path / "m.zip")
    with pytest.warns(UserWarning, match="torch sees no CUDA device"):
        BC.load(tmp_path / "m.zip", device="cuda")


def test_data_files_and_observations_say_what_is_wrong(demo, tmp_path, monkeypatch):
    import zipfile

    path = demo.save(tmp_path / "d.npz")
    with zipfile.ZipFile(path) as a, zipfile.ZipFile(tmp_path / "p.npz", "w") as b:
        for name in a.namelist():
            b.writestr(name, b"\x80\x04K\x01." if name == "actions.npy" else a.read(name))  # a raw pickle, not .npy
    with pytest.raises(ValueError, match="actions: expected an array member"):
        load_demonstrations(tmp_path / "p.npz")
    if os.path.exists("/dev/null"):
        with pytest.raises(ValueError, match="expected a regular .npz file, found /dev/null, which exists but is not"):
            load_demonstrations("/dev/null")
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "minari"))
    with pytest.raises(ValueError, match=r"observations: expected per-step shape \(3,\)"):
        demo.to_minari("ns/fit-v0", observation_space=gym.spaces.Box(-1, 1, (3,)), action_space=gym.spaces.Discrete(2))
    assert not (tmp_path / "minari").exists()
    model = BC("MlpPolicy", "CartPole-v1", expert_data=demo)
    with pytest.raises(ValueError, match="observation: expected numbers, found an array of dtype"):
        model.predict(np.array(["a", "b", "c", "d"]))
    with pytest.raises(ValueError, match=r"observation: expected finite values, found nan at index \(1,\)"):
        model.predict(np.array([0.0, np.nan, 0.0, 0.0], dtype=np.float32))
    with pytest.raises(ValueError, match=r"observation_space: expected at least one observation dimension"):
        BC("MlpPolicy", EmptyObs())


class EmptyObs(gym.Env):
    observation_space = gym.spaces.Box(-1, 1, (0,))
    action_space = gym.spaces.Discrete(2)


class HWCImages(gym.Env):
    observation_space = gym.spaces.Box(0, 255, (8, 8, 3), np.uint8)
    action_space = gym.spaces.Discrete(2)

    def reset(self, seed=None, options=None):
        super().reset(seed=seed)
        return self.observation_space.sample(), {}

    def step(self, action):
        return self.observation_space.sample(), 0.0, False, False, {}


def test_images_channels_last_are_explained_and_exported_in_the_envs_layout(tmp_path):
    pytest.importorskip("onnxruntime")
    import onnxruntime as ort

    from sb3_mbil import export_policy

    rng = np.random.default_rng(0)
    hwc = rng.integers(0, 256, size=(21, 8, 8, 3)).astype(np.uint8)
    actions = rng.integers(0, 2, size=20)
    with pytest.raises(ValueError, match=r"SB3 trains on images channels first .* np.transpose\(observations, \(0, 3, 1, 2\)\)"):
        BC("MlpPolicy", HWCImages(), expert_data=[(hwc, actions)])
    model = BC("MlpPolicy", HWCImages(), expert_data=[(np.transpose(hwc, (0, 3, 1, 2)), actions)], seed=0).learn(20)
    session = ort.InferenceSession(str(export_policy(model, tmp_path / "p.onnx")))
    onnx_actions = session.run(None, {"observation": hwc.reshape(21, -1).astype(np.float32)})[0]
    np.testing.assert_array_equal(onnx_actions, model.predict(hwc, deterministic=True)[0])


def test_the_saved_optimiser_settles_the_weight_decay_of_a_zip(demo, tmp_path):
    import json

    BC("MlpPolicy", "CartPole-v1", expert_data=demo, weight_decay=0.01).save(tmp_path / "w.zip")
    older = _rewrite_zip(tmp_path / "w.zip", tmp_path / "older.zip", lambda n, c: json.dumps(
        {k: v for k, v in json.loads(c).items() if k != "weight_decay"}) if n == "data" else c)
    with pytest.warns(UserWarning, match=r"weight_decay: taken from the saved optimiser \(0.01\)"):
        model = BC.load(older)
    assert model.weight_decay == 0.01 and model.policy.optimizer.param_groups[0]["weight_decay"] == 0.01
    edited = _rewrite_zip(tmp_path / "w.zip", tmp_path / "edited.zip", lambda n, c: json.dumps(
        {**json.loads(c), "weight_decay": 0.5}) if n == "data" else c)
    with pytest.raises(ValueError, match=r"weight_decay: expected the saved optimiser's weight decay \(0.01\), found 0.5"):
        BC.load(edited)
