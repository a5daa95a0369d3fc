"""Train an RL Zoo expert locally with rl_zoo3's own command and shipped hyperparameters: resumable checkpoints,
the stop and acceptance rules of the expert table, late switches of settings, and carrying a training between
machines (export and import of its newest checkpoint)."""

from __future__ import annotations

import json
import logging
import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from stable_baselines3.common.vec_env import DummyVecEnv

from sb3_mbil.common.files import atomic_write
from sb3_mbil.experts.agents import Expert, _algo_class, cache_dir, load_expert_file


logger = logging.getLogger("sb3_mbil.experts")


def zoo_run_folder(env_id: str, algo: str, seed: int, n_timesteps: int | None = None) -> Path:
    """The cache folder of a local zoo training (a run with its own ``n_timesteps`` has its own folder)."""
    return cache_dir() / "zoo" / (f"{algo}-{env_id}-seed{seed}" + (f"-n{n_timesteps}" if n_timesteps is not None else ""))


def train_zoo_expert(env_id: str, algo: str, seed: int = 0, n_timesteps: int | None = None, n_evaluations: int = 20,
                     verbose: int = 1, save_freq: int | None = None, stop_at_return: float | None = None,
                     min_full_fraction: float = 0.0, stop_eval_episodes: int = 20,
                     max_timesteps: int | None = None,
                     late_hyperparams: tuple[tuple[int, dict[str, Any]], ...] = ()) -> Expert:
    """Train the RL Zoo agent locally with rl_zoo3's shipped hyperparameters; return its best checkpoint.

    Runs ``python -m rl_zoo3.train`` (one torch thread). A finished run of the same (algo, env,
    seed, n_timesteps) in the cache is reused.

    :param save_freq: checkpoint (model and replay buffer) every this many steps; an interrupted
        run is then continued from its last checkpoint with rl_zoo3's own continuation (``-i``)
        instead of starting again. Without it an interrupted run starts from scratch.
    :param stop_at_return: stop training once the deterministic mean return over 10 episodes (``stop_eval_episodes``
        with ``min_full_fraction``) reaches this value (checked every ``budget / n_evaluations`` steps); the zoo's step budget
        stays the upper bound.
    :param min_full_fraction: with ``stop_at_return``, stop only once this share of the ``stop_eval_episodes``
        evaluation episodes also runs to the time limit; the expert is then the final model of the newest run (the one training stopped on)
        instead of the zoo's best-return checkpoint.
    :param max_timesteps: the step budget of a cached run (``n_timesteps`` names a separate run instead); default
        the zoo's ``n_timesteps``
    :param late_hyperparams: ``((steps, {name: value}), ...)``: the runs that continue from ``steps`` on (a multiple
        of ``save_freq``) pass these hyperparameters to rl_zoo3 (``--hyperparams name:value``), with those of every
        earlier switch; a run that would cross a switch stops there, at a checkpoint, and the next one continues with
        the new settings. A switch at 0 sets them from the start; ``env_kwargs`` changes the training env only (the
        zoo's evaluations and the stop check run on the env as it is)
    :param stop_eval_episodes: evaluation episodes of that stop check (``get_expert`` passes its acceptance count, so
        that training stops only where acceptance would pass: 20 episodes all to the time limit once became 91% of 100)
    """
    folder = zoo_run_folder(env_id, algo, seed, n_timesteps)
    runs_dir = folder / algo
    progress_file = folder / "progress.json"
    for switch, _ in late_hyperparams:
        if not save_freq or switch % save_freq:
            raise ValueError(f"late_hyperparams: expected step counts that are multiples of save_freq ({save_freq}), "
                             f"found {switch}")
    while not _zoo_finished(runs_dir, env_id):
        budget = n_timesteps or max_timesteps or _zoo_budget(env_id, algo)
        eval_freq = max(budget // n_evaluations, 1)
        cmd = [
            sys.executable, "-m", "rl_zoo3.train", "--algo", algo, "--env", env_id, "--seed", str(seed),
            "-f", str(folder), "--num-threads", "1", "--vec-env", "dummy",
            "--eval-freq", str(eval_freq), "--eval-episodes", "20", "--n-eval-envs", "1",
        ]
        resume = _latest_checkpoint(runs_dir, env_id) if save_freq else None
        if resume is None and folder.exists():  # interrupted without a checkpoint: start again from scratch
            shutil.rmtree(folder)
        folder.mkdir(parents=True, exist_ok=True)
        progress = _read_progress(folder)
        done = 0
        if resume is not None:
            ckpt, steps = resume
            done = _steps_done(progress, ckpt, steps)
            _prepare_continuation(ckpt, env_id)
            cmd += ["-i", str(ckpt)]
        remaining = budget - done
        if remaining <= 0:
            break
        next_run = f"{env_id}_{_run_ids(runs_dir, env_id)[-1] + 1 if _run_ids(runs_dir, env_id) else 1}"
        late, stops_at_switch = {}, False
        for switch, values in sorted(late_hyperparams, key=lambda item: item[0]):
            if done >= switch:
                late.update(values)
            elif done + remaining > switch:  # stop at the switch (a checkpoint); the next run continues from there
                remaining, stops_at_switch = switch - done, True
                progress.setdefault("stopped_at_switch", []).append(next_run)  # its final model is not the end
                break
        if n_timesteps is not None or resume is not None or stops_at_switch:
            cmd += ["-n", str(remaining)]
        callbacks = []
        if save_freq:  # model, replay buffer and VecNormalize statistics, whole or absent, the newest two kept
            callbacks.append({"sb3_mbil.common.callbacks.ResumableCheckpoint": {
                "save_freq": int(save_freq), "save_path": str(runs_dir / next_run), "keep": 2}})
            cmd += ["--save-replay-buffer"]
        if stop_at_return is not None:
            stop = {"min_return": float(stop_at_return), "eval_freq": eval_freq}
            if min_full_fraction > 0:
                stop.update(min_full_fraction=float(min_full_fraction), n_eval_episodes=int(stop_eval_episodes))
            callbacks.append({"sb3_mbil.common.callbacks.StopTrainingOnReturn": stop})
        hyperparams = [f"callback:{callbacks!r}"] if callbacks else []
        if resume is not None and _off_policy(algo):
            if (resume[0].parent / "replay_buffer.pkl").exists():
                # rl_zoo3's -i restarts the step count, so the zoo's learning_starts would spend the
                # first steps of every continuation on random actions without gradient updates
                hyperparams.append("learning_starts:0")
            else:  # a carried checkpoint (import_zoo_checkpoint): the zoo's warm-up refills a fresh buffer first
                logger.warning("%s has no replay buffer: training continues on a fresh one, after the zoo's "
                               "learning_starts steps of random actions", resume[0])
        hyperparams += [f"{name}:{value!r}" for name, value in late.items()]
        if hyperparams:
            cmd += ["--hyperparams", *hyperparams]
        progress["steps_before"][next_run] = done
        _write_json(progress_file, progress)
        if verbose:
            logger.info("training the expert locally with rl_zoo3: %s", " ".join(cmd))
        returncode = _run_logged(cmd, folder.with_suffix(".log"), f"{algo} on {env_id}", done, budget, verbose)
        if returncode != 0:
            raise RuntimeError(f"rl_zoo3 training failed (exit {returncode}); see {folder.with_suffix('.log')}")
    if min_full_fraction > 0 and _run_ids(runs_dir, env_id):
        last = runs_dir / f"{env_id}_{_run_ids(runs_dir, env_id)[-1]}"
        if (last / f"{env_id}.zip").is_file():
            return load_expert_file(last / f"{env_id}.zip", env_id, algo, last / env_id / "vecnormalize.pkl",
                                    source=f"zoo:{algo} seed={seed} final")
    best = _best_run(runs_dir, env_id)
    if best is None:
        raise RuntimeError(f"rl_zoo3 training left no best_model.zip in {runs_dir}; see {folder.with_suffix('.log')}")
    return load_expert_file(best / "best_model.zip", env_id, algo, best / env_id / "vecnormalize.pkl",
                            source=f"zoo:{algo} seed={seed}")


def _run_logged(cmd: list[str], log_path: Path, what: str, done: int, budget: int, verbose: int) -> int:
    """Run ``cmd``, appending its output to ``log_path``; with ``verbose``, report each of rl_zoo3's evaluations
    (``Eval num_timesteps=..., episode_reward=...``) as progress, so minutes of training are not silent."""
    with open(log_path, "a") as log:
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, bufsize=1)
        assert proc.stdout is not None
        for line in proc.stdout:
            log.write(line)
            if verbose and line.startswith("Eval num_timesteps="):
                fields = dict(part.strip().split("=", 1) for part in line.strip().split(",") if "=" in part)
                steps = int(fields.get("Eval num_timesteps", 0)) + done
                logger.info("expert %s: %d / %d steps, evaluation return %s", what, steps, budget,
                            fields.get("episode_reward", "?"))
        return proc.wait()


