"""Stochastic demonstrators: BC, BC at its best (BC*), MBIL and MBIL-C on pools of sampled or noisy actions.

Not part of the installed package: a study that imports ``sb3_mbil`` like any user code.

A *variant* is an algorithm with settings on top of its zoo entry (``zoo_hyperparams/<algo>.yml``) and, optionally,
one of two regularisers that are not constructor settings:

* ``early_stop``: :class:`sb3_mbil.common.heldout.ValidationCallback` holds out 20% of the data in blocks of 50 steps,
  scores the behaviour-cloning loss (held-out NLL, or MSE for a Box policy trained on MSE) every 500 updates, and
  the best parameters are put back at the end (the model trains on the other 80%);
* ``ensemble``: k members trained with seeds ``seed + 10_000 j`` (j = 0..k-1) on the same draw; the ensemble acts
  with the mean of the members' action probabilities (Discrete, then its argmax) or of their mean actions (Box).

Every variant is tried with the same budget (:data:`TUNING_BUDGET`) on tuning seeds >= 100; the best per
(algorithm, env, pool, N) by mean return is that algorithm's tuned variant (BC's is called BC*), reported on seeds 0-9.
"""

from __future__ import annotations

import argparse
import csv
import functools
import json
import os
import time
from dataclasses import asdict, dataclass, field
from collections.abc import Iterator
from typing import Any

import gymnasium as gym
import numpy as np
import torch as th

from sb3_mbil import ALGORITHMS
from benchmarks.harness.cli import parse_seeds, positive_int
from benchmarks.harness.grid import git_commit, tuned_settings
from benchmarks.harness.results import append_rows, finished_keys
from sb3_mbil.common.demonstrations import load_demonstrations
from sb3_mbil.common.evaluation import evaluate
from sb3_mbil.common.heldout import ValidationCallback
from stable_baselines3.common.callbacks import BaseCallback

COLUMNS = ["variant", "algo", "env", "pool", "n_trajectories", "seed", "mean_return", "std_return", "n_episodes",
           "train_seconds", "best_step", "settings", "commit"]
CURVE_COLUMNS = [*COLUMNS, "curve"]  # the curves' CSVs: each row's learning curve, JSON [[update, mean return], ...]
KEY = ("variant", "env", "pool", "n_trajectories", "seed")


@dataclass(frozen=True)
class Variant:
    """An algorithm, settings over its zoo entry, and the regularisers outside its constructor."""

    algo: str
    settings: dict[str, Any] = field(default_factory=dict)
    early_stop: bool = False
    ensemble: int = 1

    def describe(self) -> str:
        return json.dumps({**asdict(self)}, sort_keys=True)


def _discrete(env_id: str) -> bool:
    return isinstance(gym.make(env_id).action_space, gym.spaces.Discrete)


def variants_for(env_id: str) -> dict[str, Variant]:
    """:func:`_variants_for`, read once per env (the report asks for it per row; each read parses the zoo files)."""
    return dict(_variants_for(env_id))


@functools.lru_cache(maxsize=None)
def _variants_for(env_id: str) -> dict[str, Variant]:
    """The tuning grid of an env's action space: for each algorithm the same number of configurations (the budget).

    Every algorithm: its zoo entry, weight decay at the values of {0, 1e-3, 1e-2} other than the entry's (two for
    Discrete, the first for Box), early stopping, a 5-member ensemble, and two settings of the algorithm's own (BC:
    Gaussian input noise 0.1 and 0.3 in units of the states' std; MBIL and MBIL-C: alpha 0.3 and 3). Box: the
    Gaussian NLL with a state-dependent std (``bc_loss="nll"``) in place of the second weight decay.
    """
    discrete = _discrete(env_id)
    out: dict[str, Variant] = {}
    for algo in TUNED_ALGOS:
        zoo_wd = float(tuned_settings(algo, env_id).get("weight_decay", 0.0))
        wds = [w for w in (0.0, 1e-3, 1e-2) if w != zoo_wd][: 2 if discrete else 1]
        own = ({"observation_noise": 0.1}, {"observation_noise": 0.3}) if algo == "bc" else ({"alpha": 0.3}, {"alpha": 3.0})
        out[algo] = Variant(algo)
        for w in wds:
            out[f"{algo}_wd{w:g}"] = Variant(algo, {"weight_decay": w})
        if not discrete:
            out[f"{algo}_nll"] = Variant(algo, {"bc_loss": "nll"})
        out[f"{algo}_es"] = Variant(algo, early_stop=True)
        out[f"{algo}_ens5"] = Variant(algo, ensemble=5)
        for o in own:
            (k, v), = o.items()
            out[f"{algo}_{'noise' if k == 'observation_noise' else k}{v:g}"] = Variant(algo, o)
    return out


