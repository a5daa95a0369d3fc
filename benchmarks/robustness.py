"""Bad inputs and faults tried against the package, each classified as a clean error, an unclear one, or a
silent acceptance (``python -m benchmarks.robustness_report``).

* **clean**: a ``ValueError`` (or ``FileNotFoundError``, ``FloatingPointError``) whose message names the
  field it was given for;
* **unclear**: any other exception, or a message that does not name the field;
* **silent**: no error at all.
"""

from __future__ import annotations

import inspect
import os
import tempfile
from pathlib import Path

import numpy as np
from gymnasium.spaces import Box, Discrete

from benchmarks.robustness_cases import Case, round_three
from sb3_mbil.experts.controllers import native_demo, native_env

CLEAN_ERRORS = (ValueError, FileNotFoundError, FloatingPointError)


def _bad_values(default, annotation=""):
    if isinstance(default, str) and "int" in str(annotation):  # an integer or a word (e.g. flow_max_steps="auto")
        return ["no-such-choice", 0, 1.5]
    if isinstance(default, bool):
        return ["yes", 1.5]
    if isinstance(default, int):
        return ["abc", 1.5, -10**9]
    if isinstance(default, float):
        return ["fast", float("nan"), float("inf"), -1e9]
    if isinstance(default, str):
        return ["no-such-choice", 3]
    if isinstance(default, (tuple, list)):
        return [0.1, "ab", [-1.0]]
    return []


def cases(workdir: Path) -> list[Case]:

    from sb3_mbil import ALGORITHMS, BC, MBIL, Demonstrations, Trajectory, load_demonstrations
    from benchmarks.harness.grid import KEY_COLUMNS, RESULT_COLUMNS
    from benchmarks.harness.results import append_rows, finished_keys, read_result_rows

    demo = load_demonstrations("CartPole-v1").sample(1, seed=0)
    fast = {"mbil": dict(flow_max_steps=20, noise_grid=(0.1,), flow_hidden=(16,), flow_transforms=2),
            "mbil_c": dict(model_max_steps=20, model_hidden=(16,)),
            "edm": dict(sgld_steps=1, sgld_buffer_size=50), "dsfn": dict(warm_start_steps=5, dqn_steps=5, sf_steps=5)}
    out: list[Case] = []

    # constructor arguments of every algorithm
    skip = {"self", "policy", "env", "expert_data", "policy_kwargs", "tensorboard_log", "verbose", "device", "_init_setup_model"}
    for name, algo in ALGORITHMS.items():
        for arg, p in inspect.signature(algo.__init__).parameters.items():
            if arg in skip:
                continue
            for value in _bad_values(p.default, p.annotation) + (["abc", -1] if arg == "seed" else []):
                if arg == "log_density_floor" and isinstance(value, float) and np.isfinite(value):
                    continue
                out.append(Case("constructor argument", f"{name}({arg}={value!r})", arg,
                                lambda algo=algo, arg=arg, value=value: algo("MlpPolicy", native_env(algo), **{arg: value})))
        if Box not in algo.supported_action_spaces:
            out.append(Case("constructor argument", f"{name} on Pendulum-v1 (Box actions)", "action_space",
                            lambda algo=algo: algo("MlpPolicy", "Pendulum-v1")))
        if Discrete not in algo.supported_action_spaces:
            out.append(Case("constructor argument", f"{name} on CartPole-v1 (Discrete actions)", "action_space",
                            lambda algo=algo: algo("MlpPolicy", "CartPole-v1")))

    # learn arguments
    for value in (-5, 1.5, True, "10"):
        out.append(Case("learn argument", f"learn({value!r})", "total_timesteps",
                        lambda value=value: BC("MlpPolicy", "CartPole-v1", expert_data=demo).learn(value)))

    # non-finite training
    for name, algo in ALGORITHMS.items():
        native = native_demo(algo)[0]
        big = native.observations.copy()
        big[:50, 1] = 1e30
        out.append(Case("non-finite training", f"{name} on observations of 1e30", "observations",
                        lambda name=name, algo=algo, big=big, acts=native.actions: ALGORITHMS[name](
                            "MlpPolicy", native_env(algo), expert_data=[(big, acts)], **fast.get(name, {})).learn(20)))
    out.append(Case("non-finite training", "MBIL learning_rate=1e6", "balance_loss",
                    lambda: MBIL("MlpPolicy", "CartPole-v1", expert_data=demo, learning_rate=1e6, seed=0, **fast["mbil"]).learn(300)))

    # data
    def npz(**overrides):
        d = Demonstrations([Trajectory(np.zeros((4, 4), np.float32), np.zeros(3, np.int64))], {"env_id": "CartPole-v1"})
        path = d.save(workdir / f"d{len(out)}.npz")
        with np.load(path) as f:
            arrays = {k: f[k] for k in f.files}
        arrays.update(overrides)
        np.savez_compressed(path, **arrays)
        return path

    data_cases = [
        ("NaN observations", "observations", [(np.full((6, 4), np.nan), np.zeros(5, dtype=int))]),
        ("actions out of range", "actions", [(np.zeros((6, 4)), np.full(5, 7))]),
        ("float actions for Discrete", "actions", [(np.zeros((6, 4)), np.full(5, 0.5))]),
        ("observation rows do not match actions", "observations", [(np.zeros((9, 4)), np.zeros(5, dtype=int))]),
        ("wrong observation shape", "observations", [(np.zeros((6, 3)), np.zeros(5, dtype=int))]),
        ("observation outside the space", "observations", [(np.full((6, 4), 9.0), np.zeros(5, dtype=int))]),
        ("an empty list", "trajectory", []),
        ("a single array", "expert_data", np.zeros((6, 4))),
        ("a directory", "directory", str(workdir)),
        ("a missing file", "not found", str(workdir / "missing.npz")),
        ("an unknown pool name", "expert_data", "NoSuchPool"),
        ("metadata_json not JSON", "metadata_json", lambda: npz(metadata_json=np.array("{x"))),
        ("0-d n_observations", "n_observations", lambda: npz(n_observations=np.array(4))),
        ("float n_actions", "n_actions", lambda: npz(n_actions=np.array([3.0]))),
        ("episode_returns of the wrong length", "episode_returns", lambda: npz(episode_returns=np.zeros(3))),
        ("terminated as strings", "terminated", lambda: npz(terminated=np.array(["False"]))),
        ("a newer format_version", "format_version", lambda: npz(format_version=np.array(99))),
    ]
    for description, field, data in data_cases:
        out.append(Case("data", description, field,
                        lambda data=data: BC("MlpPolicy", "CartPole-v1", expert_data=data() if callable(data) else data)))

    # files and loading
    def saved(algo, name):
        path = workdir / f"{name}.zip"
        algo("MlpPolicy", "CartPole-v1", expert_data=demo, **fast.get(algo.__name__.lower(), {})).learn(2).save(path)
        return path

    def sb3_zip():
        from stable_baselines3 import PPO

        PPO("MlpPolicy", "CartPole-v1").save(workdir / "ppo.zip")
        return workdir / "ppo.zip"

    def truncated():
        path = saved(BC, "bc_cut")
        path.write_bytes(path.read_bytes()[:-300])
        return path

    out += [
        Case("loading", "BC.load on an MBIL zip", "MBIL", lambda: BC.load(saved(MBIL, "mbil"))),
        Case("loading", "MBIL.load on a BC zip", "BC", lambda: MBIL.load(saved(BC, "bc"))),
        Case("loading", "BC.load on an SB3 PPO zip", "another library", lambda: BC.load(sb3_zip())),
        Case("loading", "BC.load on a truncated zip", "unreadable", lambda: BC.load(truncated())),
        Case("loading", "load with NaN expert_data", "observations",
             lambda: BC.load(saved(BC, "bc2"), env="CartPole-v1", expert_data=[(np.full((6, 4), np.nan), np.zeros(5, int))])),
    ]

    # results CSV
    def grid_csv(cut: int):
        path = workdir / f"grid{len(out)}.csv"
        append_rows(path, [dict.fromkeys(RESULT_COLUMNS, "1") | {"seed": str(i)} for i in range(3)], RESULT_COLUMNS)
        path.write_bytes(path.read_bytes()[:-cut])
        return path

    def glued():
        path = workdir / "glued.csv"
        path.write_text("a,b\n1,2,3\n4,5\n")
        return path

    out += [
        Case("results CSV", "a report on a file whose last line is cut", "unterminated", lambda: read_result_rows(grid_csv(5))),
        Case("results CSV", "a report on a file with a glued row", "fields", lambda: read_result_rows(glued())),
        Case("results CSV", "resume on a cut last line (must drop it and redo the run)", "resumed",
             lambda: _resumes(finished_keys(grid_csv(5), KEY_COLUMNS))),
    ]
    out += round_three(workdir, demo, fast, saved)
    return out


