"""EDM: energy-based distribution matching (Jarrett, Bica, van der Schaar, NeurIPS 2020), strictly offline."""

from __future__ import annotations

from typing import Any, ClassVar

import torch as th
from gymnasium import spaces
from stable_baselines3.common.type_aliases import GymEnv, Schedule
from torch import nn

from sb3_mbil.common.demonstrations import ExpertData
from sb3_mbil.common.offline import OfflineAlgorithm
from sb3_mbil.common.policies import ImitationPolicy
from sb3_mbil.common.validation import check_int, check_real
from sb3_mbil.edm.policies import SGLDBuffer


class EDM(OfflineAlgorithm):
    """Energy-based distribution matching.

    Paper: "Strictly Batch Imitation Learning by Energy-based Distribution Matching" (Jarrett, Bica and
    van der Schaar, NeurIPS 2020). Discrete actions.

    One network f(s) gives the logits: the policy is pi(a|s) = softmax(f(s))[a] and the same logits
    define an energy-based model of the expert's state distribution, rho(s) ~ exp(LSE_a f(s)). The loss
    per minibatch of expert pairs (s, a) is

        L = CE(f(s), a) + L_rho + L_rho^2,    L_rho = E_{x ~ SGLD}[LSE f(x)] - E_{s ~ D}[LSE f(s)]

    (``energy_weight`` multiplies both L_rho terms). The samples x come from persistent SGLD chains
    (JEM): each step takes ``batch_size`` chains from a buffer of ``sgld_buffer_size``, restarts each
    from U[-1, 1]^d with probability ``sgld_reinit_prob``, runs ``sgld_steps`` steps of
    x <- x + ``sgld_step_size`` * grad_x LSE f(x) + ``sgld_noise`` * N(0, I) and writes them back.

    Deviation from the reference code: the chains live in standardised coordinates (the expert states'
    mean and std); the reference draws raw states from U[-1, 1]^d, which does not cover CartPole's or
    LunarLander's state ranges. Defaults are the reference settings (2x64 ELU, Adam 1e-3, batch 32).

    :param policy: ``"MlpPolicy"`` or a policy class
    :param env: the env or its id (spaces and evaluation only; never stepped while learning)
    :param expert_data: demonstrations (see :func:`sb3_mbil.as_demonstrations`)
    :param learning_rate: Adam learning rate (constant or schedule)
    :param batch_size: minibatch size (expert pairs and SGLD chains each)
    :param energy_weight: weight of L_rho + L_rho^2
    :param sgld_buffer_size: number of persistent SGLD chains
    :param sgld_steps: SGLD steps per gradient step
    :param sgld_step_size: SGLD gradient step
    :param sgld_noise: SGLD noise scale
    :param sgld_reinit_prob: probability of restarting a drawn chain from U[-1, 1]^d
    :param weight_decay: Adam weight decay of the policy
    :param policy_kwargs: policy keyword arguments (``net_arch``, ...)
    :param tensorboard_log: tensorboard folder
    :param verbose: verbosity
    :param seed: random seed
    :param device: torch device
    :param _init_setup_model: build the networks at construction
    """

    supported_action_spaces: ClassVar[tuple[type[spaces.Space], ...]] = (spaces.Discrete,)
    default_policy_kwargs: ClassVar[dict[str, Any]] = {"activation_fn": nn.ELU}
    sgld: SGLDBuffer

    def __init__(
        self,
        policy: str | type[ImitationPolicy],
        env: GymEnv | str | None,
        expert_data: ExpertData | None = None,
        learning_rate: float | Schedule = 1e-3,
        batch_size: int = 32,
        energy_weight: float = 1.0,
        sgld_buffer_size: int = 10_000,
        sgld_steps: int = 20,
        sgld_step_size: float = 0.01,
        sgld_noise: float = 0.01,
        sgld_reinit_prob: float = 0.05,
        weight_decay: float = 0.0,
        policy_kwargs: dict[str, Any] | None = None,
        tensorboard_log: str | None = None,
        verbose: int = 0,
        seed: int | None = None,
        device: th.device | str = "auto",
        _init_setup_model: bool = True,
    ):
        super().__init__(
            policy=policy, env=env, expert_data=expert_data, learning_rate=learning_rate, batch_size=batch_size,
            weight_decay=weight_decay, policy_kwargs=policy_kwargs, tensorboard_log=tensorboard_log, verbose=verbose,
            seed=seed, device=device, _init_setup_model=_init_setup_model,
        )
        self.energy_weight = energy_weight
        self.sgld_buffer_size = sgld_buffer_size
        self.sgld_steps = sgld_steps
        self.sgld_step_size = sgld_step_size
        self.sgld_noise = sgld_noise
        self.sgld_reinit_prob = sgld_reinit_prob
        if _init_setup_model:
            self._setup_model()

    def _check_hyperparameters(self) -> None:
        super()._check_hyperparameters()
        self.energy_weight = check_real("energy_weight", self.energy_weight, low=0.0)
        self.sgld_buffer_size = check_int("sgld_buffer_size", self.sgld_buffer_size, low=1)
        self.sgld_steps = check_int("sgld_steps", self.sgld_steps, low=0)
        self.sgld_step_size = check_real("sgld_step_size", self.sgld_step_size, low=0.0)
        self.sgld_noise = check_real("sgld_noise", self.sgld_noise, low=0.0)
        self.sgld_reinit_prob = check_real("sgld_reinit_prob", self.sgld_reinit_prob, low=0.0, high=1.0)

    def _setup_model(self) -> None:
        super()._setup_model()
        obs_dim = int(self.policy.features_extractor.features_dim)
        self.sgld = SGLDBuffer(obs_dim, self.sgld_buffer_size).to(self.device)

    def _get_torch_save_params(self) -> tuple[list[str], list[str]]:
        names, others = super()._get_torch_save_params()
        return [*names, "sgld"], others

    def _prepare_training(self) -> None:
        if not bool(self.sgld.stats_set):
            self.sgld.set_stats(self.expert_pairs().observations)

    def energy(self, obs: th.Tensor) -> th.Tensor:
        """LSE_a f(s): the unnormalised log-density of the expert's states under the model."""
        return th.logsumexp(self.policy.logits(obs), dim=-1)

    def sample_states(self) -> th.Tensor:
        """Advance ``batch_size`` persistent SGLD chains and return their states (env units, detached)."""
        idx = self._sample_indices(len(self.sgld.samples))
        z = self.sgld.samples[idx]
        restart = th.rand(len(z), 1, device=self.device) < self.sgld_reinit_prob
        z = self.langevin(th.where(restart, th.rand_like(z) * 2 - 1, z))
        self.sgld.samples[idx] = z
        return self.sgld.to_raw(z)

    def langevin(self, z: th.Tensor) -> th.Tensor:
        """``sgld_steps`` SGLD steps on standardised states z: z <- z + step * grad_z LSE f + noise * N(0, I)."""
        for _ in range(self.sgld_steps):
            z = z.detach().requires_grad_(True)
            grad = th.autograd.grad(self.energy(self.sgld.to_raw(z)).sum(), z)[0]
            z = z + self.sgld_step_size * grad + self.sgld_noise * th.randn_like(z)
        return z.detach()

    def _train_step(self) -> None:
        batch = self.sample(self.expert_pairs())
        sampled = self.sample_states()
        logits = self.policy.logits(th.cat([batch.observations, sampled]))
        n = len(batch.observations)

        # Policy term: CE(f(s), a) on the expert's pairs.
        ce = nn.functional.cross_entropy(logits[:n], batch.actions)

        # State-distribution term: L_rho = E_SGLD[LSE f(x)] - E_D[LSE f(s)], plus L_rho^2.
        lse = th.logsumexp(logits, dim=-1)
        l_rho = lse[n:].mean() - lse[:n].mean()
        loss = ce + self.energy_weight * (l_rho + l_rho.pow(2))

        self.policy.optimizer.zero_grad(set_to_none=True)
        loss.backward()
        self.policy.optimizer.step()
        self._record("train/bc_loss", ce)
        self._record("train/energy_loss", l_rho)
