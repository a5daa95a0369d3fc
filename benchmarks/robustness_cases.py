"""The third round of robustness cases (security, types, settings, schedules, loading, data, results files,
options): each a bad input that must give a clear error or a warning naming the field, or a behaviour that must
hold (``Case.behaviour``). Read by :func:`benchmarks.robustness.cases`."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import zipfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import gymnasium as gym
import numpy as np

from benchmarks.harness.cli import harness_env


@dataclass
class Case:
    """One bad input or behaviour to try: ``run`` it, and a clean outcome is an error (or warning) naming ``field``."""

    kind: str
    description: str
    field: str  # what a clean message names
    run: Callable[[], object]
    outcome: str = ""
    message: str = ""
    #: the case is a behaviour, not a bad input: ``run`` returns True when the package behaves correctly
    behaviour: bool = False


def _rewrite(src: Path, dst: Path, change) -> Path:
    with zipfile.ZipFile(src) as a, zipfile.ZipFile(dst, "w") as b:
        for name in a.namelist():
            content = change(name, a.read(name))
            if content is not None:
                b.writestr(name, content)
    return dst


def _script(*args: str) -> None:
    """A command line run as a user would: a clean outcome is a non-zero exit whose last line names the field."""
    repo = Path(__file__).resolve().parent.parent
    out = subprocess.run([sys.executable, *args], capture_output=True, text=True, timeout=600, cwd=repo, env=harness_env())
    if out.returncode == 0:
        return None
    if "Traceback" in out.stderr:
        raise RuntimeError(out.stderr.strip().splitlines()[-1])
    raise ValueError(out.stderr.strip().splitlines()[-1])


def round_three(workdir: Path, demo, fast, saved) -> list:
    import torch as th

    from sb3_mbil import BC, MBIL, Demonstrations, Trajectory, load_demonstrations
    from benchmarks.harness.results import append_rows, drop_incomplete_last_line, read_result_rows

    out: list[Case] = []

    # ---- security
    def symlink_not_followed():
        victim = workdir / "victim.txt"
        victim.write_text("precious")
        (workdir / f".x.npz.{os.getpid()}.tmp").symlink_to(victim)
        demo.save(workdir / "x.npz")
        return victim.read_text() == "precious" and not (workdir / "x.npz").is_symlink()

    def crafted_zip_safe():
        import base64

        import cloudpickle

        marker = workdir / "code-ran"

        class Payload:
            def __reduce__(self):
                return (open, (str(marker), "w"))

        payload = {":type:": "x", ":serialized:": base64.b64encode(cloudpickle.dumps(Payload())).decode()}
        crafted = _rewrite(saved(BC, "safe"), workdir / "crafted.zip", lambda n, c: json.dumps(
            {**json.loads(c), "policy_class": payload}) if n == "data" else c)
        BC.load(crafted, safe=True)
        return not marker.exists()

    def overrides_not_run():
        from benchmarks.harness.grid import tuned_settings

        marker = workdir / "ran"
        try:
            tuned_settings("bc", "CartPole-v1", {"policy_kwargs": f"dict(a=open({str(marker)!r}, 'w'))"})
        except ValueError:
            pass
        return not marker.exists()

    def trust_for_strangers():
        import huggingface_sb3

        from sb3_mbil.experts.agents import load_hub_expert

        seen, real = {}, huggingface_sb3.load_from_hub

        def fake(repo_id, filename):
            seen["trust"] = os.environ.get("TRUST_REMOTE_CODE")
            raise OSError("offline")

        huggingface_sb3.load_from_hub = fake
        try:
            load_hub_expert("CartPole-v1", "dqn", org="someone-else", online=True)
        except LookupError:
            pass
        finally:
            huggingface_sb3.load_from_hub = real
        return seen.get("trust") is None

    out += [
        Case("round three: security", "N17 symlink planted at the old temporary name", "", symlink_not_followed, behaviour=True),
        Case("round three: security", "S04 crafted cloudpickle entry, load(safe=True)", "", crafted_zip_safe, behaviour=True),
        Case("round three: security", "B09 policy_kwargs override that would run code", "", overrides_not_run, behaviour=True),
        Case("round three: security", "G01 TRUST_REMOTE_CODE for another organisation", "", trust_for_strangers,
             behaviour=True),
        Case("round three: security", "M04 to_minari('../../escaped/x-v0')", "dataset_id",
             lambda: demo.to_minari("../../escaped/x-v0")),
    ]

    # ---- types
    def seed_round_trip():
        drawn = load_demonstrations("CartPole-v1").sample(np.int64(2), seed=np.int64(5))
        again = Demonstrations.load(drawn.save(workdir / "seed.npz"))
        model = BC("MlpPolicy", "CartPole-v1", expert_data=drawn)
        model.save(workdir / "seed.zip")
        info = BC.load(workdir / "seed.zip").expert_info
        return again.metadata["sampled"]["seed"] == 5 and type(again.metadata["sampled"]["seed"]) is int \
            and type(info["draw_seed"]) is int

    out += [
        Case("round three: types", "D21 Trajectory(episode_return='abc')", "episode_return",
             lambda: Trajectory(np.zeros((3, 4)), np.zeros(2, dtype=np.int64), episode_return="abc")),
        Case("round three: types", "D23 sample(True)", "n", lambda: demo_pool().sample(True)),
        Case("round three: types", "D24 np.int64 draw seed through npz and model save/load", "", seed_round_trip,
             behaviour=True),
        Case("round three: types", "D26 sample(2, seed=-1)", "seed", lambda: demo_pool().sample(2, seed=-1)),
        Case("round three: types", "L24 normalize_observations='no'", "normalize_observations",
             lambda: BC("MlpPolicy", "CartPole-v1", policy_kwargs=dict(normalize_observations="no"))),
    ]

    # ---- policy and optimiser settings, schedules
    for cid, kwargs, field in (("L21", dict(net_arch=[-5]), "net_arch"), ("L22", dict(activation_fn="relu"), "activation_fn"),
                               ("L25", dict(optimizer_kwargs=dict(weight_decay=0.1)), "weight_decay"),
                               ("Z09", dict(net_arch=dict(pi=[32])), "net_arch"), ("Z01", dict(net_arhc=[32]), "policy_kwargs")):
        out.append(Case("round three: settings", f"{cid} policy_kwargs={kwargs}", field,
                        lambda kwargs=kwargs: BC("MlpPolicy", "CartPole-v1", policy_kwargs=kwargs)))
    out.append(Case("round three: settings", "L26 weight_decay=1e-3 with optimizer_kwargs weight_decay 0.1", "weight_decay",
                    lambda: BC("MlpPolicy", "CartPole-v1", weight_decay=1e-3,
                               policy_kwargs=dict(optimizer_kwargs=dict(weight_decay=0.1)))))
    for cid, schedule in (("L16", lambda p: float("nan")), ("L18", lambda p: "fast"),
                          ("L16b", lambda p: 1e-3 if p > 0.5 else float("nan"))):
        out.append(Case("round three: schedules", f"{cid} learning_rate schedule", "learning_rate",
                        lambda schedule=schedule: BC("MlpPolicy", "CartPole-v1", expert_data=demo,
                                                     learning_rate=schedule).learn(10)))

    # ---- loading
    def changed(name, change):
        return lambda: BC.load(_rewrite(saved(BC, f"base_{name}"), workdir / f"{name}.zip", change))

    def drop(key):
        return lambda n, c: json.dumps({k: v for k, v in json.loads(c).items() if k != key}) if n == "data" else c

    def relabel(n, c):
        return json.dumps({**json.loads(c), "algorithm": "BC"}) if n == "data" else c

    def other_weights():
        BC("MlpPolicy", "CartPole-v1", policy_kwargs=dict(net_arch=[8])).save(workdir / "small.zip")
        other = zipfile.ZipFile(workdir / "small.zip").read("policy.pth")
        return lambda n, c: other if n == "policy.pth" else c

    out += [
        Case("round three: loading", "S02 zip lacking weight_decay", "weight_decay", changed("S02", drop("weight_decay"))),
        Case("round three: loading", "S03 zip with an unknown hyperparameter", "future_knob", changed(
            "S03", lambda n, c: json.dumps({**json.loads(c), "future_knob": 3}) if n == "data" else c)),
        Case("round three: loading", "S03b zip of a newer SB3", "newer", changed(
            "S03b", lambda n, c: b"9.9.9" if n == "_stable_baselines3_version" else c)),
        Case("round three: loading", "S05 policy.pth a malicious pickle", "policy.pth", changed(
            "S05", lambda n, c: b"\x80\x04cos\nsystem\n." if n == "policy.pth" else c)),
        Case("round three: loading", "S06 policy.pth of another net_arch", "expected weights", lambda: changed(
            "S06", other_weights())()),
        Case("round three: loading", "S16 policy.pth random bytes", "policy.pth", changed(
            "S16", lambda n, c: os.urandom(64) if n == "policy.pth" else c)),
        Case("round three: loading", "S18 an MBIL zip relabelled BC", "expected weights", lambda: BC.load(
            _rewrite(saved(MBIL, "relabel"), workdir / "S18.zip", relabel))),
        Case("round three: loading", "L11 device='cuda' without a GPU", "cuda", lambda: BC(
            "MlpPolicy", "CartPole-v1", device="cuda") if not th.cuda.is_available() else None),
        Case("round three: loading", "S14 load(device='cuda') without a GPU", "cuda", lambda: BC.load(
            saved(BC, "S14"), device="cuda") if not th.cuda.is_available() else None),
    ]

    # ---- data, observations, mid-training
    def npz_with_pickle():
        path = demo.save(workdir / "p.npz")
        return _rewrite(path, workdir / "N04.npz", lambda n, c: b"\x80\x04K\x01." if n == "actions.npy" else c)

    class Empty(gym.Env):
        observation_space, action_space = gym.spaces.Box(-1, 1, (0,)), gym.spaces.Discrete(2)

    class Images(gym.Env):
        observation_space = gym.spaces.Box(0, 255, (8, 8, 3), np.uint8)
        action_space = gym.spaces.Discrete(2)

        def reset(self, seed=None, options=None):
            super().reset(seed=seed)
            return self.observation_space.sample(), {}

        def step(self, action):
            return self.observation_space.sample(), 0.0, False, False, {}

    hwc = np.random.default_rng(0).integers(0, 256, size=(21, 8, 8, 3)).astype(np.uint8)

    def swap_mid_training():
        from stable_baselines3.common.callbacks import BaseCallback

        class Swap(BaseCallback):
            def _on_step(self):
                if self.n_calls == 2:
                    self.model.set_expert_data(load_demonstrations("CartPole-v1").sample(1, seed=3))
                return True

        MBIL("MlpPolicy", "CartPole-v1", expert_data=demo, **fast["mbil"]).learn(5, callback=Swap())

    def export_layout():
        import onnxruntime as ort

        from sb3_mbil import export_policy

        model = BC("MlpPolicy", Images(), expert_data=[(np.transpose(hwc, (0, 3, 1, 2)), np.zeros(20, int))]).learn(5)
        session = ort.InferenceSession(str(export_policy(model, workdir / "img.onnx")))
        onnx = session.run(None, {"observation": hwc.reshape(21, -1).astype(np.float32)})[0]
        return bool(np.array_equal(onnx, model.predict(hwc, deterministic=True)[0]))

    model = BC("MlpPolicy", "CartPole-v1", expert_data=demo)
    out += [
        Case("round three: data", "N04 npz member a raw pickle", "actions", lambda: load_demonstrations(npz_with_pickle())),
        Case("round three: data", "N16 load_demonstrations('/dev/null')", "regular", lambda: load_demonstrations("/dev/null")),
        Case("round three: data", "M02 to_minari with a Box(3,) observation space", "observations", lambda: demo.to_minari(
            "ns/fit-v0", observation_space=gym.spaces.Box(-1, 1, (3,)), action_space=gym.spaces.Discrete(2))),
        Case("round three: data", "E04 channels-last images", "channels first", lambda: BC(
            "MlpPolicy", Images(), expert_data=[(hwc, np.zeros(20, int))])),
        Case("round three: data", "E04b ONNX fed the env's (H, W, C) images", "", export_layout, behaviour=True),
        Case("round three: data", "E09 Box observation space of shape (0,)", "observation_space", lambda: BC("MlpPolicy", Empty())),
        Case("round three: data", "P04 predict on strings", "observation", lambda: model.predict(np.array(["a"] * 4))),
        Case("round three: data", "P05 predict on NaN", "observation", lambda: model.predict(
            np.array([0, np.nan, 0, 0], dtype=np.float32))),
        Case("round three: mid-training", "L06 set_expert_data from a callback during MBIL's learn", "expert_data",
             swap_mid_training),
    ]

    # ---- results files
    columns = ["algo", "seed", "settings"]

    def quoted_newline():
        path = workdir / "B03.csv"
        append_rows(path, [{"algo": "bc", "seed": 0, "settings": "a\nb"}], columns)
        append_rows(path, [{"algo": "bc", "seed": 1, "settings": "c"}], columns)
        return drop_incomplete_last_line(path) is None and len(read_result_rows(path)) == 2

    def nul_byte():
        path = workdir / "B04.csv"
        path.write_text("algo,seed\nbc,0\x00\nbc,1\n")
        return read_result_rows(path)

    def full_disk_append():
        from benchmarks.harness import results

        path = workdir / "B14.csv"
        append_rows(path, [{"algo": "bc", "seed": 0, "settings": ""}], columns)
        before, real = path.read_text(), results.os.fsync

        def full(fd):
            raise OSError(28, "No space left on device")

        results.os.fsync = full
        try:
            append_rows(path, [{"algo": "bc", "seed": i, "settings": ""} for i in range(1, 61)], columns)
        except OSError:
            pass
        finally:
            results.os.fsync = real
        return path.read_text() == before

    out += [
        Case("round three: results files", "B03 a field with a newline, then another append", "", quoted_newline,
             behaviour=True),
        Case("round three: results files", "B04 a NUL byte in a results CSV", "NUL", nul_byte),
        Case("round three: results files", "B14t a run's 60 rows appended onto a full disk", "", full_disk_append,
             behaviour=True),
    ]

    # ---- options of the command lines, run as a user would
    bench = ["-m", "benchmarks.run_grid", "--algos", "bc", "--envs", "CartPole-v1", "--n-trajectories", "1", "--seeds", "0",
             "--episodes", "2", "--local", "--csv", str(workdir / "opt.csv")]
    zoo = ["-m", "rl_zoo3.train", "--algo", "bc", "--env", "CartPole-v1", "-n", "5", "-f", str(workdir / "logs"),
           "--hyperparams"]
    out += [
        Case("round three: options", "B07 --overrides with a misspelt setting", "learnig_rate",
             lambda: _script(*bench, "--overrides", '{"bc": {"learnig_rate": 0.001}}')),
        Case("round three: options", "B08 --overrides '[1, 2]'", "object", lambda: _script(*bench, "--overrides", "[1, 2]")),
        Case("round three: options", "B15 run_curves --variants with a misspelt setting", "learnig_rate", lambda: _script(
            "-m", "benchmarks.run_curves", "--variants", '{"x": ["bc", {"learnig_rate": 1}]}', "--envs", "CartPole-v1",
            "--seeds", "0", "--updates", "10", "--csv", str(workdir / "c.csv"))),
        Case("round three: options", "B06r --csv in a folder that cannot exist", "--csv", lambda: _script(
            *bench[:-1], str(workdir / "B03.csv" / "r.csv"))),
        Case("round three: options", "Z01 rl_zoo3 policy_kwargs with a nested typo", "policy_kwargs",
             lambda: _script(*zoo, "policy_kwargs:'dict(net_arhc=[32])'")),
        Case("round three: options", "Z02 rl_zoo3 expert_seed:-1", "expert_seed", lambda: _script(*zoo, "expert_seed:-1")),
        Case("round three: options", "Z06 rl_zoo3 learning_rate:'lin_abc'", "learning_rate",
             lambda: _script(*zoo, "learning_rate:'lin_abc'")),
        Case("round three: options", "Z09 rl_zoo3 on-policy style net_arch", "net_arch",
             lambda: _script(*zoo, "policy_kwargs:'dict(net_arch=dict(pi=[32]))'")),
    ]
    return out


def demo_pool():
    from sb3_mbil import load_demonstrations

    return load_demonstrations("CartPole-v1")
