"""Expert agents: a saved SB3 model, the RL Zoo's pretrained agent on the Hugging Face Hub (offline: its local
copy), and the cache they live in. Training one locally is :mod:`sb3_mbil.experts.zoo_training`; rolling one out
into demonstrations is :mod:`sb3_mbil.experts.generate`."""

from __future__ import annotations

import logging
import os
import socket
from dataclasses import dataclass
from pathlib import Path

import gymnasium as gym
import numpy as np
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.utils import check_for_correct_spaces
from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize



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
#: RL Zoo algorithms with a deterministic actor (sampled with the zoo's exploration noise, see generate_demonstrations)
DETERMINISTIC_ACTORS = ("td3", "ddpg")


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
