"""Loading a model zip without unpickling anything.

SB3's model zip stores some entries of its ``data`` member as cloudpickle (marked ``":serialized:"``): the policy
class, the spaces, the learning-rate schedule, ``policy_kwargs`` holding classes, and runtime buffers. Unpickling
runs code, so ``Model.load(path)`` on a zip from someone you do not trust can run anything (the same is true of
every SB3 algorithm). Our ``save`` adds a plain-JSON member, :data:`MEMBER`, describing each of those entries;
``Model.load(path, safe=True)`` rebuilds every serialised entry from it and from the algorithm class, hands them to
SB3 as ``custom_objects`` (so SB3 never unpickles them), loads the weights with ``torch.load(weights_only=True)`` as
SB3 does, and refuses a zip holding a serialised entry it cannot rebuild. The zip is read once into memory, so what
is checked is what is loaded.
"""

from __future__ import annotations

import collections
import io
import json
import warnings
import zipfile
from typing import Any

import numpy as np
from gymnasium import spaces

from sb3_mbil.common.settings import ACTIVATIONS, OPTIMIZERS
from sb3_mbil.version import __version__

#: the zip member with the plain-JSON description written by ``save``
MEMBER = "sb3_mbil.json"
FORMAT = 1
#: progress points at which a learning-rate schedule is stored (a linear schedule is reproduced exactly by the table)
SCHEDULE_POINTS = 1001
#: serialised runtime entries of SB3's base class that offline training never reads: rebuilt empty
RUNTIME_ENTRIES = ("_last_obs", "_last_episode_starts", "_last_original_obs")
BUFFER_ENTRIES = ("ep_info_buffer", "ep_success_buffer")
_CLASSES = {**{f"nn.{k}": v for k, v in ACTIVATIONS.items()}, **{f"th.optim.{k}": v for k, v in OPTIMIZERS.items()}}


class TableSchedule:
    """A learning-rate schedule given by its values at evenly spaced progress points (linear in between)."""

    def __init__(self, values: list[float]):
        self.values = [float(v) for v in values]
        self.progress = np.linspace(0.0, 1.0, len(self.values))

    def __call__(self, progress_remaining: float) -> float:
        return float(np.interp(progress_remaining, self.progress, self.values))

    def __repr__(self) -> str:
        return f"TableSchedule({self.values[-1]:g} -> {self.values[0]:g})"


# ---------------------------------------------------------------------------------------------- writing
def _space_to_json(space: spaces.Space) -> dict | None:
    if isinstance(space, spaces.Discrete):
        return {"type": "Discrete", "n": int(space.n), "start": int(space.start)}
    if isinstance(space, spaces.Box):
        return {"type": "Box", "low": space.low.tolist(), "high": space.high.tolist(), "shape": list(space.shape),
                "dtype": str(space.dtype)}
    return None


def _plain(value: Any) -> Any:
    """``value`` in plain JSON, torch classes of the whitelist as ``{":torch:": "nn.ELU"}``; raises TypeError else."""
    for name, cls in _CLASSES.items():
        if value is cls:
            return {":torch:": name}
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return {":tuple:": [_plain(v) for v in value]} if isinstance(value, tuple) else [_plain(v) for v in value]
    if isinstance(value, (np.integer, np.floating, np.bool_)):
        return value.item()
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    raise TypeError(type(value).__name__)


def describe(model) -> dict:
    """The plain-JSON description of the entries SB3 would pickle (written into the zip by ``save``)."""
    policy = next((name for name, cls in type(model).policy_aliases.items() if cls is model.policy_class), None)
    try:
        policy_kwargs = _plain(model.policy_kwargs)
    except TypeError:
        policy_kwargs = None  # holds an object safe mode cannot rebuild: such a zip loads only with safe=False
    if callable(model.learning_rate):
        learning_rate = {"table": [float(model.lr_schedule(p)) for p in np.linspace(0.0, 1.0, SCHEDULE_POINTS)]}
    else:
        learning_rate = float(model.learning_rate)
    return {"format": FORMAT, "sb3_mbil_version": __version__, "algorithm": type(model).__name__, "policy": policy,
            "observation_space": _space_to_json(model.observation_space),
            "action_space": _space_to_json(model.action_space), "learning_rate": learning_rate,
            "policy_kwargs": policy_kwargs}


def add_description(target, model) -> None:
    """Append :data:`MEMBER` to a zip SB3 has just written (a path or a seekable file object)."""
    with zipfile.ZipFile(target, "a") as archive:
        archive.writestr(MEMBER, json.dumps(describe(model)))