TUNED_ALGOS = ("bc", "mbil", "mbil_c")


def baseline_variants(env_id: str) -> dict[str, Variant]:
    """Every other algorithm of :data:`sb3_mbil.ALGORITHMS` that supports the env's action space and has a zoo entry
    for it, at that entry (named after the algorithm): the paper's baselines on the same draws, untuned."""
    from benchmarks.harness.grid import has_zoo_entry

    space = type(gym.make(env_id).action_space)
    return {name: Variant(name) for name, cls in ALGORITHMS.items()
            if name not in TUNED_ALGOS and space in cls.supported_action_spaces and has_zoo_entry(name, env_id)}


#: settings outside the tuning grid, run on the grid's seeds to test a claim, never picked as a tuned variant. BC's
#: Gaussian NLL trained for 5 000 updates instead of its zoo entry's 50 000: on Walker2d-v4's one sampled trajectory
#: BC's return peaks within the first 5 000 updates and falls after, which its held-out loss does not see (bc_es), so
#: the grid's budget may hand the family a lead that is BC's overfitting. Chosen among 2 000 and 5 000 updates of MSE
#: and 5 000 of the NLL on tuning seeds 100-109 (``python -m benchmarks.balance_ablation``: bc_2k, bc_5k, bc_nll_5k).
#: Box envs only (the NLL is the Gaussian's).
PROBES = {"bc_nll_5k": Variant("bc", {"bc_loss": "nll", "n_timesteps": 5000})}


def all_variants(env_id: str) -> dict[str, Variant]:
    """The tuning grid (:func:`variants_for`), the baselines (:func:`baseline_variants`) and the :data:`PROBES`."""
    return {**variants_for(env_id), **baseline_variants(env_id), **({} if _discrete(env_id) else PROBES)}


#: configurations per algorithm and tuning seeds: the one tuning budget every algorithm gets
TUNING_SEEDS = (100, 101, 102)
TUNING_BUDGET = "7 configurations x 3 tuning seeds (100-102) per algorithm, env, pool and N"


class EnsemblePolicy:
    """Acts with the mean of k trained models: their action probabilities (Discrete) or mean actions (Box)."""

    def __init__(self, models: list):
        self.models = models
        self.policy = models[0].policy
        self.discrete = isinstance(self.policy.action_space, gym.spaces.Discrete)

    def predict(self, observation, state=None, episode_start=None, deterministic: bool = True):
        obs, vectorized = self.policy.obs_to_tensor(observation)
        with th.no_grad():
            if self.discrete:
                probs = th.stack([th.softmax(m.policy.logits(obs), dim=-1) for m in self.models]).mean(0)
                actions = probs.argmax(dim=1).cpu().numpy()
            else:
                actions = th.stack([m.policy.mean_action(obs) for m in self.models]).mean(0).cpu().numpy()
                actions = np.clip(actions, self.policy.action_space.low, self.policy.action_space.high)
        return (actions if vectorized else actions[0]), None


