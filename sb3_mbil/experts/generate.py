"""Expert agents from the RL Zoo and expert demonstrations generated with them.

Sources of an expert:

* ``"hub"``: the RL Zoo's pretrained agent ``sb3/<algo>-<env>`` on the Hugging Face Hub, through
  ``huggingface_sb3``; a copy already in the local hub cache is used without the network. When the
  hub cannot be reached (checked in about a second), one log line says so and the local zoo
  training below is used instead.
* ``"zoo"``: train the same agent locally with rl_zoo3's own shipped hyperparameters, through
  rl_zoo3's own training command (one torch thread), keeping the best checkpoint of its
  ``EvalCallback``. Runs are cached by (algo, env, seed), so a second call reuses them.
* a path to a saved SB3 model (``.zip``), with ``--algo``.

An expert is accepted only when its mean return over ``n_eval_episodes`` reaches the env's
threshold; a zoo-trained expert below it is retrained with the next seed.
"""

from __future__ import annotations

import json
import logging
import os
import shutil
import socket
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.utils import check_for_correct_spaces
from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

from sb3_mbil.common.demonstrations import Demonstrations, Trajectory
from sb3_mbil.common.files import atomic_write
from sb3_mbil.experts.specs import EXPERTS, OTHER_SPECS, SECOND_EXPERTS, ExpertSpec, expert_spec  # noqa: F401
from sb3_mbil.version import __version__

logger = logging.getLogger("sb3_mbil.experts")

HUB_HOST = "huggingface.co"




def cache_dir() -> Path:
    return Path(os.environ.get("SB3_MBIL_CACHE", Path.home() / ".cache" / "sb3_mbil"))


@dataclass
class Expert:
    """A trained agent that acts on raw observations (through its VecNormalize statistics if any)."""

    model: BaseAlgorithm
    env_id: str
    algo: str
    source: str
    vec_normalize: VecNormalize | None = None
    #: act with the policy's mode (True) or sample from it (False: a stochastic expert whose
    #: log pi_D(a' | s') is finite, as the Markov balance equation assumes)
    deterministic: bool = True
    #: noise on the action the expert takes (executed and recorded), see :func:`noisy_actions`; 0 is none
    action_noise: float = 0.0
    #: the generator of that noise (seeded by :func:`generate_demonstrations`)
    noise_rng: np.random.Generator | None = None

    def act(self, observations: np.ndarray) -> np.ndarray:
        obs = np.asarray(observations)
        if self.vec_normalize is not None:
            obs = self.vec_normalize.normalize_obs(obs)
        actions, _ = self.model.predict(obs, deterministic=self.deterministic)
        if self.action_noise:
            if self.noise_rng is None:
                self.noise_rng = np.random.default_rng(0)
            actions = noisy_actions(actions, self.model.action_space, self.action_noise, self.noise_rng)
        return actions


#: RL Zoo algorithms whose policy is greedy in a Q function (sampled with epsilon-greedy, see generate_demonstrations)
VALUE_BASED = ("dqn", "qrdqn")


def algo_of(expert: Expert) -> str:
    return expert.algo.lower()


def noisy_actions(actions: np.ndarray, action_space: gym.spaces.Space, level: float,
                  rng: np.random.Generator) -> np.ndarray:
    """A noisy demonstrator's actions: the expert's ``actions`` (one per row) with noise at ``level``.

    * ``Discrete``: epsilon-greedy with epsilon = ``level``: with probability ``level`` the action is replaced by one
      drawn uniformly from all actions (the expert's own included), so pi_D(a | s) = (1 - level) [a = a*(s)] + level / n.
    * ``Box``: Gaussian noise with a standard deviation of ``level`` times the action range (high - low) in each
      dimension, then clipped to the box: a' = clip(a*(s) + level (high - low) eps, low, high), eps ~ N(0, I).
    """
    if not isinstance(level, (int, float)) or isinstance(level, bool) or not np.isfinite(level) or not 0 <= level <= 1:
        raise ValueError(f"action_noise: expected a number in [0, 1], found {level!r}")
    actions = np.asarray(actions)
    if isinstance(action_space, gym.spaces.Discrete):
        flip = rng.random(actions.shape) < level
        uniform = action_space.start + rng.integers(0, action_space.n, size=actions.shape)
        return np.where(flip, uniform, actions).astype(actions.dtype)
    if isinstance(action_space, gym.spaces.Box):
        scale = level * (action_space.high - action_space.low)
        noisy = actions + scale * rng.standard_normal(actions.shape)
        return np.clip(noisy, action_space.low, action_space.high).astype(actions.dtype)
    raise ValueError(f"action_noise: expected a Discrete or Box action space, found {action_space}")


