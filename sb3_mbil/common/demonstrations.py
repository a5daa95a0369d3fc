"""Expert demonstrations: trajectories of raw observations and actions.

A trajectory of ``T`` steps holds ``T`` actions and ``T + 1`` observations
(the last one is the final next observation) or, when the final observation is
unknown, ``T`` observations. ``terminated`` and ``truncated`` are kept apart.

From a set of trajectories we build, never across an episode boundary,

* the ``(s, a)`` pairs behaviour cloning needs,
* the ``(s, a, s')`` transitions,
* the consecutive tuples ``(s, a, s', a')`` MBIL's Markov balance equation needs.

Files are compressed ``.npz`` archives read with ``allow_pickle=False``
and written to a temporary file that is then renamed (whole or not at all).

Over 400 lines on purpose: :class:`Demonstrations` is the package's one data type, and its constructors and
converters (files, Minari, imitation, pairs, transitions, tuples, sampling) are its methods so that a user finds
them on the object; the shipped-pool lookup at the end is the only code outside it.
"""

from __future__ import annotations

import json
import os
import re
import zipfile
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Union

import numpy as np
from gymnasium import spaces

from sb3_mbil.common.files import atomic_write
from sb3_mbil.common.validation import check_int
from sb3_mbil.experts.specs import EXPERTS  # the first pools' experts

FORMAT_VERSION = 2  # 2: optional final actions of trajectory pieces
_REQUIRED_KEYS = ("observations", "actions", "n_observations", "n_actions", "terminated", "truncated")


def _ensure_numeric(name: str, array: np.ndarray) -> None:
    if array.dtype == object:
        raise ValueError(f"{name}: expected a numeric array, found an object array (dtype=object)")
    if not (np.issubdtype(array.dtype, np.integer) or np.issubdtype(array.dtype, np.floating)):
        raise ValueError(f"{name}: expected a real numeric dtype (integer or float), found dtype={array.dtype}")


#: Largest magnitude accepted in the data: squares and sums of squares of larger values overflow float32.
MAX_ABS_VALUE = 1e15


def _ensure_finite(name: str, array: np.ndarray) -> None:
    if np.issubdtype(array.dtype, np.floating) and not np.all(np.isfinite(array)):
        bad = np.argwhere(~np.isfinite(array))[0]
        raise ValueError(f"{name}: expected finite values, found {array[tuple(bad)]} at index {tuple(int(i) for i in bad)}")
    if array.size and np.abs(array).max() > MAX_ABS_VALUE:
        bad = np.unravel_index(int(np.abs(array).argmax()), array.shape)
        raise ValueError(f"{name}: expected values of magnitude <= {MAX_ABS_VALUE:g} (larger ones overflow float32 "
                         f"arithmetic in training), found {array[bad]} at index {tuple(int(i) for i in bad)}")


@dataclass(frozen=True)
class Trajectory:
    """One expert episode (or a part of one).

    :param observations: raw observations, shape ``(T + 1, *obs_shape)`` including the
        final next observation, or ``(T, *obs_shape)`` when it is unknown
    :param actions: actions, shape ``(T,)`` for discrete, ``(T, *action_shape)`` for continuous actions
    :param terminated: whether the episode ended in a terminal state after the last action
    :param truncated: whether the episode was cut by a time limit after the last action
    :param episode_return: the episode's return when known (``nan`` otherwise)
    :param final_action: the expert's action at the final observation, when the trajectory is a piece cut from a
        longer episode (:meth:`Demonstrations.subsample`); it completes one more ``(s, a, s', a')`` tuple
    """

    observations: np.ndarray
    actions: np.ndarray
    terminated: bool = False
    truncated: bool = False
    episode_return: float = float("nan")
    final_action: np.ndarray | None = None

    def __post_init__(self) -> None:
        obs = np.asarray(self.observations)
        act = np.asarray(self.actions)
        _ensure_numeric("observations", obs)
        _ensure_numeric("actions", act)
        if act.ndim == 0 or len(act) == 0:
            raise ValueError(f"actions: expected at least one action, found shape {act.shape}")
        if obs.ndim == 0 or len(obs) not in (len(act), len(act) + 1):
            raise ValueError(
                f"observations: expected {len(act)} or {len(act) + 1} rows for {len(act)} actions, "
                f"found shape {obs.shape}"
            )
        _ensure_finite("observations", obs)
        _ensure_finite("actions", act)
        if self.final_action is not None:
            final = np.asarray(self.final_action)
            _ensure_numeric("final_action", final)
            _ensure_finite("final_action", final)
            if final.shape != act.shape[1:]:
                raise ValueError(f"final_action: expected the shape of one action {act.shape[1:]}, found {final.shape}")
            if len(obs) != len(act) + 1:
                raise ValueError(f"final_action: expected the final observation too ({len(act) + 1} observations), "
                                 f"found {len(obs)}")
            object.__setattr__(self, "final_action", final)
        object.__setattr__(self, "observations", obs)
        object.__setattr__(self, "actions", act)
        object.__setattr__(self, "terminated", bool(self.terminated))
        object.__setattr__(self, "truncated", bool(self.truncated))
        ret = self.episode_return
        if isinstance(ret, (bool, np.bool_)) or not isinstance(ret, (int, float, np.integer, np.floating)):
            raise ValueError(f"episode_return: expected a number (nan when unknown), found {ret!r}")
        object.__setattr__(self, "episode_return", float(ret))

    def __len__(self) -> int:
        return len(self.actions)

    @property
    def has_final_observation(self) -> bool:
        return len(self.observations) == len(self.actions) + 1