@dataclass(frozen=True)
class Curve:
    """Figure 4's protocol: the greedy policy scored every ``every`` updates on ``episodes`` episodes."""

    every: int = 500
    episodes: int = 10


class CurveCallback(BaseCallback):
    """Scores a seed's policy (the mean of its ensemble's members, all at the same update in lockstep) every
    ``curve.every`` updates; episode i of the point at update k is reset with seed 2 000 000 + 1 000 * seed + i."""

    def __init__(self, members: list, env_id: str, curve: Curve, seed: int):
        super().__init__()
        self.members, self.env_id, self.curve, self.run_seed = members, env_id, curve, seed
        self.points: list[list] = []

    def _on_step(self) -> bool:
        step = self.model.num_timesteps
        if step % self.curve.every == 0:
            policy = self.members[0] if len(self.members) == 1 else EnsemblePolicy(self.members)
            returns = evaluate(policy, self.env_id, self.curve.episodes, seed=2_000_000 + 1_000 * self.run_seed,
                               n_envs=self.curve.episodes)
            self.points.append([step, round(float(returns.mean()), 2)])
        return True


def draw(env_id: str, pool: str, n_trajectories: int, seed: int):
    """The N trajectories a run of ``seed`` trains on: drawn from ``pool`` (a shipped pool name or a ``.npz``)."""
    return load_demonstrations(pool).sample(n_trajectories, seed=seed)


def _early_stop(variant: Variant, seed: int) -> ValidationCallback | None:
    if not variant.early_stop:
        return None
    return ValidationCallback(holdout_fraction=0.2, eval_freq=500, block_length=50, monitor="bc_loss",
                              restore_best=True, seed=seed)


def train_variant(variant: Variant, env_id: str, demos, seed: int, curve: Curve | None = None) -> tuple[Any, int | None]:
    """Train one variant on ``demos``; returns something with ``predict`` and the best step of early stopping (with
    ``curve``, the model's ``curve`` attribute holds the learning curve's points)."""
    if curve is not None and variant.ensemble > 1:
        raise ValueError("curve: the learning curve of an ensemble is scored in lockstep (train_variant_lockstep)")
    settings = tuned_settings(variant.algo, env_id, variant.settings)
    steps = int(float(settings.pop("n_timesteps")))
    models, best_step = [], None
    for j in range(variant.ensemble):
        model = ALGORITHMS[variant.algo]("MlpPolicy", env_id, expert_data=demos, seed=seed + 10_000 * j, **settings)
        stopper = _early_stop(variant, seed)
        scorer = CurveCallback([model], env_id, curve, seed) if curve is not None else None
        model.learn(steps, callback=[c for c in (stopper, scorer) if c is not None])  # SB3 makes a list one callback
        if stopper is not None:
            best_step = stopper.best_step
        if scorer is not None:
            model.curve = scorer.points
        models.append(model)
    return (models[0] if len(models) == 1 else EnsemblePolicy(models)), best_step