# ---------------------------------------------------------------------------------------------- reading
def _space_from_json(entry: Any, key: str, where: str) -> spaces.Space:
    try:
        if entry["type"] == "Discrete":
            return spaces.Discrete(int(entry["n"]), start=int(entry["start"]))
        if entry["type"] == "Box":
            dtype = np.dtype(entry["dtype"])
            if dtype.kind not in "fiub":
                raise ValueError(dtype)
            shape = tuple(int(s) for s in entry["shape"])
            low = np.asarray(entry["low"], dtype=dtype).reshape(shape)
            high = np.asarray(entry["high"], dtype=dtype).reshape(shape)
            return spaces.Box(low, high, shape, dtype)
    except (KeyError, TypeError, ValueError) as e:
        raise ValueError(f"{where}: {MEMBER}: {key}: expected a Box or Discrete space, found {entry!r} ({e})") from None
    raise ValueError(f"{where}: {MEMBER}: {key}: expected a Box or Discrete space, found {entry!r}")


def _from_plain(value: Any, where: str) -> Any:
    if isinstance(value, dict):
        if set(value) == {":torch:"}:
            if value[":torch:"] not in _CLASSES:
                raise ValueError(f"{where}: {MEMBER}: policy_kwargs: expected one of {sorted(_CLASSES)}, "
                                 f"found {value[':torch:']!r}")
            return _CLASSES[value[":torch:"]]
        if set(value) == {":tuple:"}:
            return tuple(_from_plain(v, where) for v in value[":tuple:"])
        return {k: _from_plain(v, where) for k, v in value.items()}
    if isinstance(value, list):
        return [_from_plain(v, where) for v in value]
    return value


def safe_custom_objects(cls, raw: bytes, where: str) -> dict[str, Any]:
    """Every serialised entry of the zip's ``data`` rebuilt without unpickling; ``ValueError`` for one that cannot be."""
    from stable_baselines3.common.utils import FloatSchedule

    try:
        with zipfile.ZipFile(io.BytesIO(raw)) as archive:
            data = json.loads(archive.read("data"))
            description = json.loads(archive.read(MEMBER)) if MEMBER in archive.namelist() else None
    except (zipfile.BadZipFile, KeyError, json.JSONDecodeError, UnicodeDecodeError) as e:
        raise ValueError(f"{where}: expected a model zip saved by {cls.__name__}.save, found an unreadable file ({e})") \
            from None
    serialised = [k for k, v in data.items() if isinstance(v, dict) and ":serialized:" in v]
    if description is None:
        if serialised:
            raise ValueError(f"{where}: expected a zip with {MEMBER} (written by sb3_mbil's save) to load with "
                             f"safe=True, found none; its entries {serialised} could only be unpickled. Load it with "
                             "safe=False only if you trust where it came from, and save it again")
        description = {}
    if not isinstance(description, dict):
        raise ValueError(f"{where}: {MEMBER}: expected a JSON object, found {type(description).__name__}")
    objects: dict[str, Any] = {}
    for key in serialised:
        if key == "policy_class":
            name = description.get("policy")
            if name not in cls.policy_aliases:
                raise ValueError(f"{where}: policy_class: expected one of {sorted(cls.policy_aliases)} to load with "
                                 f"safe=True, found {name!r}")
            objects[key] = cls.policy_aliases[name]
        elif key in ("observation_space", "action_space"):
            objects[key] = _space_from_json(description.get(key), key, where)
        elif key in ("learning_rate", "lr_schedule"):
            lr = description.get("learning_rate")
            if isinstance(lr, dict) and isinstance(lr.get("table"), list) and len(lr["table"]) >= 2 \
                    and all(isinstance(v, (int, float)) and not isinstance(v, bool) and np.isfinite(v) for v in lr["table"]):
                schedule = TableSchedule(lr["table"])
            elif isinstance(lr, (int, float)) and not isinstance(lr, bool) and np.isfinite(lr):
                schedule = float(lr)
            else:
                raise ValueError(f"{where}: {MEMBER}: learning_rate: expected a number or a table of numbers, found {lr!r}")
            objects[key] = FloatSchedule(schedule) if key == "lr_schedule" else schedule
        elif key == "policy_kwargs":
            if not isinstance(description.get("policy_kwargs"), dict):
                raise ValueError(f"{where}: policy_kwargs: expected plain settings (numbers, lists, torch classes of "
                                 f"{sorted(_CLASSES)}) to load with safe=True, found an object safe mode cannot rebuild")
            objects[key] = _from_plain(description["policy_kwargs"], where)
        elif key in RUNTIME_ENTRIES:
            objects[key] = None
        elif key in BUFFER_ENTRIES:
            window = data.get("_stats_window_size", 100)
            objects[key] = collections.deque(maxlen=window if isinstance(window, int) and window > 0 else 100)
        else:
            raise ValueError(f"{where}: {key}: expected entries safe mode can rebuild from plain JSON, found a "
                             f"serialised (pickled) {key!r}; load with safe=False only if you trust the file")
    return objects