ExpertData = Union["Demonstrations", str, os.PathLike, Sequence[tuple[np.ndarray, np.ndarray]], Sequence[Trajectory]]


@dataclass
class Demonstrations:
    """A set of expert trajectories plus metadata (env id, expert source, ...)."""

    trajectories: list[Trajectory]
    metadata: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.trajectories = list(self.trajectories)
        if len(self.trajectories) == 0:
            raise ValueError("trajectories: expected at least one trajectory, found none (no data)")
        for i, traj in enumerate(self.trajectories):
            if not isinstance(traj, Trajectory):
                raise ValueError(f"trajectories[{i}]: expected a Trajectory, found {type(traj).__name__}")
        first = self.trajectories[0]
        for i, traj in enumerate(self.trajectories[1:], start=1):
            if traj.observations.shape[1:] != first.observations.shape[1:]:
                raise ValueError(
                    f"trajectories[{i}].observations: expected shape (*, {', '.join(map(str, first.observations.shape[1:]))})"
                    f" like trajectory 0, found {traj.observations.shape}"
                )
            if traj.actions.shape[1:] != first.actions.shape[1:]:
                raise ValueError(
                    f"trajectories[{i}].actions: expected shape {('*',) + first.actions.shape[1:]} like trajectory 0, "
                    f"found {traj.actions.shape}"
                )

    # ------------------------------------------------------------------ basics
    def __len__(self) -> int:
        return len(self.trajectories)

    def __getitem__(self, index: int) -> Trajectory:
        return self.trajectories[index]

    def __iter__(self):
        return iter(self.trajectories)

    def __repr__(self) -> str:
        env = self.metadata.get("env_id", "?")
        return f"Demonstrations(env_id={env!r}, n_trajectories={len(self)}, n_steps={self.n_steps})"

    @property
    def n_steps(self) -> int:
        return int(sum(len(t) for t in self.trajectories))

    @property
    def episode_returns(self) -> np.ndarray:
        return np.array([t.episode_return for t in self.trajectories], dtype=np.float64)

    @property
    def episode_lengths(self) -> np.ndarray:
        return np.array([len(t) for t in self.trajectories], dtype=np.int64)

    def sample(self, n: int, seed: int | None = None) -> Demonstrations:
        """Draw ``n`` distinct trajectories, deterministically for a given seed (the paper's protocol)."""
        if isinstance(n, (bool, np.bool_)) or not isinstance(n, (int, np.integer)) or n < 1 or n > len(self):
            raise ValueError(f"n: expected an integer in [1, {len(self)}], found {n!r}")
        if seed is not None and (isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer))
                                 or not 0 <= seed < 2**64):
            raise ValueError(f"seed: expected None or an integer >= 0 and < 2**64, found {seed!r}")
        seed = None if seed is None else int(seed)
        rng = np.random.default_rng(seed)
        idx = rng.choice(len(self), size=int(n), replace=False)
        meta = dict(self.metadata)
        meta["sampled"] = {"n": int(n), "seed": seed, "indices": [int(i) for i in idx]}
        return Demonstrations([self.trajectories[i] for i in idx], meta)

    def subsample(self, every: int, offset: int | str = 0, with_next: bool = False, seed: int = 0) -> Demonstrations:
        """Keep every ``every``-th step of each trajectory, from step ``offset`` (the published baselines' data
        protocol: EDM's and IQ-Learn's codes keep every 20th or 5th step). ``offset="random"``: each trajectory
        starts at its own step drawn uniformly from [0, every) with ``seed`` (the GAIL codes' ``ExpertDataset``;
        IQ-Learn's has the draw commented out and starts at 0).

        Each kept step t becomes its own one-step piece: ``(s_t, a_t)``, its true successor ``s_{t+1}`` and the
        expert's ``a_{t+1}`` as the piece's ``final_action``, so (s, a, s') and (s, a, s', a') are true one-step
        samples and never join two episodes or two kept steps. A kept last step keeps the episode's end
        (``terminated`` / ``truncated``) and, without a following action, forms a transition but no tuple.
        ``every=1`` keeps every step (still as pieces). ``with_next``: each piece also keeps the kept step's next step
        (s_{t+1}, a_{t+1}) as a labelled pair, i.e. two steps per piece (a control: the labels the successors give
        MBIL, handed to a method that learns from (s, a) pairs only).
        """
        every = check_int("every", every, low=1)
        seed = check_int("seed", seed, low=0, high=2**64 - 1)
        if offset == "random":
            offsets = np.random.default_rng(seed).integers(0, every, size=len(self.trajectories)).tolist()
        else:
            if isinstance(offset, str):
                raise ValueError(f"offset: expected an integer in [0, {every - 1}] or 'random', found {offset!r}")
            offset = check_int("offset", offset, low=0)
            if offset >= every:
                raise ValueError(f"offset: expected an integer in [0, {every - 1}] for every={every} or 'random', "
                                 f"found {offset}")
            offsets = [offset] * len(self.trajectories)
        pieces = []
        steps = 2 if with_next else 1
        for traj, start in zip(self.trajectories, offsets):
            n = len(traj)
            for t in range(start, n, every):
                k = min(steps, n - t)  # steps kept in this piece
                last = t + k == n
                has_next_obs = t + k < len(traj.observations)
                pieces.append(Trajectory(
                    traj.observations[t : t + k + 1] if has_next_obs else traj.observations[t : t + k],
                    traj.actions[t : t + k],
                    terminated=traj.terminated and last, truncated=traj.truncated and last,
                    final_action=None if last else traj.actions[t + k]))
        if not pieces:
            raise ValueError(f"offset: expected a step to keep, found none (offset {offset}, lengths "
                             f"{self.episode_lengths.tolist()[:10]})")
        meta = dict(self.metadata)
        meta["subsampled"] = {"every": every, "offset": offset, "n_episodes": len(self), "n_steps": self.n_steps}
        if offset == "random":
            meta["subsampled"].update(seed=int(seed), offsets=[int(o) for o in offsets])
        if with_next:
            meta["subsampled"]["with_next"] = True
        return Demonstrations(pieces, meta)

    def provenance(self) -> dict[str, Any]:
        """Where these trajectories came from, in plain types (saved with a model; named in its Hub model card)."""
        meta, sampled = self.metadata, self.metadata.get("sampled") or {}
        expert = meta.get("expert")
        info = {
            "env_id": meta.get("env_id"),
            "pool": meta.get("pool"),
            "expert": (expert.get("source") if isinstance(expert, dict) else None) or meta.get("source"),
            "n_trajectories": len(self),
            "n_steps": self.n_steps,
            "draw_seed": sampled.get("seed"),
            "pool_indices": sampled.get("indices"),
        }
        return json.loads(json.dumps(info, default=_json_value))  # plain JSON types (a model zip stores it as JSON)

    # ------------------------------------------------------------------ views
    def pairs(self) -> dict[str, np.ndarray]:
        """All ``(s, a)`` pairs: ``observations`` and ``actions``."""
        obs = np.concatenate([t.observations[: len(t)] for t in self.trajectories])
        act = np.concatenate([t.actions for t in self.trajectories])
        return {"observations": obs, "actions": act}

    def transitions(self) -> dict[str, np.ndarray]:
        """``(s, a, s')`` inside each trajectory, with ``dones`` = terminated at the final step.

        A trajectory without its final observation contributes ``T - 1`` transitions.
        """
        obs, act, nxt, dones = [], [], [], []
        for t in self.trajectories:
            n = len(t.observations) - 1
            if n <= 0:
                continue
            obs.append(t.observations[:n])
            act.append(t.actions[:n])
            nxt.append(t.observations[1 : n + 1])
            d = np.zeros(n, dtype=bool)
            if t.has_final_observation:
                d[-1] = t.terminated
            dones.append(d)
        if not obs:
            raise ValueError("trajectories: expected at least one with two observations, found none (no transition)")
        return {
            "observations": np.concatenate(obs),
            "actions": np.concatenate(act),
            "next_observations": np.concatenate(nxt),
            "dones": np.concatenate(dones),
        }

    def tuples(self) -> dict[str, np.ndarray]:
        """Consecutive ``(s, a, s', a')`` inside each trajectory (``T - 1`` per trajectory, ``T`` with a
        ``final_action``)."""
        obs, act, nxt, nxt_act, traj_index = [], [], [], [], []
        for i, t in enumerate(self.trajectories):
            n = len(t) - 1 + (t.final_action is not None)
            if n <= 0:
                continue
            obs.append(t.observations[:n])
            act.append(t.actions[:n])
            nxt.append(t.observations[1 : n + 1])
            nxt_act.append(t.actions[1 : n + 1] if t.final_action is None else
                           np.concatenate([t.actions[1:], t.final_action[None]]))
            traj_index.append(np.full(n, i, dtype=np.int64))
        if not obs:
            raise ValueError(
                "trajectories: expected at least one trajectory with 2 or more actions (or a final action) to form "
                "(s, a, s', a') tuples, "
                f"found lengths {self.episode_lengths.tolist()[:10]}"
            )
        return {
            "observations": np.concatenate(obs),
            "actions": np.concatenate(act),
            "next_observations": np.concatenate(nxt),
            "next_actions": np.concatenate(nxt_act),
            "trajectory_index": np.concatenate(traj_index),
        }

    # ------------------------------------------------------------------ checks
    def check_spaces(self, observation_space: spaces.Space, action_space: spaces.Space) -> None:
        """Raise ``ValueError`` naming the field when the data does not fit the env's spaces."""
        if not isinstance(observation_space, spaces.Box):
            raise ValueError(f"observation_space: expected a gymnasium Box, found {observation_space}")
        for i, t in enumerate(self.trajectories):
            if t.observations.shape[1:] != observation_space.shape:
                found, want = t.observations.shape[1:], observation_space.shape
                hint = ""
                if len(want) == 3 and found == (want[1], want[2], want[0]):
                    hint = (": SB3 trains on images channels first (it transposes an env's (H, W, C) images), so give "
                            "the observations as (C, H, W), e.g. np.transpose(observations, (0, 3, 1, 2))")
                if len(want) == 1 and want[0] == 0:
                    hint = ": the env's observations are empty (shape (0,)), there is nothing to learn from"
                raise ValueError(
                    f"trajectories[{i}].observations: expected per-step shape {want} "
                    f"(from the env's observation space), found {found}{hint}"
                )
            if np.issubdtype(observation_space.dtype, np.floating) and not np.can_cast(
                t.observations.dtype, observation_space.dtype, casting="same_kind"
            ):
                raise ValueError(
                    f"trajectories[{i}].observations: expected a dtype castable to {observation_space.dtype}, "
                    f"found {t.observations.dtype}"
                )
            low, high = np.broadcast_to(observation_space.low, observation_space.shape), np.broadcast_to(
                observation_space.high, observation_space.shape)
            tol = 1e-5 * (1 + np.abs(np.where(np.isfinite(high - low), high - low, 0.0)))
            outside = (t.observations < low - tol) | (t.observations > high + tol)
            if np.any(outside):
                idx = tuple(int(k) for k in np.argwhere(outside)[0])
                raise ValueError(
                    f"trajectories[{i}].observations: expected values within the observation space bounds (dimension "
                    f"{idx[1:]}: [{low[idx[1:]]}, {high[idx[1:]]}]), found {t.observations[idx]} at index {idx}"
                )
            _check_actions(f"trajectories[{i}].actions", t.actions, action_space)

    # ------------------------------------------------------------------ files
    def save(self, path: str | os.PathLike) -> Path:
        """Write a compressed ``.npz`` atomically (a temporary file renamed into place)."""
        path = Path(path)
        if path.suffix != ".npz":
            path = path.with_suffix(path.suffix + ".npz") if path.suffix else path.with_suffix(".npz")
        path.parent.mkdir(parents=True, exist_ok=True)
        arrays = {
            "format_version": np.array(1),
            "observations": np.concatenate([t.observations for t in self.trajectories]),
            "actions": np.concatenate([t.actions for t in self.trajectories]),
            "n_observations": np.array([len(t.observations) for t in self.trajectories], dtype=np.int64),
            "n_actions": np.array([len(t.actions) for t in self.trajectories], dtype=np.int64),
            "terminated": np.array([t.terminated for t in self.trajectories], dtype=bool),
            "truncated": np.array([t.truncated for t in self.trajectories], dtype=bool),
            "episode_returns": self.episode_returns,
            "metadata_json": np.array(json.dumps(self.metadata, sort_keys=True, default=_json_value)),
        }
        finals = [t.final_action for t in self.trajectories if t.final_action is not None]
        if finals:  # pieces of longer episodes (format 2; a format-1 reader refuses the file instead of losing them)
            arrays["format_version"] = np.array(2)
            arrays["has_final_action"] = np.array([t.final_action is not None for t in self.trajectories], dtype=bool)
            arrays["final_actions"] = np.stack(finals)
        with atomic_write(path) as tmp, open(tmp, "wb") as f:
            np.savez_compressed(f, **arrays)
        return path

    # ------------------------------------------------------------------ Minari
    @classmethod
    def from_minari(cls, dataset: Any) -> Demonstrations:
        """Demonstrations from a Minari dataset (a ``MinariDataset`` or the id of one in the local Minari store).

        Minari episodes hold ``T + 1`` observations and ``T`` actions, like our trajectories; the episode
        return is the sum of its rewards. The dataset's env need not be installed or recoverable: only the
        stored arrays and spaces are read. Needs the ``minari`` extra.
        """
        minari = _import_minari()
        if isinstance(dataset, str):
            local = minari.list_local_datasets()
            if dataset not in local:
                raise ValueError(f"expert_data: expected a Minari dataset id in the local store "
                                 f"({sorted(local)[:10]}), found {dataset!r}")
            dataset = minari.load_dataset(dataset)
        for name, space in (("observation_space", dataset.observation_space), ("action_space", dataset.action_space)):
            if not isinstance(space, (spaces.Box, spaces.Discrete)):
                raise ValueError(f"minari dataset {dataset.spec.dataset_id}: {name}: expected a Box or Discrete space, "
                                 f"found {space}")
        trajs = []
        for episode in dataset.iterate_episodes():
            rewards = np.asarray(episode.rewards, dtype=np.float64)
            trajs.append(Trajectory(np.asarray(episode.observations), np.asarray(episode.actions),
                                    terminated=bool(episode.terminations[-1]), truncated=bool(episode.truncations[-1]),
                                    episode_return=float(rewards.sum())))
        env_spec = getattr(dataset.spec, "env_spec", None)
        metadata = {"source": f"minari:{dataset.spec.dataset_id}", "n_trajectories": len(trajs)}
        if env_spec is not None:
            metadata["env_id"] = env_spec.id
        return cls(trajs, metadata)

    def to_minari(self, dataset_id: str, env: Any = None, observation_space: spaces.Space | None = None,
                  action_space: spaces.Space | None = None, **dataset_kwargs: Any) -> Any:
        """Write these trajectories as a Minari dataset in the local store; returns the ``MinariDataset``.

        ``env`` (an id, env or ``EnvSpec``; default: this data's ``env_id``) gives the spaces unless they are
        passed. Our format keeps episode returns, not per-step rewards: each episode's return is written as
        its last step's reward (the other steps 0), so Minari's returns equal ours. Trajectories without their
        final observation cannot be written (Minari needs ``T + 1`` observations). Needs the ``minari`` extra.
        """
        check_minari_id(dataset_id)
        minari = _import_minari()
        from minari.data_collector import EpisodeBuffer

        short = [i for i, t in enumerate(self.trajectories) if not t.has_final_observation]
        if short:
            raise ValueError(f"trajectories[{short[0]}]: expected T + 1 observations for Minari, found "
                             f"{len(self.trajectories[short[0]].observations)} for {len(self.trajectories[short[0]])} actions")
        env = env if env is not None else self.metadata.get("env_id")
        obs_space = observation_space or getattr(env, "observation_space", None)
        act_space = action_space or getattr(env, "action_space", None)
        if obs_space is None or act_space is None:
            try:  # an env id: its spaces, when the env is installed
                import gymnasium as gym

                made = gym.make(env) if isinstance(env, str) else None
                obs_space, act_space = obs_space or made.observation_space, act_space or made.action_space
            except Exception:
                pass
        if obs_space is not None and act_space is not None:
            self.check_spaces(obs_space, act_space)  # before anything is written
        if env is None and (observation_space is None or action_space is None):
            raise ValueError("env: expected an env id (or observation_space and action_space), found None and no env_id "
                             "in the metadata")
        buffers = []
        for i, t in enumerate(self.trajectories):
            rewards = np.zeros(len(t), dtype=np.float64)
            rewards[-1] = 0.0 if np.isnan(t.episode_return) else t.episode_return
            terminations = np.zeros(len(t), dtype=bool)
            truncations = np.zeros(len(t), dtype=bool)
            terminations[-1], truncations[-1] = t.terminated, t.truncated
            buffers.append(EpisodeBuffer(id=i, observations=t.observations, actions=t.actions, rewards=rewards,
                                         terminations=terminations, truncations=truncations, infos={}))
        kwargs = {"algorithm_name": str(self.metadata.get("source", "expert")), "author": "sb3_mbil",
                  "author_email": "sb3_mbil@localhost", "code_permalink": "https://github.com/sb3_mbil",
                  "description": f"expert demonstrations exported by sb3_mbil ({self.metadata.get('source', '?')})",
                  **dataset_kwargs}
        return minari.create_dataset_from_buffers(dataset_id=dataset_id, buffer=buffers, env=env,
                                                  observation_space=observation_space, action_space=action_space, **kwargs)

    @classmethod
    def load(cls, path: str | os.PathLike) -> Demonstrations:
        path = Path(path)
        if path.is_dir():
            raise ValueError(f"expert_data: expected a .npz file, found a directory: {path}")
        if path.exists() and not path.is_file():
            raise ValueError(f"expert_data: expected a regular .npz file, found {path}, which exists but is not a "
                             "regular file (a device, a socket or a pipe)")
        if not path.is_file():
            raise FileNotFoundError(f"expert data file not found: {path}")
        if not zipfile.is_zipfile(path):
            raise ValueError(f"{path}: expected a readable .npz archive (a zip file), found something else")
        try:
            with np.load(path, allow_pickle=False) as data:
                arrays = {k: data[k] for k in data.files}
        except ValueError as e:  # object arrays need pickle
            raise ValueError(f"{path}: expected plain numeric arrays (allow_pickle=False), found {e}") from e
        except Exception as e:
            raise ValueError(f"{path}: expected a readable .npz archive, found a file numpy cannot read ({e})") from e
        for key, value in arrays.items():
            if not isinstance(value, np.ndarray):  # numpy hands back a member that is not .npy as raw bytes
                raise ValueError(f"{path}: {key}: expected an array member (.npy format), found {type(value).__name__} "
                                 "(a member written some other way, e.g. a raw pickle)")
        missing = [k for k in _REQUIRED_KEYS if k not in arrays]
        if missing:
            raise ValueError(f"{path}: expected keys {list(_REQUIRED_KEYS)}, missing {missing}")
        for key in ("observations", "actions", "n_observations", "n_actions", "terminated", "truncated"):
            if arrays[key].ndim == 0:
                raise ValueError(f"{path}: {key}: expected an array with one entry per {'step' if key in ('observations', 'actions') else 'trajectory'}, "
                                 f"found a 0-d value {arrays[key]!r}")
        if "format_version" in arrays and (arrays["format_version"].shape != () or not np.issubdtype(
                arrays["format_version"].dtype, np.integer) or int(arrays["format_version"]) > FORMAT_VERSION):
            raise ValueError(f"{path}: format_version: expected an integer <= {FORMAT_VERSION} (this version of sb3_mbil "
                             f"reads format {FORMAT_VERSION}), found {arrays['format_version']!r}")
        for key in ("terminated", "truncated"):
            if arrays[key].dtype != bool and not (np.issubdtype(arrays[key].dtype, np.integer)
                                                  and np.isin(arrays[key], (0, 1)).all()):
                raise ValueError(f"{path}: {key}: expected booleans (one per trajectory), found dtype {arrays[key].dtype}")
        for key in ("n_observations", "n_actions"):
            if arrays[key].ndim != 1 or not np.issubdtype(arrays[key].dtype, np.integer) or np.any(arrays[key] < 0):
                raise ValueError(f"{path}: {key}: expected a 1-d array of non-negative integers, found dtype "
                                 f"{arrays[key].dtype} and shape {arrays[key].shape}")
        n_obs, n_act = arrays["n_observations"], arrays["n_actions"]
        n = len(n_act)
        for key in ("n_observations", "terminated", "truncated"):
            if len(arrays[key]) != n:
                raise ValueError(f"{path}: {key}: expected {n} entries (one per trajectory), found {len(arrays[key])}")
        if int(n_obs.sum()) != len(arrays["observations"]) or int(n_act.sum()) != len(arrays["actions"]):
            raise ValueError(
                f"{path}: observations/actions: expected {int(n_obs.sum())}/{int(n_act.sum())} rows from the lengths, "
                f"found {len(arrays['observations'])}/{len(arrays['actions'])}"
            )
        returns = arrays.get("episode_returns", np.full(n, np.nan))
        meta = {}
        if "metadata_json" in arrays:
            try:
                meta = json.loads(str(arrays["metadata_json"]))
            except json.JSONDecodeError as e:
                raise ValueError(f"{path}: metadata_json: expected a JSON object, found unreadable JSON ({e})") from None
            if not isinstance(meta, dict):
                raise ValueError(f"{path}: metadata_json: expected a JSON object, found {type(meta).__name__}")
        if len(returns) != n:
            raise ValueError(f"{path}: episode_returns: expected {n} entries (one per trajectory), found {len(returns)}")
        has_final = arrays.get("has_final_action", np.zeros(n, dtype=bool))
        finals = arrays.get("final_actions", np.zeros((0, *arrays["actions"].shape[1:]), arrays["actions"].dtype))
        if has_final.shape != (n,) or has_final.dtype != bool or int(has_final.sum()) != len(finals):
            raise ValueError(f"{path}: has_final_action / final_actions: expected {n} booleans and one final action per "
                             f"True, found shapes {has_final.shape} and {finals.shape}")
        final_of = dict(zip(np.flatnonzero(has_final).tolist(), finals))
        obs_splits = np.split(arrays["observations"], np.cumsum(n_obs)[:-1])
        act_splits = np.split(arrays["actions"], np.cumsum(n_act)[:-1])
        trajs = []
        for i in range(n):
            try:
                trajs.append(
                    Trajectory(
                        obs_splits[i],
                        act_splits[i],
                        terminated=bool(arrays["terminated"][i]),
                        truncated=bool(arrays["truncated"][i]),
                        episode_return=float(returns[i]),
                        final_action=final_of.get(i),
                    )
                )
            except ValueError as e:
                raise ValueError(f"{path}: trajectories[{i}]: {e}") from e
        return cls(trajs, meta)


