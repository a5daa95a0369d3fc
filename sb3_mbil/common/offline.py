"""Base class for strictly batch (offline) imitation algorithms.

The learner never steps the environment: the env gives the spaces and is used
for evaluation only. One gradient step is one timestep and one
``callback.on_step()``, so the progress bar, ``EvalCallback`` and
``CheckpointCallback`` work unchanged and count gradient steps.

Over 400 lines on purpose: the base class is one contract (SB3's own ``base_class.py`` is longer): building from
hyperparameters, the learn loop and its finite checks, the training random stream, and save/load with its checks
are read together when an algorithm is added.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import sys
import time
import warnings
import zipfile
from pathlib import Path
from typing import Any, ClassVar, TypeVar

import gymnasium as gym
import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.policies import BasePolicy
from stable_baselines3.common.type_aliases import GymEnv, MaybeCallback, Schedule

from sb3_mbil.common.demonstrations import Demonstrations, ExpertData, as_demonstrations
from sb3_mbil.common.files import atomic_write
from sb3_mbil.common.losses import bc_loss
from sb3_mbil.common.policies import ImitationPolicy, MlpPolicy
from sb3_mbil.common.safe_load import (add_description, check_members, check_version, safe_custom_objects,
                                      warn_unknown_entries)
from sb3_mbil.common.threads import training_cpu
from sb3_mbil.common.type_aliases import PairSamples, Samples, TransitionSamples, TupleSamples, take
from sb3_mbil.common.validation import (CheckedSchedule, check_int, check_learning_rate, check_policy_kwargs,
                                       check_real, check_seed)

SelfOffline = TypeVar("SelfOffline", bound="OfflineAlgorithm")


#: gradient steps between the checks that the recorded losses and the parameters are finite (each check waits for
#: the device once, instead of once per step); a non-finite value names its term and the step it first appeared at
FINITE_CHECK_EVERY = 100


def warn_if_no_device(device: th.device | str) -> None:
    """SB3 falls back to the CPU without a word when CUDA is asked for and absent: say so."""
    if str(device).startswith("cuda") and not th.cuda.is_available():
        warnings.warn(f"device: {device!r} asked for, but torch sees no CUDA device: running on the CPU", stacklevel=3)


def encode_numpy_state(state: tuple) -> th.Tensor:
    """numpy's legacy global state (MT19937) as one int64 tensor: 624 keys, position, has_gauss, cached gaussian's
    bits (a tensor, so that it is saved with the model's torch variables and loaded with ``weights_only``)."""
    name, keys, pos, has_gauss, cached = state
    if name != "MT19937":
        raise ValueError(f"numpy random state: expected MT19937, found {name!r}")
    tail = np.array([pos, has_gauss], dtype=np.int64)
    return th.from_numpy(np.concatenate([keys.astype(np.int64), tail, np.array([cached]).view(np.int64)]))


def decode_numpy_state(encoded: th.Tensor) -> tuple:
    values = encoded.cpu().numpy().astype(np.int64)
    if values.shape != (627,):
        raise ValueError(f"_rng_numpy: expected 627 entries (numpy's MT19937 state), found shape {values.shape}")
    return ("MT19937", values[:624].astype(np.uint32), int(values[624]), int(values[625]),
            float(values[626:627].view(np.float64)[0]))


def check_spaces(observation_space: spaces.Space, action_space: spaces.Space,
                 supported: tuple[type[spaces.Space], ...] = (spaces.Discrete, spaces.Box), algo: str = "") -> None:
    """Refuse, with a clear message, spaces the offline algorithms (or this one: ``supported``) do not support."""
    if not isinstance(observation_space, spaces.Box):
        raise ValueError(f"observation_space: expected a gymnasium Box, found {observation_space}")
    if int(np.prod(observation_space.shape)) == 0:
        raise ValueError(f"observation_space: expected at least one observation dimension, found shape "
                         f"{observation_space.shape}")
    if not isinstance(action_space, (spaces.Discrete, spaces.Box)):
        raise ValueError(f"action_space: expected Discrete or Box, found {action_space}")
    if not isinstance(action_space, supported):
        names = " or ".join(s.__name__ for s in supported)
        raise ValueError(f"action_space: expected {names} ({algo} supports {names} actions only), found {action_space}")
    if isinstance(action_space, spaces.Discrete):
        if int(action_space.start) != 0:
            raise ValueError(f"action_space: expected Discrete with start=0, found start={action_space.start}")
    elif not np.all(np.isfinite(action_space.low)) or not np.all(np.isfinite(action_space.high)):
        raise ValueError(f"action_space: expected finite Box bounds, found {action_space}")


class OfflineAlgorithm(BaseAlgorithm):
    """An SB3 algorithm that learns from expert data only.

    The base builds what every algorithm has (SB3's ``OffPolicyAlgorithm._setup_model`` pattern): the
    checked hyperparameters, the learning-rate schedule, the seeding and the policy with its Adam
    optimiser (``weight_decay`` as Adam's L2 term). An algorithm adds its own networks in its
    ``_setup_model`` after ``super()._setup_model()``, names them in ``_get_torch_save_params``, and
    writes one gradient step in ``_train_step``.

    :param policy: policy class or alias (``"MlpPolicy"``)
    :param env: the env (or its id); used for its spaces and for evaluation only
    :param expert_data: :class:`~sb3_mbil.Demonstrations`, a path to a ``.npz``, a shipped pool name
        or a list of ``(observations, actions)`` pairs, one per trajectory. Not saved with the model.
    :param learning_rate: policy learning rate (constant or schedule of the remaining progress)
    :param batch_size: minibatch size of one gradient step
    :param weight_decay: Adam weight decay (L2) of the policy
    :param policy_kwargs: keyword arguments of the policy
    :param tensorboard_log: tensorboard log folder (None: no tensorboard)
    :param verbose: 0 silent, 1 info, 2 debug
    :param seed: random seed
    :param device: torch device
    :param _init_setup_model: build the networks at construction
    """

    policy_aliases: ClassVar[dict[str, type[BasePolicy]]] = {"MlpPolicy": MlpPolicy}
    supported_action_spaces: ClassVar[tuple[type[spaces.Space], ...]] = (spaces.Discrete, spaces.Box)
    #: the algorithm's own policy defaults (e.g. a reference code's activation), under the user's policy_kwargs
    default_policy_kwargs: ClassVar[dict[str, Any]] = {}
    policy: ImitationPolicy

    def __init__(
        self,
        policy: str | type[BasePolicy],
        env: GymEnv | str | None,
        expert_data: ExpertData | None = None,
        learning_rate: float | Schedule = 1e-3,
        batch_size: int = 64,
        weight_decay: float = 0.0,
        policy_kwargs: dict[str, Any] | None = None,
        tensorboard_log: str | None = None,
        verbose: int = 0,
        seed: int | None = None,
        device: th.device | str = "auto",
        _init_setup_model: bool = True,
    ):
        if hasattr(env, "observation_space") and hasattr(env, "action_space"):
            self._check_spaces(env.observation_space, env.action_space)  # before SB3's own checks
        warn_if_no_device(device)
        super().__init__(
            policy=policy,
            env=env,
            learning_rate=learning_rate,
            policy_kwargs=policy_kwargs,
            tensorboard_log=tensorboard_log,
            verbose=verbose,
            device=device,
            support_multi_env=True,
            seed=seed,
        )
        if env is not None:
            self._check_spaces(self.observation_space, self.action_space)
        elif _init_setup_model:
            raise ValueError("env: expected a gymnasium env or env id (needed for the spaces), found None")
        self.algorithm = type(self).__name__  # saved in the zip: load checks it
        self.expert_data = expert_data
        self.batch_size = batch_size
        self.weight_decay = weight_decay
        self._demonstrations: Demonstrations | None = None
        #: where the expert data came from (pool, number of trajectories, the seed of the draw); saved in the zip
        self.expert_info: dict[str, Any] | None = None
        self._on_new_data()
        if expert_data is not None and env is not None:
            self.demonstrations()  # bad data is refused when it is given, not at the first learn

    @classmethod
    def _check_spaces(cls, observation_space: spaces.Space, action_space: spaces.Space) -> None:
        check_spaces(observation_space, action_space, cls.supported_action_spaces, cls.__name__)

    # ------------------------------------------------------------------ setup
    def _check_hyperparameters(self) -> None:
        """Check (and canonicalise) the constructor arguments; extend with ``super()._check_hyperparameters()``."""
        self.learning_rate = check_learning_rate("learning_rate", self.learning_rate)
        self.batch_size = check_int("batch_size", self.batch_size, low=1)
        self.weight_decay = check_real("weight_decay", self.weight_decay, low=0.0)
        self.seed = check_seed("seed", self.seed)
        self.policy_kwargs = check_policy_kwargs(self.policy_class, self.policy_kwargs)

    def _setup_lr_schedule(self) -> None:
        # every value the schedule returns is checked where it is used (NaN or a string would reach torch or SB3)
        self.lr_schedule = CheckedSchedule("learning_rate", self.learning_rate)
        self.lr_schedule(1.0)

    def _setup_model(self) -> None:
        """Build from the hyperparameters alone (``load`` calls it before restoring the state dicts)."""
        self._check_hyperparameters()
        self._setup_lr_schedule()
        self.set_random_seed(self.seed)
        kwargs = {**self.default_policy_kwargs, **self.policy_kwargs}
        kwargs["optimizer_kwargs"] = {**kwargs.get("optimizer_kwargs", {}), "weight_decay": self.weight_decay}
        self.policy = self.policy_class(self.observation_space, self.action_space, self.lr_schedule, **kwargs).to(self.device)
        self._on_new_data()
        # the training stream: empty until the first learn, which starts it from the global generators as they are
        # then (the seed's state, after every network of the algorithm is initialised)
        self._rng_torch = th.empty(0, dtype=th.uint8)
        self._rng_numpy = th.empty(0, dtype=th.int64)

    def _get_torch_save_params(self) -> tuple[list[str], list[str]]:
        # The optimiser is saved too, and the random state of training: training continued after load is training
        # continued in memory, bit for bit.
        return ["policy", "policy.optimizer"], ["_rng_torch", "_rng_numpy"]

    # ------------------------------------------------------------------ random state
    def _capture_rng(self) -> None:
        """Keep the global generators' current state as the model's training stream."""
        self._rng_torch = th.get_rng_state()
        self._rng_numpy = encode_numpy_state(np.random.get_state())

    @contextlib.contextmanager
    def _training_rng(self):
        """Train on the model's own random stream: torch's and numpy's global generators are set to the state the
        last ``learn`` left them in (or the seed's), and given back to the caller afterwards. The stream is saved
        in the zip, so ``save``, ``load``, ``learn`` draws what ``learn`` continued in memory would."""
        caller = (th.get_rng_state(), np.random.get_state())
        if len(self._rng_torch):
            th.set_rng_state(self._rng_torch)
            np.random.set_state(decode_numpy_state(self._rng_numpy))
        try:
            yield
        finally:
            self._capture_rng()
            th.set_rng_state(caller[0])
            np.random.set_state(caller[1])

    def torch_modules(self) -> dict[str, th.nn.Module]:
        """Every torch module the zip holds (``_get_torch_save_params``), by name."""
        out = {}
        for name in self._get_torch_save_params()[0]:
            obj = self
            for part in name.split("."):
                obj = getattr(obj, part)
            if isinstance(obj, th.nn.Module):
                out[name] = obj
        return out

    @th.no_grad()
    def validation_losses(self, expert_data: ExpertData) -> dict[str, float]:
        """Losses on (held-out) expert data: ``bc_loss``, -E log pi(a|s) for Discrete actions and the mean's
        squared error for Box actions (see :class:`~sb3_mbil.common.heldout.ValidationCallback`)."""
        pairs = as_demonstrations(expert_data, self.observation_space, self.action_space).pairs()
        obs, act = self._to_tensor(pairs["observations"], "obs"), self._to_tensor(pairs["actions"], "act")
        kind = "nll" if isinstance(self.action_space, spaces.Discrete) else "mse"
        return {"bc_loss": float(bc_loss(self.policy, self.policy.heads(obs), act, kind))}

    def predict(self, observation, state=None, episode_start=None, deterministic: bool = False):
        """SB3's ``predict``, refusing observations that are not finite numbers (a NaN would give an action silently)."""
        if not isinstance(observation, dict):
            obs = np.asarray(observation)
            if obs.dtype.kind not in "biuf":
                raise ValueError(f"observation: expected numbers, found an array of dtype {obs.dtype}")
            if obs.dtype.kind == "f" and not np.all(np.isfinite(obs)):
                idx = tuple(int(i) for i in np.argwhere(~np.isfinite(obs))[0])
                raise ValueError(f"observation: expected finite values, found {obs[idx]} at index {idx}")
        return super().predict(observation, state, episode_start, deterministic)

    def diagnostics(self) -> dict[str, Any]:
        """What the algorithm reports about its last ``learn`` beyond the logger, for result rows (a harness reads
        this, never the algorithm's attributes): ``fit_seconds`` of any model it fitted before the policy, and the
        algorithm's own (e.g. MBIL's held-out likelihoods). Override and extend ``super().diagnostics()``."""
        return {"fit_seconds": 0.0}

    # ------------------------------------------------------------------ files
    def save(self, path: str | os.PathLike | io.BufferedIOBase, exclude=None, include=None) -> None:
        """SB3's ``save``, written whole or not at all: a failed or killed save leaves the old zip intact. The zip
        also holds a plain-JSON description of the entries SB3 pickles, so that it loads with ``safe=True``."""
        if not isinstance(path, (str, os.PathLike)):
            super().save(path, exclude, include)
            path.seek(0)
            add_description(path, self)
            return
        target = Path(path)
        if target.suffix == "":
            target = target.with_suffix(".zip")  # as SB3 names it
        with atomic_write(target) as tmp:
            super().save(tmp, exclude, include)
            add_description(tmp, self)

    @classmethod
    def load(cls, path, env: GymEnv | str | None = None, device: th.device | str = "auto", custom_objects=None,
             print_system_info: bool = False, force_reset: bool = True, safe: bool = False, **kwargs):
        """SB3's ``load``; ``env`` may be an env id (as in the constructor), the zip is checked to be one of ``cls``
        first, and ``expert_data`` given here is checked at once.

        .. warning:: A model zip can hold pickled objects, and unpickling runs code: as with every SB3 algorithm,
           ``load`` a zip only from a source you trust, or pass ``safe=True``.

        :param safe: unpickle nothing: every pickled entry is rebuilt from the algorithm class and the zip's plain
            JSON (:mod:`sb3_mbil.common.safe_load`), the weights are read with ``torch.load(weights_only=True)``, and
            a zip holding an entry that cannot be rebuilt is refused with a ``ValueError``. Every zip this package
            writes loads this way.
        """
        raw, where = None, "model zip"
        if isinstance(path, (str, os.PathLike)):
            target = Path(path)
            if not target.exists() and target.suffix == "":
                target = target.with_suffix(".zip")
            where = str(target)
            if target.is_file():
                raw = target.read_bytes()  # read once: what is checked is what is loaded
                cls._check_saved_by(target, raw)
        if safe and raw is None:
            if not hasattr(path, "read"):
                raise FileNotFoundError(f"model zip not found: {path}")
            raw = path.read()
        if raw is not None:
            check_version(raw, where)
            check_members(cls, raw, where)
        if safe:
            objects = safe_custom_objects(cls, raw, where)
            custom_objects = {**objects, **(custom_objects or {})}
        if isinstance(env, str):
            env = gym.make(env)
        warn_if_no_device(device)
        try:
            model = super().load(io.BytesIO(raw) if raw is not None else path, env=env, device=device,
                                 custom_objects=custom_objects, print_system_info=print_system_info,
                                 force_reset=force_reset, **kwargs)
        except (RuntimeError, ValueError) as e:
            text = str(e)
            if "Error(s) in loading state_dict" in text or "invalid object name" in text or "size mismatch" in text:
                first = text.strip().splitlines()[0]
                raise ValueError(f"{where}: expected weights that fit the networks {cls.__name__} builds from the "
                                 f"zip's settings, found a mismatch ({first}; a zip of another algorithm or of other "
                                 "settings?)") from None
            raise
        if raw is not None:
            warn_unknown_entries(model, raw, where)
            model._match_optimizer_weight_decay(raw, where)
        if model.expert_data is not None and model.env is not None:
            model.demonstrations()
        return model

    def _match_optimizer_weight_decay(self, raw: bytes, where: str) -> None:
        """The saved optimiser is the record of the weight decay a model trained with: a zip without the
        ``weight_decay`` entry (an older version) takes it from there; one whose entry disagrees with it is refused."""
        saved = {g.get("weight_decay") for g in self.policy.optimizer.param_groups}
        if len(saved) != 1:
            return
        (optimizer_wd,) = saved
        if optimizer_wd is None or float(optimizer_wd) == float(self.weight_decay):
            return
        with zipfile.ZipFile(io.BytesIO(raw)) as archive:
            has_entry = "weight_decay" in json.loads(archive.read("data"))
        if has_entry:
            raise ValueError(f"{where}: weight_decay: expected the saved optimiser's weight decay "
                             f"({optimizer_wd}), found {self.weight_decay} (a zip edited or assembled from two models)")
        warnings.warn(f"{where}: weight_decay: taken from the saved optimiser ({optimizer_wd}); the zip has no entry "
                      "for it", stacklevel=3)
        self.weight_decay = float(optimizer_wd)

    @classmethod
    def _check_saved_by(cls, path: Path, raw: bytes | None = None) -> None:
        """Refuse, naming the file and both algorithms, a zip that another algorithm (or library) saved."""
        if not path.exists() and path.suffix == "":
            path = path.with_suffix(".zip")
        if raw is None and not path.is_file():
            return  # SB3 raises its FileNotFoundError
        try:
            with zipfile.ZipFile(io.BytesIO(raw) if raw is not None else path) as archive:
                data = json.loads(archive.read("data"))
        except (zipfile.BadZipFile, KeyError, json.JSONDecodeError, UnicodeDecodeError) as e:
            raise ValueError(f"{path}: expected a model zip saved by {cls.__name__}.save, found an unreadable file "
                             f"(truncated or not a model zip: {e})") from None
        saved = data.get("algorithm") if isinstance(data, dict) else None
        if saved != cls.__name__:
            origin = f"sb3_mbil's {saved}" if saved else "another library (e.g. an SB3 PPO or DQN) or an older sb3_mbil"
            hint = f": load it with sb3_mbil.{saved}.load" if saved else ""
            raise ValueError(f"{path}: expected a model saved by {cls.__name__}, found one saved by {origin}{hint}")

    # ------------------------------------------------------------------ data
    def _excluded_save_params(self) -> list[str]:
        # The dataset and everything derived from it stay out of the zip.
        return [*super()._excluded_save_params(), "expert_data", "_demonstrations", "_expert_cache", "_train_stats", "_parameters",
                "_data_in_use", "_window", "_record_sink", "_lockstep_generator"]

    def set_expert_data(self, expert_data: ExpertData) -> None:
        """Give (or replace) the expert data, e.g. after ``load`` to continue learning. Inside ``learn`` only a
        callback's ``on_training_start`` may do so (before anything is fitted to the data)."""
        if getattr(self, "_data_in_use", False):
            raise ValueError("expert_data: expected no change while learn trains on the data (models fitted to it "
                             "and the training caches would no longer match), found set_expert_data called from a "
                             "callback after training started; call it before learn, or in on_training_start")
        self.expert_data = expert_data
        self._demonstrations = None
        self._on_new_data()
        if expert_data is not None:
            self.demonstrations()

    def _on_new_data(self) -> None:
        """Forget the tensors derived from the data (extend to forget an algorithm's own caches)."""
        self._expert_cache: dict[type, Any] = {}

    def demonstrations(self) -> Demonstrations:
        """The checked expert data as :class:`Demonstrations`."""
        if self._demonstrations is None:
            if self.expert_data is None:
                raise ValueError(
                    "expert_data: expected demonstrations to learn from, found None "
                    "(pass expert_data= to the constructor, to load, or call set_expert_data)"
                )
            demos = as_demonstrations(self.expert_data, self.observation_space, self.action_space)
            recorded, env_id = demos.metadata.get("env_id"), self._env_id()
            if recorded is not None and env_id is not None and recorded != env_id:
                warnings.warn(f"expert_data: recorded on {recorded} (its metadata), used with {env_id}: the spaces "
                              "match, the dynamics may not", UserWarning, stacklevel=2)
            self._demonstrations = demos
            self.expert_info = demos.provenance()
        return self._demonstrations

    def _env_id(self) -> str | None:
        """The id of the env the model learns for, when it was made from a registered id."""
        try:
            spec = self.env.get_attr("spec")[0] if self.env is not None else None
        except (AttributeError, IndexError):
            return None
        return getattr(spec, "id", None)

    def _to_tensor(self, array: np.ndarray, kind: str) -> th.Tensor:
        """Observations/continuous actions as flat float32, discrete actions as int64."""
        if kind == "obs":
            return th.as_tensor(np.asarray(array, dtype=np.float32).reshape(len(array), -1), device=self.device)
        if isinstance(self.action_space, spaces.Discrete):
            return th.as_tensor(np.asarray(array).reshape(len(array)).astype(np.int64), device=self.device)
        return th.as_tensor(np.asarray(array, dtype=np.float32).reshape(len(array), -1), device=self.device)

    def expert_pairs(self) -> PairSamples:
        """Every expert (s, a) pair as tensors (cached until the data changes)."""
        if PairSamples not in self._expert_cache:
            p = self.demonstrations().pairs()
            self._expert_cache[PairSamples] = PairSamples(self._to_tensor(p["observations"], "obs"),
                                                          self._to_tensor(p["actions"], "act"))
        return self._expert_cache[PairSamples]

    def expert_transitions(self) -> TransitionSamples:
        """Every expert (s, a, s', done) inside a trajectory as tensors (cached)."""
        if TransitionSamples not in self._expert_cache:
            t = self.demonstrations().transitions()
            self._expert_cache[TransitionSamples] = TransitionSamples(
                self._to_tensor(t["observations"], "obs"), self._to_tensor(t["actions"], "act"),
                self._to_tensor(t["next_observations"], "obs"),
                th.as_tensor(t["dones"], dtype=th.float32, device=self.device))
        return self._expert_cache[TransitionSamples]

    def expert_tuples(self) -> TupleSamples:
        """Every consecutive expert (s, a, s', a') inside a trajectory as tensors (cached)."""
        if TupleSamples not in self._expert_cache:
            demos = self.demonstrations()
            # a one-step trajectory forms no tuple, unless it is a piece that knows the next action (subsample)
            short = [i for i, t in enumerate(demos) if len(t) < 2 and t.final_action is None]
            if "subsampled" in demos.metadata and len(short) < len(demos):  # kept last steps of episodes
                short = []
            if short:
                raise ValueError(
                    f"expert_data: expected trajectories of 2 or more steps ({type(self).__name__} needs consecutive "
                    f"(s, a, s', a')), found {len(short)} shorter ones, e.g. trajectory {short[0]} with "
                    f"{len(demos[short[0]])} step"
                )
            self._expert_cache[TupleSamples] = self.tuple_tensors(demos)
        return self._expert_cache[TupleSamples]

    def tuple_tensors(self, expert_data: ExpertData) -> TupleSamples:
        """The consecutive (s, a, s', a') of any expert data (e.g. held-out trajectories) as tensors."""
        t = as_demonstrations(expert_data, self.observation_space, self.action_space).tuples()
        return TupleSamples(self._to_tensor(t["observations"], "obs"), self._to_tensor(t["actions"], "act"),
                            self._to_tensor(t["next_observations"], "obs"), self._to_tensor(t["next_actions"], "act"))

    def model_fit_split(self, fraction: float) -> tuple[int, np.ndarray, np.ndarray]:
        """(seed, train indices, held-out indices) of the expert tuples for fitting a density model: whole blocks of
        consecutive steps held out; the seed is the model's (drawn once when it has none)."""
        from sb3_mbil.common.flows import block_split

        seed = int(self.seed) if self.seed is not None else int(th.randint(0, 2**31 - 1, ()).item())
        train_idx, val_idx = block_split(self.demonstrations().tuples()["trajectory_index"], fraction, seed)
        return seed, train_idx, val_idx

    def sample(self, samples: Samples) -> Samples:
        """A minibatch of ``batch_size`` rows drawn with replacement."""
        return take(samples, self._sample_indices(len(samples.observations)))

    # ------------------------------------------------------------------ hooks
    def _optimizers(self) -> list[th.optim.Optimizer]:
        """The optimisers that follow the learning-rate schedule (extend with an algorithm's own)."""
        return [self.policy.optimizer]

    def _update_learning_rate(self, optimizers: list[th.optim.Optimizer] | th.optim.Optimizer) -> None:
        """SB3's: the schedule's value set on every optimiser and logged (read once per update, not twice)."""
        lr = self.lr_schedule(self._current_progress_remaining)
        self.logger.record("train/learning_rate", lr)
        for optimizer in optimizers if isinstance(optimizers, list) else [optimizers]:
            for group in optimizer.param_groups:
                group["lr"] = lr

    def training_complete(self) -> bool:
        """True when the method has nothing left to do (an algorithm with a finite schedule); ``learn`` then returns."""
        return False

    def _fit_log(self, what: str):
        """A progress printer for a model fit (``verbose >= 1``), or None."""
        if self.verbose < 1:
            return None
        return lambda line: print(f"{type(self).__name__}: {what}: {line}", flush=True)

    def _prepare_training(self) -> None:
        """Called once at the start of every ``learn`` (after the logger is set)."""

    def _train_step(self) -> None:
        """One gradient step. Record values with ``self._record``.

        The default is the lockstep-ready form (:mod:`sb3_mbil.common.lockstep`): :meth:`_draw_batch` then
        :meth:`_batch_loss`, one step of the policy's optimiser. An algorithm with other optimisers writes its own."""
        loss = self._batch_loss(self._draw_batch())
        self.policy.optimizer.zero_grad(set_to_none=True)
        loss.backward()
        self.policy.optimizer.step()

    def _draw_batch(self) -> Any:
        """Every random draw of one update and every per-model tensor its loss reads (the minibatch's rows, their
        cached targets), as a (named) tuple of tensors (``None`` for an unused field)."""
        raise NotImplementedError

    def _batch_loss(self, batch: Any) -> th.Tensor:
        """The update's loss from :meth:`_draw_batch`'s batch: the policy's outputs at :meth:`_policy_inputs` (one
        forward pass), then :meth:`_loss_from_heads`."""
        inputs = self._policy_inputs(batch)
        heads = self.policy.raw_heads(inputs) if self._raw_heads() else self.policy.heads(inputs)
        return self._loss_from_heads(batch, heads)

    def _policy_inputs(self, batch: Any) -> th.Tensor:
        """The states the update evaluates the policy at, in one tensor (one forward pass)."""
        raise NotImplementedError

    def _raw_heads(self) -> bool:
        """True when the loss reads the policy's :meth:`~ImitationPolicy.raw_heads` (a tanh-Gaussian's likelihood)."""
        return False

    def _loss_from_heads(self, batch: Any, heads: tuple[th.Tensor, ...]) -> th.Tensor:
        """The loss from the batch and the policy's outputs at :meth:`_policy_inputs`: it reads no parameter, no
        random draw and no per-model state, so that seeds can evaluate it at once on their stacked outputs."""
        raise NotImplementedError

    def supports_lockstep(self) -> bool:
        """True when the update is :meth:`_draw_batch`, :meth:`_policy_inputs` and :meth:`_loss_from_heads` on the
        policy's optimiser alone, so that several seeds can train as one batched network
        (:func:`sb3_mbil.learn_lockstep`)."""
        return type(self)._loss_from_heads is not OfflineAlgorithm._loss_from_heads and \
            type(self)._train_step is OfflineAlgorithm._train_step and \
            type(self)._batch_loss is OfflineAlgorithm._batch_loss

    # ------------------------------------------------------------------ learn
    def learn(
        self: SelfOffline,
        total_timesteps: int,
        callback: MaybeCallback = None,
        log_interval: int = 1000,
        tb_log_name: str | None = None,
        reset_num_timesteps: bool = True,
        progress_bar: bool = False,
    ) -> SelfOffline:
        """Train for ``total_timesteps`` gradient steps.

        :param total_timesteps: number of gradient steps
        :param callback: SB3 callback(s), called once per gradient step
        :param log_interval: dump the logger every this many gradient steps
        :param tb_log_name: tensorboard run name (default: the algorithm's class name, as SB3's algorithms do)
        :param reset_num_timesteps: reset the step counter (False to continue)
        :param progress_bar: show a progress bar (tqdm and rich)

        Training runs with one torch intra-op thread (``model.torch_threads``, default
        ``SB3_MBIL_TORCH_THREADS`` or 1) and subnormal floats flushed to zero (``SB3_MBIL_FLUSH_SUBNORMALS``), and
        restores the caller's settings after (:mod:`sb3_mbil.common.threads`).
        """
        with training_cpu(self), self._training_rng():
            return self._learn(total_timesteps, callback, log_interval, tb_log_name, reset_num_timesteps, progress_bar)

    def _learn(self: SelfOffline, total_timesteps: int, callback: MaybeCallback, log_interval: int,
               tb_log_name: str | None, reset_num_timesteps: bool, progress_bar: bool) -> SelfOffline:
        total_timesteps, callback = self._begin_learning(total_timesteps, callback, tb_log_name, reset_num_timesteps,
                                                         progress_bar)
        try:
            while self.num_timesteps < total_timesteps and not self.training_complete():
                self._update_current_progress_remaining(self.num_timesteps, total_timesteps)
                self._update_learning_rate(self._optimizers())
                self._train_step()
                if not self._end_step(callback, log_interval):
                    break
            self._finish_learning(callback)
        finally:
            self._data_in_use = False
        return self

    def _begin_learning(self, total_timesteps: int, callback: MaybeCallback, tb_log_name: str | None,
                        reset_num_timesteps: bool, progress_bar: bool):
        """Everything before the first update: SB3's set-up, the data's checks, the callbacks' start, the models'
        fits (``_prepare_training``); returns SB3's (total_timesteps, callback)."""
        if self.env is None:
            raise ValueError("env: expected an env to learn (load the model with env=...), found None")
        if isinstance(total_timesteps, bool) or not (
            isinstance(total_timesteps, (int, np.integer))
            or (isinstance(total_timesteps, float) and total_timesteps.is_integer())
        ) or total_timesteps < 0:
            raise ValueError(f"total_timesteps: expected an integer number of gradient steps >= 0 (0 prepares the "
                             f"algorithm, e.g. fits MBIL's flows, and trains nothing), found {total_timesteps!r}")
        total_timesteps, callback = self._setup_learn(
            int(total_timesteps), callback, reset_num_timesteps, tb_log_name or type(self).__name__, progress_bar
        )
        self.demonstrations()  # check the data before anything else
        # callbacks start before anything is fitted: a ValidationCallback may hold out part of the data here
        callback.on_training_start(locals(), globals())
        if getattr(self.policy, "normalize_observations", False) and not bool(self.policy.obs_stats_set):
            # set once (kept by save/load and by set_expert_data, so continued training sees the same inputs)
            self.policy.set_observation_stats(self.expert_pairs().observations)
        self._data_in_use = True
        try:
            self._prepare_training()
        except BaseException:
            self._data_in_use = False
            raise
        self.policy.set_training_mode(True)
        self._train_stats: dict[str, tuple] = {}
        self._window: dict[str, list[tuple[int, th.Tensor]]] = {}
        self._parameters: list[tuple[str, th.nn.Parameter]] | None = None
        return total_timesteps, callback

    def _end_step(self, callback, log_interval: int) -> bool:
        """After one update: count it, check finiteness every ``FINITE_CHECK_EVERY`` steps, call the callbacks, dump
        the logs; False when a callback stops training."""
        self.num_timesteps += 1
        if self.num_timesteps % FINITE_CHECK_EVERY == 0:
            self._check_finite()
        self._n_updates += 1
        callback.update_locals(locals())
        if not callback.on_step():
            return False
        if log_interval > 0 and self.num_timesteps % log_interval == 0:
            self.dump_logs()
        return True

    def _finish_learning(self, callback) -> None:
        self._check_finite()
        self.policy.set_training_mode(False)
        callback.on_training_end()

    def _record(self, key: str, value: th.Tensor) -> None:
        """Keep a training statistic (its mean since the last dump is logged). Nothing waits for the device here:
        every ``FINITE_CHECK_EVERY`` steps :meth:`_check_finite` checks the kept values at once, and a non-finite
        one stops training naming its term and the step it appeared at."""
        sink = getattr(self, "_record_sink", None)
        if sink is not None:  # lockstep: the values leave the batched loss as its output
            sink[key] = value.detach()
            return
        self._window.setdefault(key, []).append((self.num_timesteps + 1, value.detach()))

    def _check_finite(self) -> None:
        """Stop at the first non-finite recorded value (its term and gradient step named), then at a non-finite
        parameter; fold the checked values into the logged means."""
        window, self._window = getattr(self, "_window", {}), {}
        if not hasattr(self, "_train_stats"):
            self._train_stats = {}
        first = None
        for key, items in window.items():
            # an entry is (step, value), or (first step, values of consecutive steps) from a lockstep run
            values = th.cat([v.reshape(-1) for _, v in items])
            finite = th.isfinite(values)
            if not bool(finite.all()):
                i = int((~finite).nonzero()[0])
                steps = [s + k for s, v in items for k in range(v.numel())]
                if first is None or steps[i] < first[0]:
                    first = (steps[i], key, float(values[i]))
            total, count = self._train_stats.get(key, (0.0, 0))
            self._train_stats[key] = (total + values.sum(), count + len(values))
        if first is not None:
            step, key, value = first
            raise FloatingPointError(
                f"{type(self).__name__}: {key} is {value} at gradient step {step}: training stopped "
                "(lower the learning rate, or check the scale of the expert data)")
        if hasattr(self, "_parameters"):
            self._check_parameters()

    def _check_parameters(self) -> None:
        """Stop at the first non-finite parameter of any saved module (a loss can stay finite while a step is not);
        frozen ones (target networks, DSFN's feature network) are copies of checked ones and are skipped."""
        if self._parameters is None:
            self._parameters = [(f"{name}.{k}", p) for name, module in self.torch_modules().items()
                                for k, p in module.named_parameters() if p.requires_grad]
        norms = th._foreach_norm([p.detach() for _, p in self._parameters])
        if not bool(th.isfinite(th.stack(norms)).all()):
            bad = next(k for (k, _), n in zip(self._parameters, norms) if not th.isfinite(n))
            raise FloatingPointError(
                f"{type(self).__name__}: parameter {bad} is not finite after gradient step {self.num_timesteps}: training "
                "stopped (lower the learning rate, or check the scale of the expert data)")

    def dump_logs(self) -> None:
        self._check_finite()
        for key, (total, count) in getattr(self, "_train_stats", {}).items():
            self.logger.record(key, float(total) / count)
        self._train_stats = {}
        elapsed = max((time.time_ns() - self.start_time) / 1e9, sys.float_info.epsilon)
        fps = int((self.num_timesteps - self._num_timesteps_at_start) / elapsed)
        self.logger.record("time/fps", fps)
        self.logger.record("time/time_elapsed", int(elapsed), exclude="tensorboard")
        self.logger.record("time/total_timesteps", self.num_timesteps, exclude="tensorboard")
        self.logger.record("train/n_updates", self._n_updates, exclude="tensorboard")
        self.logger.dump(step=self.num_timesteps)

    def _sample_indices(self, n: int) -> th.Tensor:
        """A minibatch of ``batch_size`` indices in [0, n), drawn with replacement."""
        return th.randint(0, n, (self.batch_size,), device=self.device, generator=self._generator())

    def _generator(self) -> th.Generator | None:
        """The generator of the training stream: torch's global one (set by ``learn``), or the model's own while it
        trains in lockstep with other seeds."""
        return getattr(self, "_lockstep_generator", None)