def _off_policy(algo: str) -> bool:
    from rl_zoo3.utils import ALGOS
    from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm

    return algo in ALGOS and issubclass(ALGOS[algo], OffPolicyAlgorithm)


def _run_ids(runs_dir: Path, env_id: str) -> list[int]:
    ids = []
    for p in runs_dir.glob(f"{env_id}_*"):
        suffix = p.name[len(env_id) + 1:]
        if p.is_dir() and suffix.isdigit():
            ids.append(int(suffix))
    return sorted(ids)


def _zoo_finished(runs_dir: Path, env_id: str) -> bool:
    """The latest run saved its final model (budget used up, or stopped at the return threshold), acceptance
    did not refuse that model while budget remained (:func:`refuse_zoo_run`), and the run did not stop at a
    ``late_hyperparams`` switch."""
    ids = _run_ids(runs_dir, env_id)
    if not ids or not (runs_dir / f"{env_id}_{ids[-1]}" / f"{env_id}.zip").is_file():
        return False
    progress_file = runs_dir.parent / "progress.json"
    progress = json.loads(progress_file.read_text()) if progress_file.is_file() else {}
    return f"{env_id}_{ids[-1]}" not in progress.get("refused", []) + progress.get("stopped_at_switch", [])


def refuse_zoo_run(env_id: str, algo: str, seed: int, n_timesteps: int | None = None,
                   max_timesteps: int | None = None) -> bool:
    """Acceptance refused the final model of this cached zoo run: if the run stopped before its step budget and left a
    checkpoint with its replay buffer, mark it so that the next :func:`train_zoo_expert` continues it from there
    (rl_zoo3's ``-i``) instead of reusing the refused model, and return True. Otherwise (budget used up, or nothing
    to continue from) return False: the caller moves to another seed.

    A stop check on fewer episodes than acceptance (20 where acceptance runs 100) can pass on a model that acceptance
    then refuses; the remaining budget, not a new seed, is the cheap way on."""
    folder = zoo_run_folder(env_id, algo, seed, n_timesteps)
    runs_dir = folder / algo
    ids = _run_ids(runs_dir, env_id)
    resume = _latest_checkpoint(runs_dir, env_id)
    progress_file = folder / "progress.json"
    if not ids or resume is None or not progress_file.is_file():
        return False
    progress = json.loads(progress_file.read_text())
    done = _steps_done(progress, *resume)
    if done >= (n_timesteps or max_timesteps or _zoo_budget(env_id, algo)):
        return False
    progress.setdefault("refused", []).append(f"{env_id}_{ids[-1]}")
    _write_json(progress_file, progress)
    return True