def train_variant_lockstep(variant: Variant, env_id: str, draws: dict[int, Any],
                           curve: Curve | None = None) -> dict[int, tuple[Any, int | None]]:
    """:func:`train_variant` for several seeds (``draws``: seed -> its data) at once: every seed's models (and every
    ensemble member) trained in lockstep (:func:`sb3_mbil.learn_lockstep`), each bit for bit its separate run, early
    stopping's callback one per model. An algorithm that cannot train in lockstep trains seed by seed."""
    from sb3_mbil import learn_lockstep

    settings = tuned_settings(variant.algo, env_id, variant.settings)
    steps = int(float(settings.pop("n_timesteps")))
    members = [(seed, j) for seed in draws for j in range(variant.ensemble)]
    models = [ALGORITHMS[variant.algo]("MlpPolicy", env_id, expert_data=draws[seed], seed=seed + 10_000 * j, **settings)
              for seed, j in members]
    if not models[0].supports_lockstep():
        return {seed: train_variant(variant, env_id, demos, seed, curve) for seed, demos in draws.items()}
    stoppers = [_early_stop(variant, seed) for seed, _ in members]
    scorers: list[CurveCallback | None] = [None] * len(members)
    if curve is not None:  # on each seed's last member: at its callback every member has made the same updates
        for seed in draws:
            mine = [k for k, (s, _) in enumerate(members) if s == seed]
            scorers[mine[-1]] = CurveCallback([models[k] for k in mine], env_id, curve, seed)
    learn_lockstep(models, steps, callbacks=[[c for c in pair if c is not None] for pair in zip(stoppers, scorers)])
    out = {}
    for seed in draws:
        mine = [k for k, (s, _) in enumerate(members) if s == seed]
        best_step = stoppers[mine[-1]].best_step if variant.early_stop else None  # the last member's, as train_variant
        group = [models[k] for k in mine]
        policy = group[0] if len(group) == 1 else EnsemblePolicy(group)
        if curve is not None:
            policy.curve = scorers[mine[-1]].points
        out[seed] = policy, best_step
    return out


def run_cell(name: str, variant: Variant, env_id: str, pool: str, n_trajectories: int, seed: int,
             n_episodes: int, commit: str, curve: Curve | None = None) -> dict[str, Any]:
    """One seed's run and its row (with ``curve``, its learning curve in the row's ``curve`` column, and
    ``train_seconds`` including the curve's evaluations)."""
    th.set_num_threads(1)
    demos = draw(env_id, pool, n_trajectories, seed)
    t0 = time.perf_counter()
    policy, best_step = train_variant(variant, env_id, demos, seed, curve)
    return _row(name, variant, env_id, pool, n_trajectories, seed, policy, best_step, time.perf_counter() - t0,
                n_episodes, commit)


def lockstep_ready(variant: Variant, env_id: str, demos) -> bool:
    """Whether the variant's algorithm trains in lockstep on this env (a model built to ask, never trained)."""
    settings = tuned_settings(variant.algo, env_id, variant.settings)
    settings.pop("n_timesteps")
    return ALGORITHMS[variant.algo]("MlpPolicy", env_id, expert_data=demos, seed=0, **settings).supports_lockstep()


def run_cell_lockstep(name: str, variant: Variant, env_id: str, pool: str, n_trajectories: int, seeds: list[int],
                      n_episodes: int, commit: str, curve: Curve | None = None) -> Iterator[dict[str, Any]]:
    """:func:`run_cell` for several seeds, trained in lockstep; each seed's row is its own run's, but
    ``train_seconds`` is the seeds' training time divided among them. An algorithm that cannot train in lockstep
    runs seed by seed, each row yielded as its run ends."""
    th.set_num_threads(1)
    draws = {seed: draw(env_id, pool, n_trajectories, seed) for seed in seeds}
    if not lockstep_ready(variant, env_id, draws[seeds[0]]):
        for seed in seeds:
            yield run_cell(name, variant, env_id, pool, n_trajectories, seed, n_episodes, commit, curve)
        return
    t0 = time.perf_counter()
    trained = train_variant_lockstep(variant, env_id, draws, curve)
    share = (time.perf_counter() - t0) / len(seeds)
    for seed in seeds:
        yield _row(name, variant, env_id, pool, n_trajectories, seed, *trained[seed], share, n_episodes, commit)


def _row(name, variant, env_id, pool, n_trajectories, seed, policy, best_step, train_seconds, n_episodes, commit):
    returns = evaluate(policy, env_id, n_episodes, seed=1_000_000 + seed, n_envs=20)
    row = {"variant": name, "algo": variant.algo, "env": env_id, "pool": pool, "n_trajectories": n_trajectories,
           "seed": seed, "mean_return": float(returns.mean()), "std_return": float(returns.std()),
           "n_episodes": len(returns), "train_seconds": round(train_seconds, 1),
           "best_step": "" if best_step is None else best_step, "settings": variant.describe(), "commit": commit}
    if getattr(policy, "curve", None) is not None:
        row["curve"] = json.dumps(policy.curve)
    return row


