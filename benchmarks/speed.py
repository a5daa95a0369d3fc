"""Wall time of an algorithm of :data:`sb3_mbil.ALGORITHMS` (its set-up, e.g. MBIL's flow fitting, and its
updates, separately) against BC on the same data, measured side by side in one process."""

from __future__ import annotations

import statistics
import time
from typing import Any

import torch as th

from sb3_mbil.common.demonstrations import ExpertData


def measure_speed(env_id: str, expert_data: ExpertData, steps: int = 2000, repeats: int = 3, seed: int = 0,
                  algo: str = "mbil", algo_kwargs: dict[str, Any] | None = None, bc_kwargs: dict[str, Any] | None = None,
                  budget: int = 10_000) -> dict[str, Any]:
    """Time ``steps`` updates of ``algo`` and of BC, interleaved ``repeats`` times; report medians and ratios.

    ``setup_seconds`` is what the algorithm does once before its updates (``learn(0)``: MBIL fits its flows
    there). ``total_ratio`` is the set-up plus ``budget`` updates over BC's ``budget`` updates.
    """
    from sb3_mbil import ALGORITHMS, BC

    if algo not in ALGORITHMS:
        raise ValueError(f"algo: expected one of {sorted(ALGORITHMS)}, found {algo!r}")
    th.set_num_threads(1)
    model = ALGORITHMS[algo]("MlpPolicy", env_id, expert_data=expert_data, seed=seed, **(algo_kwargs or {}))
    t0 = time.perf_counter()
    model.learn(0)
    setup = time.perf_counter() - t0
    bc = BC("MlpPolicy", env_id, expert_data=expert_data, seed=seed, **(bc_kwargs or {}))
    bc.learn(0)
    times: dict[str, list[float]] = {"algo": [], "bc": []}
    for _ in range(repeats):
        for name, m in (("algo", model), ("bc", bc)):
            t0 = time.perf_counter()
            m.learn(steps, reset_num_timesteps=False, log_interval=-1)
            times[name].append(time.perf_counter() - t0)
    algo_s, bc_s = statistics.median(times["algo"]), statistics.median(times["bc"])
    out: dict[str, Any] = {"env": env_id, "algo": algo, "n_pairs": len(model.expert_pairs().observations), "steps": steps,
                           "setup_seconds": round(setup, 2)}
    report = getattr(model, "flow_report", None)
    if report is not None:  # MBIL: where the fitting time goes (CPU seconds of each model's fit)
        out.update(n_tuples=report["n_tuples"],
                   transition_fit_cpu_seconds=round(report["transition"]["seconds"], 2) if report["transition"] else 0.0,
                   next_action_fit_cpu_seconds=round(report["next_action"]["seconds"], 2))
    out.update(
        algo_seconds=round(algo_s, 3),
        bc_seconds=round(bc_s, 3),
        algo_ms_per_update=round(1000 * algo_s / steps, 4),
        bc_ms_per_update=round(1000 * bc_s / steps, 4),
        policy_update_ratio=round(algo_s / bc_s, 3),
        budget=budget,
        total_ratio=round((setup + algo_s * budget / steps) / (bc_s * budget / steps), 3),
    )
    return out
