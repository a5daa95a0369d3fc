"""Wall time of MBIL (flow fitting and policy updates, separately) against BC on the same data."""

from __future__ import annotations

import statistics
import time
from typing import Any

import torch as th

from sb3_mbil.bc import BC
from sb3_mbil.common.demonstrations import ExpertData
from sb3_mbil.mbil import MBIL


def measure_speed(env_id: str, expert_data: ExpertData, steps: int = 2000, repeats: int = 3, seed: int = 0,
                  mbil_kwargs: dict[str, Any] | None = None, bc_kwargs: dict[str, Any] | None = None,
                  budget: int = 10_000) -> dict[str, Any]:
    """Time ``steps`` policy updates of MBIL and BC, interleaved ``repeats`` times; report medians and ratios.

    ``total_ratio`` is MBIL's flow fitting plus ``budget`` updates over BC's ``budget`` updates.
    """
    th.set_num_threads(1)
    mbil = MBIL("MlpPolicy", env_id, expert_data=expert_data, seed=seed, **(mbil_kwargs or {}))
    t0 = time.perf_counter()
    mbil.fit_flows()
    fit = time.perf_counter() - t0
    bc = BC("MlpPolicy", env_id, expert_data=expert_data, seed=seed, **(bc_kwargs or {}))
    times: dict[str, list[float]] = {"mbil": [], "bc": []}
    for _ in range(repeats):
        for name, model in (("mbil", mbil), ("bc", bc)):
            t0 = time.perf_counter()
            model.learn(steps, reset_num_timesteps=False, log_interval=-1)
            times[name].append(time.perf_counter() - t0)
    mbil_s, bc_s = statistics.median(times["mbil"]), statistics.median(times["bc"])
    return {
        "env": env_id,
        "n_tuples": mbil.flow_report["n_tuples"],
        "steps": steps,
        "flow_fit_seconds": round(fit, 2),
        # CPU seconds of each model's fit (noise levels tried, early stopping, refit): where the fitting time goes
        "transition_fit_cpu_seconds": round(mbil.flow_report["transition"]["seconds"], 2),
        "next_action_fit_cpu_seconds": round(mbil.flow_report["next_action"]["seconds"], 2),
        "mbil_policy_seconds": round(mbil_s, 3),
        "bc_seconds": round(bc_s, 3),
        "mbil_ms_per_update": round(1000 * mbil_s / steps, 4),
        "bc_ms_per_update": round(1000 * bc_s / steps, 4),
        "policy_update_ratio": round(mbil_s / bc_s, 3),
        "budget": budget,
        "total_ratio": round((fit + mbil_s * budget / steps) / (bc_s * budget / steps), 3),
    }
