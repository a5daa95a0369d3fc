"""The data protocols of the benchmark.

- ``full``: every step of each drawn trajectory (ours; the MBIL paper's own protocol for MBIL).
- ``published``: what the published classic-control baseline curves used, i.e. each baseline's own code's data
  handling. BC, EDM and RCAL keep every 20th step (EDM's code). IQ-Learn keeps every 20th step on CartPole and every
  5th on Acrobot and LunarLander (its scripts). AVRIL keeps full trajectories. So does ValueDICE: the published
  comparison ran the google-research ``value_dice`` code (CKIL's appendix C.1), whose ``data_utils`` draws whole
  trajectories and keeps every step (our rows before this used BC's rate). So does DSFN: the comparison ran
  dtak/batch-apprenticeship-learning (CKIL's appendix C.6), which keeps every step (its two data bugs are not
  copied; see :class:`sb3_mbil.DSFN`). For these, ``published`` holds the same data as ``full``, the trajectories
  whole. MBIL and its variants use the same kept steps as BC, each with its true successor (s', a'). Each
  trajectory's subsampling starts at its own random step, as in the GAIL codes' ``ExpertDataset`` (IQ-Learn's at
  step 0, as in its code). EDM's code also starts at step 0, on trajectories that its PPO and A2C experts recorded
  with sampled actions. Our pools hold the experts' deterministic actions, and from step 0
  their kept states of Acrobot-v1 sit at one phase of the swing in every trajectory, so BC never swings up. Random
  starts stand in for the spread that sampled actions give (``results/tuning/subsample_offset_sampled.csv``).
- ``published_next``: a control for ``published``: each kept step and its next step, both as labelled (s, a) pairs,
  so that BC sees the labels MBIL gets from the successors (s', a'); MBIL then also gets the next step's tuple.

The protocols draw the same N trajectories for a seed (``Demonstrations.sample(N, seed)``); the published codes took
the first N, or the block of N starting at the seed, which we do not copy: the draw is part of the comparison.
"""

from __future__ import annotations

from sb3_mbil.common.demonstrations import Demonstrations, load_demonstrations
from sb3_mbil.common.validation import check_choice

PROTOCOLS = ("full", "published", "published_next")

#: keep every k-th step on the ``published`` protocol: per algorithm, one rate or a rate per env
PUBLISHED_EVERY: dict[str, int | dict[str, int]] = {
    "bc": 20, "edm": 20, "rcal": 20,
    "iq_learn": {"CartPole-v1": 20, "Acrobot-v1": 5, "LunarLander-v3": 5},
    "avril": 1, "valuedice": 1, "dsfn": 1,
}
#: the default for algorithms not listed (MBIL and its variants): BC's rate
DEFAULT_EVERY = 20
#: where each trajectory's subsampling starts: "random" (its own step in [0, every), drawn with the run's seed: the
#: GAIL codes' ExpertDataset) or 0 (IQ-Learn's code, whose random start is commented out; EDM's code, on a sampled-action
#: expert). On Acrobot-v1 BC from step 0 scores -500 and from random steps -77 to -155, the published -94 to -159
#: (results/tuning/subsample_offset.csv)
PUBLISHED_START: dict[str, int | str] = {"iq_learn": 0}
DEFAULT_START = "random"


def published_every(algo: str, env_id: str) -> int:
    """The step rate of ``algo`` on ``env_id`` in the published protocol (1 = full trajectories)."""
    rate = PUBLISHED_EVERY.get(algo, DEFAULT_EVERY)
    return int(rate.get(env_id, DEFAULT_EVERY)) if isinstance(rate, dict) else int(rate)


def published_start(algo: str) -> int | str:
    """Where ``algo``'s subsampling starts in each trajectory on the ``published`` protocol (0 or ``"random"``)."""
    return PUBLISHED_START.get(algo, DEFAULT_START)


def same_data(algo: str, env_id: str, protocol_a: str, protocol_b: str) -> bool:
    """Whether ``algo`` trains on the same data on ``env_id`` under two protocols (for a seed and pool): the same
    protocol, or whole trajectories under both (``full``, and ``published`` at a rate of 1: AVRIL, ValueDICE, DSFN).
    Such runs are the same run: the grid can reuse one protocol's row for the other (:func:`benchmarks.harness.runner.reuse_rows`)."""
    for p in (protocol_a, protocol_b):
        check_choice("protocol", p, PROTOCOLS)
    return protocol_a == protocol_b or (keeps_whole(algo, env_id, protocol_a) and keeps_whole(algo, env_id, protocol_b))


def keeps_whole(algo: str, env_id: str, protocol: str) -> bool:
    """Whether ``algo`` trains on whole trajectories on ``env_id`` under ``protocol`` (``full``, or ``published`` at a
    rate of 1)."""
    return protocol == "full" or (protocol == "published" and published_every(algo, env_id) == 1)


def demonstrations_for(algo: str, env_id: str, n_trajectories: int, seed: int, protocol: str = "full",
                       pool: str | None = None) -> Demonstrations:
    """The data one benchmark run trains on: N trajectories drawn with ``seed`` from the pool (the env's shipped
    pool by default), whole (``full``) or subsampled at the algorithm's published rate (``published``)."""
    protocol = check_choice("protocol", protocol, PROTOCOLS)
    demos = load_demonstrations(pool or env_id).sample(n_trajectories, seed=seed)
    if keeps_whole(algo, env_id, protocol):
        # whole trajectories, not one-step pieces: DSFN's feature expectations run over each trajectory's steps
        return demos
    return demos.subsample(published_every(algo, env_id), published_start(algo), with_next=protocol == "published_next",
                           seed=seed)