def _resumes(keys) -> None:
    """A resume that dropped the cut row is the right behaviour: report it as a clean outcome."""
    if len(keys) == 2:
        raise ValueError("resumed: the cut last line was dropped and its run will be redone")
    raise AssertionError(f"resume kept {len(keys)} runs")


def run_cases() -> list[Case]:
    import warnings

    with tempfile.TemporaryDirectory() as d:
        all_cases = cases(Path(d))
        cwd = os.getcwd()
        os.chdir(d)
        try:
            for c in all_cases:
                try:
                    with warnings.catch_warnings(record=True) as caught:
                        warnings.simplefilter("always")
                        result = c.run()
                except CLEAN_ERRORS as e:
                    c.message = str(e).splitlines()[0][:200]
                    c.outcome = "clean" if c.field.lower() in str(e).lower() else "unclear"
                except Exception as e:  # noqa: BLE001 - classifying every failure is the point
                    c.message, c.outcome = f"{type(e).__name__}: {str(e).splitlines()[0][:180] if str(e) else ''}", "unclear"
                else:
                    named = [w for w in caught if c.field.lower() in str(w.message).lower()]
                    if c.behaviour:
                        c.outcome = "clean" if result is True else "silent"
                        c.message = "behaves correctly" if result is True else f"wrong result: {result!r}"[:200]
                    elif named:
                        c.outcome, c.message = "clean", f"warning: {str(named[0].message).splitlines()[0][:190]}"
                    else:
                        c.outcome = "silent"
        finally:
            os.chdir(cwd)
    return all_cases


def table(all_cases: list[Case]) -> str:
    kinds = list(dict.fromkeys(c.kind for c in all_cases))
    lines = ["| kind | cases | clean errors | unclear | silent |", "|---|---|---|---|---|"]
    for k in [*kinds, "all"]:
        cs = [c for c in all_cases if k in ("all", c.kind)]
        n = {o: sum(c.outcome == o for c in cs) for o in ("clean", "unclear", "silent")}
        lines.append(f"| {k} | {len(cs)} | {n['clean']} | {n['unclear']} | {n['silent']} |")
    rest = [c for c in all_cases if c.outcome != "clean"]
    if rest:
        lines += ["", "Not clean:", ""] + [f"- {c.kind}: {c.description}: {c.outcome} ({c.message})" for c in rest]
    return "\n".join(lines)