def check_version(raw: bytes, where: str) -> None:
    """Warn when the zip was written by a newer sb3_mbil than this one."""
    from packaging.version import InvalidVersion, Version

    try:
        with zipfile.ZipFile(io.BytesIO(raw)) as archive:
            if MEMBER not in archive.namelist():
                return
            saved = json.loads(archive.read(MEMBER)).get("sb3_mbil_version")
    except Exception:
        return
    try:
        newer = saved is not None and Version(str(saved)) > Version(__version__)
    except InvalidVersion:
        newer = True
    if newer:
        warnings.warn(f"{where}: saved by sb3_mbil {saved}, newer than this {__version__}: settings it added are "
                      "unknown here and may load with other meanings", stacklevel=3)


def check_members(cls, raw: bytes, where: str) -> None:
    """Before SB3 reads the zip: every ``.pth`` member readable as weights (``weights_only``), named when it is not;
    a warning for a zip written by a newer Stable-Baselines3, for hyperparameters of ``cls`` the zip lacks (they
    load with the constructor's defaults, which may disagree with the saved optimiser) and for entries ``cls`` does
    not know (written by another version: they are set on the model but nothing reads them)."""
    import inspect

    import stable_baselines3
    import torch as th
    from packaging.version import InvalidVersion, Version

    with zipfile.ZipFile(io.BytesIO(raw)) as archive:
        names = archive.namelist()
        data = json.loads(archive.read("data"))
        for member in names:
            if member.endswith(".pth"):
                try:
                    th.load(io.BytesIO(archive.read(member)), map_location="cpu", weights_only=True)
                except Exception as e:
                    first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
                    raise ValueError(f"{where}: {member}: expected torch weights (a state dict saved by torch.save), "
                                     f"found a member torch cannot read as weights ({type(e).__name__}: {first})") from None
        saved_sb3 = archive.read("_stable_baselines3_version").decode().strip() \
            if "_stable_baselines3_version" in names else None
    try:
        if saved_sb3 and Version(saved_sb3) > Version(stable_baselines3.__version__):
            warnings.warn(f"{where}: saved with Stable-Baselines3 {saved_sb3}, newer than the installed "
                          f"{stable_baselines3.__version__}", stacklevel=3)
    except InvalidVersion:
        warnings.warn(f"{where}: _stable_baselines3_version: expected a version, found {saved_sb3!r}", stacklevel=3)
    params = [p for p in inspect.signature(cls.__init__).parameters
              if p not in ("self", "policy", "env", "expert_data", "device", "_init_setup_model", "tensorboard_log",
                           "verbose")]
    missing = [p for p in params if p not in data]
    if missing:
        warnings.warn(f"{where}: the zip has no {missing}: loaded with {cls.__name__}'s defaults for them, which may "
                      "not be what it was trained with (a zip of an older version?)", stacklevel=3)


def warn_unknown_entries(model, raw: bytes, where: str) -> None:
    """Warn about entries of the zip's ``data`` that a model of this class, built with the same spaces, does not have
    (a hyperparameter of another version: set on the model, but nothing here reads it)."""
    import gymnasium as gym
    import torch as th

    class Spaces(gym.Env):
        observation_space, action_space = model.observation_space, model.action_space

    with zipfile.ZipFile(io.BytesIO(raw)) as archive:
        keys = list(json.loads(archive.read("data")))
    state = np.random.get_state()
    with th.random.fork_rng(), warnings.catch_warnings():  # the probe's initialisation draws nothing of the caller's
        warnings.simplefilter("ignore")
        probe = type(model)(policy="MlpPolicy", env=Spaces())
    np.random.set_state(state)
    unknown = sorted(k for k in keys if k not in probe.__dict__ and k != "policy_class")
    if unknown:
        warnings.warn(f"{where}: entries {unknown} are unknown to {type(model).__name__} (a zip of another "
                      "version?): they are set on the model, but nothing here reads them", stacklevel=3)