def _json_value(value: Any) -> Any:
    """Metadata values JSON does not know: numpy scalars and arrays as numbers and lists (a draw seed np.int64(5)
    comes back as 5, not '5'), anything else as its text."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (set, frozenset)):
        return sorted(value, key=str)
    return str(value)


def _check_actions(name: str, actions: np.ndarray, action_space: spaces.Space) -> None:
    if isinstance(action_space, spaces.Discrete):
        flat = actions.reshape(len(actions), -1)
        if flat.shape[1] != 1:
            raise ValueError(f"{name}: expected one integer per step for {action_space}, found shape {actions.shape}")
        flat = flat[:, 0]
        if np.issubdtype(flat.dtype, np.floating) and not np.all(flat == np.round(flat)):
            raise ValueError(f"{name}: expected integer actions for {action_space}, found non-integer values")
        lo, hi = int(action_space.start), int(action_space.start + action_space.n - 1)
        if flat.min() < lo or flat.max() > hi:
            bad = flat[(flat < lo) | (flat > hi)][0]
            raise ValueError(f"{name}: expected actions in [{lo}, {hi}] ({action_space}), found {bad}")
    elif isinstance(action_space, spaces.Box):
        if actions.shape[1:] != action_space.shape:
            raise ValueError(f"{name}: expected per-step shape {action_space.shape}, found {actions.shape[1:]}")
        tol = 1e-5 * (1 + np.abs(action_space.high - action_space.low))
        below = actions < action_space.low - tol
        above = actions > action_space.high + tol
        if np.any(below | above):
            idx = tuple(int(i) for i in np.argwhere(below | above)[0])
            raise ValueError(
                f"{name}: expected actions within the action space bounds [{action_space.low.min()}, "
                f"{action_space.high.max()}], found {actions[idx]} at index {idx}"
            )
    else:
        raise ValueError(f"action_space: expected Discrete or Box, found {action_space}")


def _from_pairs(items: Iterable[Any]) -> Demonstrations:
    trajs = []
    for i, item in enumerate(items):
        if isinstance(item, Trajectory):
            trajs.append(item)
            continue
        if not isinstance(item, (tuple, list)) or len(item) != 2:
            raise ValueError(
                f"expert_data[{i}]: expected an (observations, actions) pair or a Trajectory, found {type(item).__name__}"
            )
        try:
            obs, act = np.asarray(item[0]), np.asarray(item[1])
        except ValueError as e:
            raise ValueError(f"expert_data[{i}]: expected rectangular arrays, found ragged data ({e})") from e
        try:
            trajs.append(Trajectory(obs, act))
        except ValueError as e:
            raise ValueError(f"expert_data[{i}]: {e}") from e
    return Demonstrations(trajs, {"source": "user arrays"})


POOL_DIR = Path(__file__).resolve().parent.parent / "data"


def available_pools() -> list[str]:
    """Names of the expert pools shipped with the package (``load_demonstrations(name)``)."""
    return sorted(p.stem for p in POOL_DIR.glob("*.npz"))


MINARI_PREFIX = "minari:"


#: a Minari dataset id: ``(namespace/)*name-vN``, each part letters, digits, ``_``, ``-`` or ``.``, never starting with
#: a dot (so no ``..`` and no absolute path can reach outside the store)
_MINARI_ID = re.compile(r"(?:[A-Za-z0-9_][A-Za-z0-9_.-]*/)*[A-Za-z0-9_][A-Za-z0-9_.-]*-v[0-9]+")


def check_minari_id(dataset_id: Any) -> str:
    """A Minari dataset id that names a folder inside the store, or a ``ValueError`` before anything is written."""
    if not isinstance(dataset_id, str) or not _MINARI_ID.fullmatch(dataset_id):
        raise ValueError(f"dataset_id: expected '(namespace/)name-v<version>' with parts of letters, digits, '_', '-' "
                         f"or '.' (not starting with '.'), found {dataset_id!r}")
    return dataset_id


def _import_minari():
    try:
        import minari
    except ImportError as e:
        raise ImportError(f"Minari datasets need the minari extra: pip install 'sb3_mbil[minari]' ({e})") from None
    return minari


#: what the actions of a shipped pool are: the expert's deterministic action (each env's first pools) or an action
#: sampled from its own stochastic policy (pools ``"<pool>-sampled"``: a demonstrator whose log pi_D(a' | s') is finite)
POOL_ACTIONS = ("deterministic", "sampled")


def pool_name(env_id: str, expert: str | None = None, actions: str = "deterministic") -> str:
    """The shipped pool of ``env_id`` whose expert is the RL Zoo algorithm ``expert`` and whose actions are ``actions``.

    Each env's first pool is named after the env (``"LunarLander-v3"``, the paper's expert); a second expert's pool
    after the env and its algorithm (``"LunarLander-v3-dqn"``). ``expert=None`` is the first pool. ``actions="sampled"``
    picks that expert's pool of sampled actions (``"LunarLander-v3-sampled"``, ``"LunarLander-v3-dqn-sampled"``).
    """
    if actions not in POOL_ACTIONS:
        raise ValueError(f"actions: expected one of {list(POOL_ACTIONS)}, found {actions!r}")
    suffix = "" if actions == "deterministic" else f"-{actions}"
    pools = available_pools()
    if expert is None:
        name = env_id + suffix
        if suffix and name not in pools:
            raise ValueError(f"actions: expected a shipped pool {name!r} for {env_id} with {actions} actions, found none "
                             f"(pools of {env_id}: {[p for p in pools if p.startswith(env_id)]})")
        return name
    expert = str(expert).lower()
    if f"{env_id}-{expert}{suffix}" in pools:
        return f"{env_id}-{expert}{suffix}"
    first = EXPERTS.get(env_id)
    if first is not None and first.algo == expert and env_id + suffix in pools:
        return env_id + suffix
    choices = ([first.algo] if first is not None and env_id + suffix in pools else []) + [
        p[len(env_id) + 1:len(p) - len(suffix)] for p in pools
        if p.startswith(f"{env_id}-") and p.endswith(suffix) and (suffix or not p.endswith("-sampled"))
        and p[len(env_id) + 1:len(p) - len(suffix)]]
    raise ValueError(f"expert: expected one of {choices} for {env_id} with {actions} actions, found {expert!r}")


def load_demonstrations(path_or_name: str | os.PathLike, expert: str | None = None,
                        actions: str | None = None) -> Demonstrations:
    """Load demonstrations from a ``.npz`` file, a shipped expert pool by env id (``"CartPole-v1"``; ``expert="ppo"``
    picks the env's pool of another expert and ``actions="sampled"`` its pool of sampled actions, see
    :func:`pool_name`), or a dataset of the local Minari store (``"minari:<dataset id>"``)."""
    if expert is not None or actions is not None:
        path_or_name = pool_name(str(path_or_name), expert, actions or "deterministic")
    if isinstance(path_or_name, str) and path_or_name.startswith(MINARI_PREFIX):
        demos = Demonstrations.from_minari(path_or_name[len(MINARI_PREFIX):])
        demos.metadata["pool"] = path_or_name
        return demos
    path = Path(path_or_name)
    if path.exists():
        demos = Demonstrations.load(path)
        demos.metadata["pool"] = str(path_or_name)
        return demos
    name = str(path_or_name)
    if name in available_pools():
        demos = Demonstrations.load(POOL_DIR / f"{name}.npz")
        demos.metadata["pool"] = name
        return demos
    if path.suffix == ".npz" or os.sep in name:
        raise FileNotFoundError(f"expert data file not found: {path}")
    raise ValueError(f"expert_data: expected a file, a shipped pool name {available_pools()} or 'minari:<dataset id>', "
                     f"found {name!r}")


def as_demonstrations(
    expert_data: ExpertData,
    observation_space: spaces.Space | None = None,
    action_space: spaces.Space | None = None,
) -> Demonstrations:
    """Accept a :class:`Demonstrations`, a path, or a list of ``(observations, actions)`` pairs, and check it."""
    if expert_data is None:
        raise ValueError("expert_data: expected Demonstrations, a path or a list of (observations, actions), found None")
    if isinstance(expert_data, Demonstrations):
        demos = expert_data
    elif isinstance(expert_data, (str, os.PathLike)):
        demos = load_demonstrations(expert_data)
    elif isinstance(expert_data, np.ndarray):
        raise ValueError(
            "expert_data: expected a list of (observations, actions) pairs, one per trajectory, found a single array"
        )
    elif isinstance(expert_data, Iterable):
        demos = _from_pairs(list(expert_data))
    else:
        raise ValueError(
            f"expert_data: expected Demonstrations, a path or a list of (observations, actions), "
            f"found {type(expert_data).__name__}"
        )
    if observation_space is not None and action_space is not None:
        demos.check_spaces(observation_space, action_space)
    return demos