def _latest_checkpoint(runs_dir: Path, env_id: str) -> tuple[Path, int] | None:
    for run_id in reversed(_run_ids(runs_dir, env_id)):
        run = runs_dir / f"{env_id}_{run_id}"
        # an off-policy run's checkpoint is usable only with its replay buffer (missing when a session
        # ended between the two files, or pruned)
        needs_buffer = any(run.glob("rl_model_replay_buffer_*_steps.pkl"))
        ckpts = []
        for p in run.glob("rl_model_*_steps.zip"):
            steps = _checkpoint_steps(p)
            if steps is not None and (not needs_buffer or (run / f"rl_model_replay_buffer_{steps}_steps.pkl").is_file()):
                ckpts.append((steps, p))
        if ckpts:
            steps, path = max(ckpts)
            return path, steps
    return None


def _checkpoint_steps(path: Path) -> int | None:
    """The step count in a checkpoint's name (``rl_model_<steps>_steps.zip``), or None."""
    middle = path.stem[len("rl_model_"):-len("_steps")] if path.stem.startswith("rl_model_") else ""
    return int(middle) if middle.isdigit() and path.stem.endswith("_steps") else None


def _read_progress(folder: Path) -> dict:
    """A zoo run folder's ``progress.json``: the steps done before each run of the cached training."""
    progress_file = folder / "progress.json"
    return json.loads(progress_file.read_text()) if progress_file.is_file() else {"steps_before": {}}


def _steps_done(progress: dict, ckpt: Path, steps: int) -> int:
    """Steps of the whole cached training at a checkpoint: those before its run plus its own."""
    return progress["steps_before"].get(ckpt.parent.name, 0) + steps