# ---------------------------------------------------------------------- loading
def _algo_class(algo: str) -> type[BaseAlgorithm]:
    from rl_zoo3.utils import ALGOS

    if algo not in ALGOS:
        raise ValueError(f"algo: expected one of the RL Zoo's algorithms {sorted(ALGOS)}, found {algo!r}")
    return ALGOS[algo]


def load_expert_file(path: str | os.PathLike, env_id: str, algo: str, vec_normalize_path: str | os.PathLike | None = None,
                     source: str | None = None) -> Expert:
    """Load a saved SB3 model as the expert of ``env_id``; clear errors for a corrupt file or a wrong env."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"expert model file not found: {path}")
    env = gym.make(env_id)
    try:
        model = _algo_class(algo).load(path, device="cpu")
    except Exception as e:
        raise ValueError(f"{path}: expected a saved {algo.upper()} model (.zip), found a file SB3 cannot load ({e!r})") from e
    try:
        check_for_correct_spaces(env, model.observation_space, model.action_space)
    except ValueError as e:
        raise ValueError(
            f"{path}: expected a model for {env_id} (observation space {env.observation_space}, action space "
            f"{env.action_space}), found one for observation space {model.observation_space}, action space "
            f"{model.action_space}"
        ) from e
    vec_norm = None
    if vec_normalize_path is not None and Path(vec_normalize_path).is_file():
        vec_norm = VecNormalize.load(str(vec_normalize_path), DummyVecEnv([lambda: gym.make(env_id)]))
        vec_norm.training = False
        vec_norm.norm_reward = False
    return Expert(model, env_id, algo, source or f"file:{path}", vec_norm)


def hub_reachable(timeout: float = 1.5) -> bool:
    """Is the Hugging Face Hub reachable? Answers in about ``timeout`` seconds, not after 20 s of retries."""
    if os.environ.get("HF_HUB_OFFLINE", "0").lower() in ("1", "true", "yes", "on"):
        return False
    try:
        # resolve and connect with a deadline (getaddrinfo has none of its own: run it in a thread)
        import concurrent.futures

        with concurrent.futures.ThreadPoolExecutor(1) as pool:
            infos = pool.submit(socket.getaddrinfo, HUB_HOST, 443, 0, socket.SOCK_STREAM).result(timeout=timeout)
        with socket.create_connection(infos[0][4][:2], timeout=timeout):
            return True
    except Exception:
        return False


#: the Hugging Face organisation of the RL Zoo's own agents: the one whose models are unpickled without asking
RL_ZOO_ORG = "sb3"


def load_hub_expert(env_id: str, algo: str, org: str = RL_ZOO_ORG, online: bool | None = None,
                    trust_remote_code: bool | None = None) -> Expert:
    """The RL Zoo agent ``{org}/{algo}-{env_id}`` from the Hugging Face Hub (or its local cache).

    An SB3 model zip can hold cloudpickled objects, and unpickling runs code. ``huggingface_sb3`` refuses to load one
    unless ``TRUST_REMOTE_CODE`` is set; we set it around the load for the RL Zoo's own organisation
    (:data:`RL_ZOO_ORG`) only, unless ``trust_remote_code`` says otherwise. Another organisation's agent is loaded
    only with ``trust_remote_code=True``.

    Raises ``LookupError`` when it is neither reachable nor cached.
    """
    if trust_remote_code is None:
        trust_remote_code = org == RL_ZOO_ORG
    if not isinstance(trust_remote_code, bool):
        raise ValueError(f"trust_remote_code: expected True, False or None, found {trust_remote_code!r}")
    from huggingface_hub import hf_hub_download
    from huggingface_sb3 import ModelName, ModelRepoId, load_from_hub

    model_name = ModelName(algo, env_id)
    repo_id = str(ModelRepoId(org, model_name))
    offline_flag = os.environ.get("HF_HUB_OFFLINE", "0").lower() in ("1", "true", "yes", "on")
    online = hub_reachable() if online is None else online
    try:
        if online or offline_flag:
            # huggingface_sb3 reads the hub, or with HF_HUB_OFFLINE=1 the local hub cache. It refuses to
            # unpickle a model unless TRUST_REMOTE_CODE is set: these are the RL Zoo's own agents.
            previous = os.environ.get("TRUST_REMOTE_CODE")
            if trust_remote_code:
                os.environ["TRUST_REMOTE_CODE"] = "True"
            else:
                os.environ.pop("TRUST_REMOTE_CODE", None)
            try:
                model_path = load_from_hub(repo_id, model_name.filename)
            finally:
                if previous is None:
                    os.environ.pop("TRUST_REMOTE_CODE", None)
                else:
                    os.environ["TRUST_REMOTE_CODE"] = previous
        else:  # unreachable without the flag: read the cache without waiting for the network
            model_path = hf_hub_download(repo_id, model_name.filename, local_files_only=True)
    except Exception as e:
        raise LookupError(f"{repo_id} is not reachable on the Hugging Face Hub nor in its local cache ({type(e).__name__})") from e
    vec_norm_path = None
    try:
        vec_norm_path = hf_hub_download(repo_id, "vec_normalize.pkl", local_files_only=not online)
    except Exception:
        pass  # agents trained without VecNormalize have none
    return load_expert_file(model_path, env_id, algo, vec_norm_path, source=f"hub:{repo_id}")


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


def _zoo_budget(env_id: str, algo: str) -> int:
    import rl_zoo3
    import yaml

    with open(Path(rl_zoo3.__file__).parent / "hyperparams" / f"{algo}.yml") as f:
        table = yaml.safe_load(f)
    if env_id not in table:
        raise ValueError(f"env: expected an env with RL Zoo hyperparameters for {algo}, found {env_id!r} (not in {algo}.yml)")
    return int(float(table[env_id]["n_timesteps"]))


# ---------------------------------------------------------------------- rollouts
def rollout(expert: Expert, n_episodes: int, seed: int, n_envs: int = 16, progress: bool = False,
            env_kwargs: dict[str, Any] | None = None) -> Demonstrations:
    """Run the expert for ``n_episodes`` (episode i reset with seed + i); raw observations are stored."""
    envs = [gym.make(expert.env_id, **(env_kwargs or {})) for _ in range(min(n_envs, n_episodes))]
    results: dict[int, Trajectory] = {}
    state: list[dict | None] = [None] * len(envs)
    next_ep = 0
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=n_episodes, desc=f"{expert.env_id} episodes", unit="ep")

    def start(k: int) -> None:
        nonlocal next_ep
        if next_ep >= n_episodes:
            state[k] = None
            return
        obs, _ = envs[k].reset(seed=seed + next_ep)
        state[k] = {"ep": next_ep, "obs": [obs], "act": [], "ret": 0.0}
        next_ep += 1

    for k in range(len(envs)):
        start(k)
    while any(s is not None for s in state):
        live = [k for k, s in enumerate(state) if s is not None]
        actions = expert.act(np.stack([state[k]["obs"][-1] for k in live]))
        for k, action in zip(live, actions):
            s = state[k]
            obs, reward, terminated, truncated, _ = envs[k].step(action)
            s["obs"].append(obs)
            s["act"].append(action)
            s["ret"] += float(reward)
            if terminated or truncated:
                results[s["ep"]] = Trajectory(
                    np.array(s["obs"]), np.array(s["act"]), terminated=terminated, truncated=truncated, episode_return=s["ret"]
                )
                if bar is not None:
                    bar.update(1)
                start(k)
    if bar is not None:
        bar.close()
    return Demonstrations([results[i] for i in range(n_episodes)], {"env_id": expert.env_id})


def evaluate_expert(expert: Expert, n_episodes: int = 100, seed: int = 10**6) -> tuple[float, float, float]:
    """Mean and std of the expert's return over ``n_episodes`` (seeds apart from the pool's), and the share of the
    episodes that ran to the time limit (cut by it, not ended in a terminal state)."""
    episodes = rollout(expert, n_episodes, seed)
    returns = episodes.episode_returns
    full = np.mean([t.truncated and not t.terminated for t in episodes])
    return float(returns.mean()), float(returns.std()), float(full)


def get_expert(env_id: str, source: str = "hub", algo: str | None = None, seed: int = 0, min_return: float | None = None,
               n_eval_episodes: int = 100, max_attempts: int = 5, n_timesteps: int | None = None,
               min_full_fraction: float | None = None) -> tuple[Expert, dict]:
    """An accepted expert for ``env_id`` from ``source`` (``"hub"``, ``"zoo"`` or a model path).

    Returns the expert and an evaluation record. Raises ``ValueError`` when no expert reaches the
    return threshold, or runs the required share of its episodes to the time limit (``min_full_fraction``, by
    default the env's :class:`ExpertSpec`): a weak expert is never used silently.
    """
    first = EXPERTS.get(env_id)
    algo = algo or (first.algo if first else None)
    if algo is None:
        raise ValueError(f"algo: expected the RL Zoo algorithm of the expert for {env_id!r} (no default), found None")
    spec = expert_spec(env_id, algo)
    threshold = min_return if min_return is not None else (first.min_return if first else None)
    if threshold is None:
        logger.warning("no return threshold for %s: the expert is accepted whatever it scores (pass min_return)", env_id)
    zoo_kwargs = {"save_freq": spec.save_freq, "stop_at_return": spec.stop_at_return,
                  "n_evaluations": spec.n_evaluations, "min_full_fraction": spec.min_full_fraction,
                  "stop_eval_episodes": n_eval_episodes, "max_timesteps": spec.max_timesteps,
                  "late_hyperparams": spec.late_hyperparams} \
        if spec else {}
    min_full = min_full_fraction if min_full_fraction is not None else (spec.min_full_fraction if spec else 0.0)
    attempts = []
    attempt_seed = seed
    for _ in range(max_attempts):
        if source == "hub":
            try:
                expert = load_hub_expert(env_id, algo)
            except LookupError as e:
                logger.warning("Hugging Face Hub unavailable (%s): training the expert locally with rl_zoo3 instead", e)
                source = "zoo"
                expert = train_zoo_expert(env_id, algo, attempt_seed, n_timesteps, **zoo_kwargs)
        elif source == "zoo":
            expert = train_zoo_expert(env_id, algo, attempt_seed, n_timesteps, **zoo_kwargs)
        else:
            expert = load_expert_file(source, env_id, algo, Path(source).parent / env_id / "vecnormalize.pkl")
        t0 = time.time()
        mean, std, full = evaluate_expert(expert, n_eval_episodes)
        record = {"source": expert.source, "algo": algo, "seed": attempt_seed, "eval_mean_return": mean,
                  "eval_std_return": std, "eval_full_fraction": full, "eval_episodes": n_eval_episodes,
                  "min_return": threshold, "min_full_fraction": min_full, "eval_seconds": round(time.time() - t0, 1)}
        attempts.append(record)
        logger.info("expert %s: mean return %.1f +- %.1f over %d episodes, %.0f%% to the time limit (threshold %s, %.0f%%)",
                    expert.source, mean, std, n_eval_episodes, 100 * full, threshold, 100 * min_full)
        if (threshold is None or mean >= threshold) and full >= min_full:
            record["attempts"] = attempts[:-1]
            return expert, record
        if source != "zoo":
            break
        # a run that stopped early (its stop check passed) continues on its remaining budget; otherwise the next seed
        if not refuse_zoo_run(env_id, algo, attempt_seed, n_timesteps, zoo_kwargs.get("max_timesteps")):
            attempt_seed += 1
    raise ValueError(
        f"expert for {env_id}: expected a mean return >= {threshold} over {n_eval_episodes} episodes"
        + (f" with {min_full:.0%} of them to the time limit" if min_full else "")
        + f", found {json.dumps([(a['source'], round(a['eval_mean_return'], 1), a['eval_full_fraction']) for a in attempts])}"
    )


def generate_demonstrations(env_id: str, n_trajectories: int, source: str = "hub", seed: int = 0, out: str | os.PathLike | None = None,
                            algo: str | None = None, min_return: float | None = None, n_eval_episodes: int = 100,
                            progress: bool = True, command: str | None = None,
                            sampled_actions: bool = False, action_noise: float = 0.0,
                            dqn_epsilon: float = 0.05) -> tuple[Demonstrations, Path | None]:
    """Get an accepted expert, roll it out ``n_trajectories`` times (episode i seeded ``seed + i``), save atomically.

    :param sampled_actions: record actions sampled from the expert's policy (torch seeded with
        ``seed``) instead of its deterministic actions; the acceptance test stays deterministic.
    :param dqn_epsilon: with ``sampled_actions``, a value-based expert (DQN, QR-DQN), whose policy is greedy, samples
        epsilon-greedily at this epsilon (uniform over all actions, seeded with ``seed``, independently per episode),
        a setting whose return stays within 10% of the greedy one for the shipped DQN experts (docs/experts.md).
        SB3's own ``predict(deterministic=False)`` is not used for them: it draws one coin for the whole batch of
        envs from numpy's unseeded global generator, at the exploration rate the checkpoint happened to be saved with
    :param action_noise: a noisy demonstrator: the expert's deterministic action with noise at this level, executed
        and recorded (:func:`noisy_actions`; epsilon for Discrete actions, a share of the action range for Box);
        the noise generator is seeded with ``seed``
    """
    if not isinstance(n_trajectories, int) or n_trajectories < 1:
        raise ValueError(f"n_trajectories: expected a positive integer, found {n_trajectories!r}")
    noisy_actions(np.zeros(1), gym.spaces.Box(-1, 1, (1,)), action_noise, np.random.default_rng(0))  # checks the level
    if sampled_actions and action_noise:
        raise ValueError("action_noise: expected 0 with sampled_actions (noise goes on the deterministic action), "
                         f"found {action_noise!r}")
    expert, record = get_expert(env_id, source, algo, seed, min_return, n_eval_episodes)
    sampling = None
    if sampled_actions and algo_of(expert) in VALUE_BASED:
        action_noise, sampling = dqn_epsilon, f"epsilon-greedy over Q, epsilon={dqn_epsilon:g}"
        noisy_actions(np.zeros(1), gym.spaces.Box(-1, 1, (1,)), action_noise, np.random.default_rng(0))
    elif sampled_actions:
        import torch as th

        th.manual_seed(seed)
        expert.deterministic = False
        sampling = "the policy's own distribution"
    if action_noise:
        expert.action_noise = float(action_noise)
        expert.noise_rng = np.random.default_rng(seed)
    demos = rollout(expert, n_trajectories, seed, progress=progress)
    returns, lengths = demos.episode_returns, demos.episode_lengths
    import gymnasium
    import stable_baselines3

    demos.metadata.update({
        "env_id": env_id,
        "expert": record,
        "seed": seed,
        "n_trajectories": n_trajectories,
        "mean_return": float(returns.mean()),
        "std_return": float(returns.std()),
        "mean_length": float(lengths.mean()),
        "expert_actions": "sampled" if sampled_actions else ("noisy" if action_noise else "deterministic"),
        "action_noise": 0.0 if sampled_actions else float(action_noise),
        **({"sampling": sampling} if sampling else {}),
        "command": command,
        "versions": {"sb3_mbil": __version__, "gymnasium": gymnasium.__version__, "stable_baselines3": stable_baselines3.__version__},
        "created": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    })
    path = demos.save(out) if out is not None else None
    return demos, path
