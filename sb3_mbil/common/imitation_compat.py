"""Converters between :class:`~sb3_mbil.Demonstrations` and the ``imitation`` library's trajectory types.

``imitation`` pins old gymnasium and SB3 releases, so it cannot be installed beside this package and is no extra of
ours: the converters are duck-typed. ``from_imitation`` needs only objects with imitation's fields (``obs``,
``acts``, ``terminal`` and, optionally, ``rews``); ``to_imitation`` builds imitation's ``Trajectory`` where imitation
is importable, or any class with those fields passed as ``trajectory_class``.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np

from sb3_mbil.common.demonstrations import Demonstrations, Trajectory


def from_imitation(trajectories: Iterable[Any], metadata: dict | None = None) -> Demonstrations:
    """imitation ``Trajectory``/``TrajectoryWithRew`` (obs has the final observation) -> Demonstrations."""
    out = []
    for i, t in enumerate(trajectories):
        for field in ("obs", "acts", "terminal"):
            if not hasattr(t, field):
                raise ValueError(f"trajectories[{i}]: expected an imitation Trajectory with '{field}', found {type(t).__name__}")
        obs, acts = np.asarray(t.obs), np.asarray(t.acts)
        if len(obs) != len(acts) + 1:
            raise ValueError(f"trajectories[{i}].obs: expected {len(acts) + 1} rows (acts + 1), found {len(obs)}")
        rews = getattr(t, "rews", None)
        ret = float(np.sum(rews)) if rews is not None else float("nan")
        terminal = bool(t.terminal)
        out.append(Trajectory(obs, acts, terminated=terminal, truncated=not terminal, episode_return=ret))
    return Demonstrations(out, {"source": "imitation", **(metadata or {})})


def to_imitation(demos: Demonstrations, trajectory_class: type | None = None) -> list:
    """Demonstrations -> list of imitation ``Trajectory`` (per-step rewards are not stored by us).

    Trajectories without their final observation cannot be converted (imitation requires it).
    """
    if trajectory_class is None:
        try:
            from imitation.data.types import Trajectory as trajectory_class
        except ImportError as e:
            raise ImportError("to_imitation needs the imitation library's Trajectory, which cannot be installed beside "
                              "this package (it pins an older gymnasium): pass trajectory_class, a class with its "
                              "fields obs, acts, infos, terminal") from e
    out = []
    for i, t in enumerate(demos):
        if not t.has_final_observation:
            raise ValueError(f"trajectories[{i}].observations: expected the final next observation (T + 1 rows), found T")
        out.append(trajectory_class(obs=t.observations, acts=t.actions, infos=None, terminal=t.terminated))
    return out