def export_zoo_checkpoint(env_id: str, algo: str, dest: str | os.PathLike, seed: int = 0,
                          n_timesteps: int | None = None) -> Path:
    """Copy the newest checkpoint of a cached zoo run to ``dest`` as ``rl_model_<steps done>_steps.zip``, with its
    VecNormalize statistics (``rl_model_vecnormalize_<steps>_steps.pkl``) when it has them, and remove older ones
    there: a file small enough to commit (Ant-v4's SAC: 3.4 MB; its replay buffer, about 500 MB, is left out) from
    which :func:`import_zoo_checkpoint` continues the training on a machine whose cache is empty."""
    folder = zoo_run_folder(env_id, algo, seed, n_timesteps)
    resume = _latest_checkpoint(folder / algo, env_id)
    if resume is None:
        raise ValueError(f"checkpoint: expected a checkpoint of the zoo run in {folder}, found none")
    ckpt, steps = resume
    done = _steps_done(_read_progress(folder), ckpt, steps)
    dest = Path(dest)
    dest.mkdir(parents=True, exist_ok=True)
    copies = [(ckpt, dest / f"rl_model_{done}_steps.zip")]
    vecnormalize = ckpt.parent / f"rl_model_vecnormalize_{steps}_steps.pkl"
    if vecnormalize.is_file():
        copies.append((vecnormalize, dest / f"rl_model_vecnormalize_{done}_steps.pkl"))
    for source, target in copies:
        with atomic_write(target) as tmp:
            shutil.copyfile(source, tmp)
    for old in dest.glob("rl_model_*_steps.*"):  # one carried checkpoint per run folder: the newest
        if old not in {target for _, target in copies}:
            old.unlink()
    return copies[0][1]


def refill_replay_buffer(checkpoint: str | os.PathLike, env_id: str, algo: str, n_steps: int, seed: int = 0):
    """A replay buffer of ``n_steps`` transitions collected by the checkpoint's own policy, acting as it does in
    training (SAC: sampling from its policy; DQN: epsilon-greedy at its saved exploration rate), with SB3's own
    ``collect_rollouts`` and no gradient update. A carried checkpoint continues on it instead of on the zoo's warm-up
    of random actions. Ant-v4's SAC carried at 675 000 steps (2 929 over 100 episodes) scored 366 and 281 at the zoo's
    evaluations 25 000 and 50 000 steps after a random warm-up, and 1 560 25 000 steps after this refill."""
    from stable_baselines3.common.type_aliases import TrainFreq, TrainFrequencyUnit

    if n_steps < 1:
        raise ValueError(f"n_steps: expected an integer >= 1, found {n_steps!r}")
    env = DummyVecEnv([lambda: gym.make(env_id)])
    env.seed(seed)
    model = _algo_class(algo).load(checkpoint, env=env, device="cpu")
    _, callback = model._setup_learn(n_steps, callback=None, reset_num_timesteps=True)
    callback.on_training_start(locals(), globals())
    model.collect_rollouts(model.get_env(), callback=callback, train_freq=TrainFreq(n_steps, TrainFrequencyUnit.STEP),
                           replay_buffer=model.replay_buffer, learning_starts=0)
    return model.replay_buffer


def import_zoo_checkpoint(env_id: str, algo: str, source: str | os.PathLike, seed: int = 0,
                          n_timesteps: int | None = None, refill_steps: int = 50_000) -> bool:
    """Make the newest checkpoint written by :func:`export_zoo_checkpoint` in ``source`` (a folder) the one the
    next :func:`train_zoo_expert` continues from, unless the cache already holds a run at least as far (or a finished
    one). An off-policy checkpoint gets a replay buffer of ``refill_steps`` transitions of its own policy
    (:func:`refill_replay_buffer`), and training continues on it at once. Returns whether it did."""
    carried = [(s, p) for p in Path(source).glob("rl_model_*_steps.zip") if (s := _checkpoint_steps(p)) is not None]
    if not carried:
        return False
    steps, path = max(carried)
    folder = zoo_run_folder(env_id, algo, seed, n_timesteps)
    runs_dir = folder / algo
    progress = _read_progress(folder)
    if _zoo_finished(runs_dir, env_id):
        return False
    resume = _latest_checkpoint(runs_dir, env_id)
    if resume is not None and _steps_done(progress, *resume) >= steps:
        return False
    ids = _run_ids(runs_dir, env_id)
    run = runs_dir / f"{env_id}_{ids[-1] + 1 if ids else 1}"
    run.mkdir(parents=True)
    vecnormalize = path.parent / f"rl_model_vecnormalize_{steps}_steps.pkl"
    if _off_policy(algo):
        if vecnormalize.is_file():
            raise ValueError(f"{source}: expected a checkpoint without VecNormalize statistics for an off-policy "
                             f"algorithm (its replay buffer is refilled on the raw env), found {vecnormalize.name}")
        from stable_baselines3.common.save_util import save_to_pkl

        logger.info("%s: refilling a replay buffer with %d steps of the checkpoint's policy", env_id, refill_steps)
        buffer = refill_replay_buffer(path, env_id, algo, refill_steps, seed=seed)
        with atomic_write(run / f"rl_model_replay_buffer_{steps}_steps.pkl") as tmp, open(tmp, "wb") as f:
            save_to_pkl(f, buffer)
    for carried_file in ([vecnormalize] if vecnormalize.is_file() else []) + [path]:  # the checkpoint last, whole or absent
        with atomic_write(run / carried_file.name) as tmp:
            shutil.copyfile(carried_file, tmp)
    progress["steps_before"][run.name] = 0
    _write_json(folder / "progress.json", progress)
    logger.info("%s: continuing from the carried checkpoint %s (%d steps done)", env_id, path, steps)
    return True