def pending_cells(csv_path: str, env_id: str, pools: list[str], n_trajectories: list[int], variants: list[str],
                  seeds: list[int]) -> Iterator[tuple[str, int, str, list[int]]]:
    """(pool, N, variant, the seeds whose row is not yet in ``csv_path``) for every cell with a seed to run, in order
    (the probes on tuning seeds resume with it)."""
    done = finished_keys(csv_path, KEY)
    for pool in pools:
        for n in n_trajectories:
            for name in variants:
                todo = [s for s in seeds if (name, env_id, pool, str(n), str(s)) not in done]
                if todo:
                    yield pool, n, name, todo


def best_variants(rows: list[dict], env_id: str, pool: str, n_trajectories: int) -> dict[str, str]:
    """Per algorithm, the variant with the highest mean return over the tuning rows of (env, pool, N); only variants
    with as many seeds as the most-run one compete (a variant still running is not picked on fewer seeds). A tie (at
    a ceiling, e.g. CartPole-v1's 500) goes to the algorithm's zoo entry (the variant named after it), then to the
    variant that ran first."""
    scores: dict[str, list[float]] = {}
    for r in rows:
        if (r["env"], r["pool"], int(r["n_trajectories"])) == (env_id, pool, n_trajectories):
            scores.setdefault(r["variant"], []).append(float(r["mean_return"]))
    if not scores:
        return {}
    most = max(len(v) for v in scores.values())
    table = variants_for(env_id)
    best: dict[str, tuple[float, str]] = {}
    for name, values in scores.items():
        if len(values) == most and name in table:
            algo = table[name].algo
            mean = float(np.mean(values))
            if algo not in best or mean > best[algo][0] or (mean == best[algo][0] and name == algo):
                best[algo] = (mean, name)
    return {algo: name for algo, (_, name) in best.items()}


