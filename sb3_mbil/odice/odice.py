"""ODICE: offline imitation with orthogonal-gradient DICE (Mao, Xu, Zhang, Zhan, ICLR 2024), strictly offline."""

from __future__ import annotations

from typing import Any, ClassVar

import torch as th
from gymnasium import spaces
from stable_baselines3.common.type_aliases import GymEnv, Schedule

from sb3_mbil.common.demonstrations import ExpertData
from sb3_mbil.common.networks import MlpCritic, make_target, soft_update
from sb3_mbil.common.offline import OfflineAlgorithm
from sb3_mbil.common.policies import ImitationPolicy
from sb3_mbil.common.validation import check_real, check_sizes


def pearson_conjugate(x: th.Tensor) -> tuple[th.Tensor, th.Tensor]:
    """f*(x) = x w - (w - 1)^2 with w = max(x / 2 + 1, 0): the convex conjugate of the Pearson chi^2 generator
    f(w) = (w - 1)^2, and w, its maximiser."""
    w = th.clamp(x / 2.0 + 1.0, min=0.0)
    return x * w - (w - 1.0).pow(2), w


class ODICE(OfflineAlgorithm):
    """ODICE for offline imitation: a DICE value function learned with orthogonal gradients, then weighted BC.

    Paper: "ODICE: Revealing the Mystery of Distribution Correction Estimation via Orthogonal-gradient Update"
    (Mao, Xu, Zhang, Zhan, ICLR 2024). Box actions.

    Imitation as its code runs it: the expert's transitions with every reward 0. With the residuals
    delta_f = r + gamma (1 - done) Vbar(s') - V(s) (gradient through V(s)) and
    delta_b = r + gamma (1 - done) V(s') - Vbar(s) (gradient through V(s')), Vbar an EMA copy of V (tau):

        forward loss   L_f = (1 - lambda) E[V(s)] + lambda E[f*(delta_f)]
        backward loss  L_b = lambda eta E[f*(delta_b)]
        V's update     grad L_f + (grad L_b projected orthogonal to grad L_f)

    with f* the Pearson chi^2 conjugate (:func:`pearson_conjugate`), and V the minimum of twin critics. The policy
    is weighted behaviour cloning, min E[-w log pi(a | s)] with w = min(max(delta_f, 0), 100) detached, as in
    the reference code. Settings: lambda 0.4, eta 1, gamma 0.99, batch 256, Adam 1e-4, twin V 2x256 ReLU,
    tau 0.005. Deviations: the policy is this package's Gaussian (state-dependent log-std, its mean bounded
    into the action box by a tanh, 2x256 instead of 2x1024).

    :param policy: ``"MlpPolicy"`` or a policy class
    :param env: the env or its id (spaces and evaluation only; never stepped while learning)
    :param expert_data: demonstrations (see :func:`sb3_mbil.as_demonstrations`)
    :param learning_rate: Adam learning rate of the policy (constant or schedule)
    :param batch_size: minibatch size of expert transitions
    :param gamma: discount
    :param lambda_: the forward/value trade-off lambda
    :param eta: weight of the backward term
    :param value_learning_rate: Adam learning rate of V
    :param value_arch: hidden sizes of V
    :param tau: target (Vbar) update rate
    :param max_weight: clip of the BC weights
    :param weight_decay: Adam weight decay of the policy
    :param policy_kwargs: policy keyword arguments (``net_arch``, ...)
    :param tensorboard_log: tensorboard folder
    :param verbose: verbosity
    :param seed: random seed
    :param device: torch device
    :param _init_setup_model: build the networks at construction
    """

    supported_action_spaces: ClassVar[tuple[type[spaces.Space], ...]] = (spaces.Box,)
    default_policy_kwargs: ClassVar[dict[str, Any]] = {"net_arch": [256, 256], "normalize_observations": True,
                                                       "bounded_mean": True}
    value: MlpCritic
    value_target: MlpCritic

    def __init__(
        self,
        policy: str | type[ImitationPolicy],
        env: GymEnv | str | None,
        expert_data: ExpertData | None = None,
        learning_rate: float | Schedule = 1e-4,
        batch_size: int = 256,
        gamma: float = 0.99,
        lambda_: float = 0.4,
        eta: float = 1.0,
        value_learning_rate: float = 1e-4,
        value_arch: list[int] | tuple[int, ...] = (256, 256),
        tau: float = 0.005,
        max_weight: float = 100.0,
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
        self.gamma = gamma
        self.lambda_ = lambda_
        self.eta = eta
        self.value_learning_rate = value_learning_rate
        self.value_arch = value_arch
        self.tau = tau
        self.max_weight = max_weight
        if _init_setup_model:
            self._setup_model()

    def _check_hyperparameters(self) -> None:
        super()._check_hyperparameters()
        self.gamma = check_real("gamma", self.gamma, low=0.0, high=1.0)
        self.lambda_ = check_real("lambda_", self.lambda_, low=0.0, high=1.0)
        self.eta = check_real("eta", self.eta, low=0.0)
        self.value_learning_rate = check_real("value_learning_rate", self.value_learning_rate, low=0.0, low_open=True)
        self.value_arch = check_sizes("value_arch", self.value_arch)
        self.tau = check_real("tau", self.tau, low=0.0, high=1.0, low_open=True)
        self.max_weight = check_real("max_weight", self.max_weight, low=0.0, low_open=True)

    def _setup_model(self) -> None:
        super()._setup_model()
        obs_dim = self.policy.features_extractor.features_dim
        self.value = MlpCritic(obs_dim, 1, 0, self.value_arch, th.nn.ReLU, n_critics=2).to(self.device)
        self.value.optimizer = th.optim.Adam(self.value.parameters(), lr=self.value_learning_rate)
        self.value_target = make_target(self.value)

    def _get_torch_save_params(self) -> tuple[list[str], list[str]]:
        names, others = super()._get_torch_save_params()
        return [*names, "value", "value.optimizer", "value_target"], others

    def _v(self, module: MlpCritic, obs: th.Tensor) -> th.Tensor:
        """min over the twin critics of V(s)."""
        return module(self.policy.features(obs)).min(dim=0).values.squeeze(-1)

    def _train_step(self) -> None:
        batch = self.sample(self.expert_transitions())
        not_done = 1.0 - batch.dones
        reward = th.zeros_like(not_done)  # imitation: every reward 0

        # V: forward and backward residuals.
        v, v_next = self._v(self.value, batch.observations), self._v(self.value, batch.next_observations)
        with th.no_grad():
            v_bar, v_bar_next = self._v(self.value_target, batch.observations), self._v(self.value_target, batch.next_observations)
        delta_f = reward + self.gamma * not_done * v_bar_next - v
        delta_b = reward + self.gamma * not_done * v_next - v_bar
        forward = (1.0 - self.lambda_) * v.mean() + self.lambda_ * pearson_conjugate(delta_f)[0].mean()
        backward = self.lambda_ * self.eta * pearson_conjugate(delta_b)[0].mean()

        # The orthogonal-gradient update: the backward gradient without its component along the forward one.
        params = list(self.value.parameters())
        g_f = th.autograd.grad(forward, params, retain_graph=True)
        g_b = th.autograd.grad(backward, params)
        dot = sum((a * b).sum() for a, b in zip(g_f, g_b))
        norm = sum(a.pow(2).sum() for a in g_f).clamp(min=1e-12)
        for p, a, b in zip(params, g_f, g_b):
            p.grad = a + b - (dot / norm) * a
        self.value.optimizer.step()
        soft_update(self.value_target, self.value, self.tau)

        # Policy: behaviour cloning weighted by max(delta_f, 0), clipped.
        weight = delta_f.detach().clamp(min=0.0, max=self.max_weight)
        log_prob = self.policy.log_prob(batch.observations, batch.actions)
        policy_loss = -(weight * log_prob).mean()
        self.policy.optimizer.zero_grad(set_to_none=True)
        policy_loss.backward()
        self.policy.optimizer.step()
        self._record("train/value_forward", forward)
        self._record("train/value_backward", backward)
        self._record("train/policy_loss", policy_loss)
        self._record("train/weight_mean", weight.mean())