def _prepare_continuation(ckpt: Path, env_id: str) -> None:
    """Put the checkpoint's replay buffer and VecNormalize statistics where rl_zoo3's ``-i`` looks for them."""
    steps = ckpt.stem[len("rl_model_"):-len("_steps")]
    for source, target in (
        (ckpt.parent / f"rl_model_replay_buffer_{steps}_steps.pkl", ckpt.parent / "replay_buffer.pkl"),
        (ckpt.parent / f"rl_model_vecnormalize_{steps}_steps.pkl", ckpt.parent / env_id / "vecnormalize.pkl"),
    ):
        if source.is_file():
            target.parent.mkdir(parents=True, exist_ok=True)
            tmp = target.with_suffix(".tmp")
            if tmp.exists() or tmp.is_symlink():
                tmp.unlink()
            os.symlink(source.name if target.parent == source.parent else source, tmp)
            os.replace(tmp, target)


def _best_run(runs_dir: Path, env_id: str) -> Path | None:
    """The run whose EvalCallback saw the highest mean return (its best_model.zip is the expert)."""
    best, best_score = None, -np.inf
    for run_id in _run_ids(runs_dir, env_id):
        run = runs_dir / f"{env_id}_{run_id}"
        if not (run / "best_model.zip").is_file():
            continue
        score = -np.inf
        if (run / "evaluations.npz").is_file():
            with np.load(run / "evaluations.npz") as ev:
                if len(ev["results"]):
                    score = float(ev["results"].mean(axis=1).max())
        if best is None or score > best_score:
            best, best_score = run, score
    return best


def _write_json(path: Path, data: dict) -> None:
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(data, indent=1))
    os.replace(tmp, path)


def zoo_hyperparams(env_id: str, algo: str) -> dict[str, Any]:
    """rl_zoo3's shipped hyperparameters of ``algo`` on ``env_id`` (its ``hyperparams/<algo>.yml``, parsed)."""
    import rl_zoo3
    import yaml

    with open(Path(rl_zoo3.__file__).parent / "hyperparams" / f"{algo}.yml") as f:
        table = yaml.safe_load(f)
    if env_id not in table:
        raise ValueError(f"env: expected an env with RL Zoo hyperparameters for {algo}, found {env_id!r} (not in {algo}.yml)")
    return table[env_id]


def zoo_exploration_noise(env_id: str, algo: str) -> float:
    """The Gaussian exploration noise rl_zoo3 trains a deterministic actor (TD3, DDPG) with on ``env_id``, as a share
    of the action range (:func:`~sb3_mbil.experts.agents.noisy_actions`' level): SB3 adds N(0, noise_std) to the
    action scaled to [-1, 1] and clips it there, so the level is noise_std / 2."""
    params = zoo_hyperparams(env_id, algo)
    if params.get("noise_type") != "normal" or "noise_std" not in params:
        raise ValueError(f"noise_type: expected the RL Zoo's 'normal' exploration noise with a noise_std for {algo} on "
                         f"{env_id}, found {params.get('noise_type')!r}")
    return float(params["noise_std"]) / 2


def _zoo_budget(env_id: str, algo: str) -> int:
    return int(float(zoo_hyperparams(env_id, algo)["n_timesteps"]))