def run(variants: list[str], env_id: str, pools: list[str], n_trajectories: list[int], seeds: list[int],
        n_episodes: int, csv_path: str, tuned_from: str | None = None, tuning_pool: str | None = None,
        tuned_algos: list[str] | None = None, lockstep: bool = False, curve: Curve | None = None,
        lockstep_models: int | None = None) -> None:
    """Every (variant, pool, N, seed) whose row is not yet in ``csv_path``, seed-major; one row appended per run.
    ``curve``: each run also records its learning curve (Figure 4; the rows' ``curve`` column, :data:`CURVE_COLUMNS`).

    ``tuned_from``: a tuning CSV; each algorithm's best variant there for (env, pool, N) runs too (the pool's own
    tuning, or ``tuning_pool``'s when given); ``tuned_algos``: only these algorithms' best variants. ``lockstep``:
    the pending seeds of each (variant, pool, N) train together (:func:`run_cell_lockstep`), cell after cell; the
    rows are the same. ``lockstep_models``: at most this many models in one lockstep group (seeds x ensemble
    members, at least one seed), so that a long cell (an ensemble's) appends its rows group by group and a stopped
    run loses one group at most.
    """
    from benchmarks.harness.results import read_result_rows

    table = all_variants(env_id)
    unknown = [v for v in variants if v not in table]
    if unknown:
        raise ValueError(f"variants: expected names from {sorted(table)}, found {unknown}")
    if curve is not None and os.path.exists(csv_path) and os.path.getsize(csv_path):
        with open(csv_path, newline="") as f:
            header = next(csv.reader(f), [])
        if "curve" not in header:
            raise ValueError(f"csv: expected a file with a 'curve' column to record learning curves in, found "
                             f"{csv_path} with columns {header}")
    if lockstep_models is not None and lockstep_models < 1:
        raise ValueError(f"lockstep_models: expected a positive number of models or None, found {lockstep_models}")
    tuning = read_result_rows(tuned_from) if tuned_from else []
    done = finished_keys(csv_path, KEY)
    commit = git_commit()

    def names(pool: str, n: int) -> list[str]:
        best = best_variants(tuning, env_id, tuning_pool or pool, n) if tuned_from else {}
        if tuned_algos is not None:
            best = {algo: name for algo, name in best.items() if algo in tuned_algos}
        if tuned_from and not best:
            raise ValueError(f"tuned_from: expected tuning rows of {env_id}, {tuning_pool or pool}, N={n} in "
                             f"{tuned_from}, found none")
        return list(dict.fromkeys([*variants, *best.values()]))

    def report(row: dict) -> None:
        append_rows(csv_path, [row], CURVE_COLUMNS)  # a new file's header; an existing file keeps its own
        print(f"{row['variant']} {env_id} {row['pool']} N={row['n_trajectories']} seed={row['seed']}: "
              f"{row['mean_return']:.1f} ({row['train_seconds']} s)", flush=True)

    if lockstep:
        for pool in pools:
            for n in n_trajectories:
                for _, _, name, todo in pending_cells(csv_path, env_id, [pool], [n], names(pool, n), seeds):
                    size = len(todo) if lockstep_models is None else max(1, lockstep_models // table[name].ensemble)
                    for start in range(0, len(todo), size):
                        group = todo[start:start + size]
                        for row in run_cell_lockstep(name, table[name], env_id, pool, n, group, n_episodes, commit,
                                                     curve):
                            report(row)
        return
    for seed in seeds:
        for pool in pools:
            for n in n_trajectories:
                for name in names(pool, n):
                    if (name, env_id, pool, str(n), str(seed)) not in done:
                        report(run_cell(name, table[name], env_id, pool, n, seed, n_episodes, commit, curve))


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--env", required=True)
    parser.add_argument("--pools", nargs="+", required=True, help="shipped pool names or .npz paths")
    parser.add_argument("--variants", nargs="+", required=True,
                        help="names from all_variants(env); 'all': the tuning grid of BC, MBIL and MBIL-C; "
                             "'baselines': every other algorithm at its zoo entry")
    parser.add_argument("--n-trajectories", type=int, nargs="+", default=[1])
    parser.add_argument("--seeds", type=parse_seeds, default=list(TUNING_SEEDS))
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--csv", required=True)
    parser.add_argument("--tuned-from", default=None, help="tuning CSV: also run each algorithm's best variant")
    parser.add_argument("--tuning-pool", default=None, help="with --tuned-from: the pool whose tuning picks them")
    parser.add_argument("--tuned-algos", nargs="+", default=None, help="with --tuned-from: only these algorithms")
    parser.add_argument("--curve-every", type=positive_int, default=None, metavar="K",
                        help="also score each run every K updates (Figure 4: 500) on --curve-episodes episodes")
    parser.add_argument("--curve-episodes", type=positive_int, default=10)
    parser.add_argument("--lockstep", action="store_true",
                        help="train the pending seeds of each (variant, pool, N) together (sb3_mbil.learn_lockstep; "
                             "the same rows, cell after cell)")
    parser.add_argument("--lockstep-models", type=positive_int, default=None, metavar="M",
                        help="with --lockstep: at most M models (seeds x ensemble members) train together; a cell's "
                             "rows are appended group by group")
    args = parser.parse_args(argv)
    expand = {"all": sorted(variants_for(args.env)), "baselines": sorted(baseline_variants(args.env))}
    variants = [name for v in args.variants for name in expand.get(v, [v])]
    run(variants, args.env, args.pools, args.n_trajectories, args.seeds, args.episodes, args.csv, args.tuned_from,
        args.tuning_pool, args.tuned_algos, args.lockstep,
        Curve(args.curve_every, args.curve_episodes) if args.curve_every else None, args.lockstep_models)


if __name__ == "__main__":
    main()
