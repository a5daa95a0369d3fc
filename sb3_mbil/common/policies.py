"""The imitation policy pi_theta(a | s) shared by MBIL and BC.

An MLP with two ReLU hidden layers (the paper's policy) and

* a softmax head for ``Discrete`` actions: pi(a|s) is a probability mass;
* separate mean and log-std heads for ``Box`` actions: pi(a|s) is a diagonal
  Gaussian density in the env's raw action units (no squashing, so the density
  is exactly the Gaussian's; ``predict`` clips to the action bounds). With
  ``bounded_mean=True`` the *mean* is tanh-squashed into the bounds,
  ``mean = center + half_range * tanh(h)``; the distribution around it stays an
  unsquashed Gaussian in raw units, so log pi needs no Jacobian term.

Deterministic ``predict`` returns the argmax or the mean.

With ``normalize_observations=True`` the network sees (s - mean) / std of the expert states (std
floored at 1e-3, the result clipped to +-10 as SB3's VecNormalize does); the statistics are set from
the demonstrations at the first ``learn`` and saved with the policy.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import torch as th
from gymnasium import spaces
from stable_baselines3.common.policies import BasePolicy
from stable_baselines3.common.torch_layers import FlattenExtractor, create_mlp
from stable_baselines3.common.type_aliases import Schedule
from torch import nn

LOG_2PI = math.log(2.0 * math.pi)


class StackedLinear(th.autograd.Function):
    """S linear layers at once: ``x`` (S, N, in), ``weight`` (S, out, in), ``bias`` (S, out). Each slice's output and
    gradients are bit for bit those of ``torch.nn.functional.linear`` on that slice alone, so that seeds trained in
    lockstep follow their separate runs exactly: the products a single layer computes (``addmm`` forward, grad_out^T x
    for the weight) are taken per slice, because a batched ``baddbmm``/``bmm`` rounds differently for some shapes
    (120 and 65 of 720 slices over 144 shapes: ``python -m benchmarks.probe_stacked_linear``), and training amplifies a rounding difference; the input's
    gradient is one ``bmm`` (exact on every shape measured)."""

    @staticmethod
    def forward(ctx, x: th.Tensor, weight: th.Tensor, bias: th.Tensor) -> th.Tensor:
        ctx.save_for_backward(x, weight)
        out = x.new_empty(x.shape[0], x.shape[1], weight.shape[1])
        for o, b, xi, wt in zip(out.unbind(), bias.unbind(), x.unbind(), weight.transpose(1, 2).unbind()):
            th.addmm(b, xi, wt, out=o)
        return out

    @staticmethod
    def backward(ctx, grad: th.Tensor):
        x, weight = ctx.saved_tensors
        grad_x = th.bmm(grad, weight) if ctx.needs_input_grad[0] else None
        grad_weight = None
        if ctx.needs_input_grad[1]:
            grad_weight = th.stack([gi.t().mm(xi) for gi, xi in zip(grad.unbind(), x.unbind())])
        grad_bias = grad.sum(1) if ctx.needs_input_grad[2] else None
        return grad_x, grad_weight, grad_bias


class ImitationPolicy(BasePolicy):
    """MLP policy with a categorical (Discrete) or Gaussian (Box) head.

    :param observation_space: Box observation space
    :param action_space: Discrete or Box action space
    :param lr_schedule: learning rate schedule (for the optimizer)
    :param net_arch: hidden layer sizes (the paper: two hidden layers)
    :param activation_fn: activation of the hidden layers (ReLU in the paper)
    :param log_std_bounds: clamp of the Gaussian head's log standard deviation
    :param optimizer_class: the optimizer
    :param optimizer_kwargs: its keyword arguments (e.g. ``weight_decay``)
    :param normalize_observations: standardise observations with the expert states' statistics
    :param bounded_mean: (Box) squash the Gaussian's mean into the action bounds with a tanh
    """

    OBS_STD_FLOOR = 1e-3
    OBS_CLIP = 10.0

    def __init__(
        self,
        observation_space: spaces.Space,
        action_space: spaces.Space,
        lr_schedule: Schedule,
        net_arch: list[int] | None = None,
        activation_fn: type[nn.Module] = nn.ReLU,
        log_std_bounds: tuple[float, float] = (-5.0, 2.0),
        optimizer_class: type[th.optim.Optimizer] = th.optim.Adam,
        optimizer_kwargs: dict[str, Any] | None = None,
        normalize_observations: bool = False,
        bounded_mean: bool = False,
    ):
        super().__init__(
            observation_space,
            action_space,
            features_extractor_class=FlattenExtractor,
            normalize_images=False,
            optimizer_class=optimizer_class,
            optimizer_kwargs=optimizer_kwargs,
        )
        self.net_arch = [64, 64] if net_arch is None else list(net_arch)
        self.activation_fn = activation_fn
        self.log_std_bounds = tuple(float(b) for b in log_std_bounds)
        if len(self.log_std_bounds) != 2 or not self.log_std_bounds[0] < self.log_std_bounds[1]:
            raise ValueError(f"log_std_bounds: expected (low, high) with low < high, found {log_std_bounds!r}")
        self.discrete = isinstance(action_space, spaces.Discrete)
        self.normalize_observations = bool(normalize_observations)
        if not isinstance(bounded_mean, bool):
            raise ValueError(f"bounded_mean: expected True or False, found {bounded_mean!r}")
        if bounded_mean and self.discrete:
            raise ValueError("bounded_mean: expected False for Discrete actions (it bounds a Gaussian mean), found True")
        self.bounded_mean = bounded_mean
        self._build(lr_schedule)

    def _build(self, lr_schedule: Schedule) -> None:
        self.features_extractor = self.make_features_extractor()
        n_in = self.features_extractor.features_dim
        self.register_buffer("obs_mean", th.zeros(n_in))
        self.register_buffer("obs_std", th.ones(n_in))
        self.register_buffer("obs_stats_set", th.tensor(False))
        self.latent = nn.Sequential(*create_mlp(n_in, -1, self.net_arch, self.activation_fn))
        latent_dim = self.net_arch[-1] if self.net_arch else n_in
        if self.discrete:
            self.logits_head = nn.Linear(latent_dim, int(self.action_space.n))
        else:
            act_dim = int(math.prod(self.action_space.shape))
            self.mean_head = nn.Linear(latent_dim, act_dim)
            self.log_std_head = nn.Linear(latent_dim, act_dim)
            low = th.as_tensor(self.action_space.low, dtype=th.float32).reshape(-1)
            high = th.as_tensor(self.action_space.high, dtype=th.float32).reshape(-1)
            self.register_buffer("action_center", (high + low) / 2, persistent=False)  # from the space
            self.register_buffer("action_half_range", (high - low) / 2, persistent=False)
        self.optimizer = self.optimizer_class(self.parameters(), lr=lr_schedule(1), **self.optimizer_kwargs)

    def _get_constructor_parameters(self) -> dict[str, Any]:
        data = super()._get_constructor_parameters()
        data.update(
            net_arch=self.net_arch,
            activation_fn=self.activation_fn,
            log_std_bounds=self.log_std_bounds,
            optimizer_class=self.optimizer_class,
            optimizer_kwargs=self.optimizer_kwargs,
            normalize_observations=self.normalize_observations,
            bounded_mean=self.bounded_mean,
        )
        # The features extractor is fixed (flatten): do not pass these on.
        for key in ("features_extractor_class", "features_extractor_kwargs", "normalize_images", "squash_output"):
            data.pop(key, None)
        return data

    @th.no_grad()
    def set_observation_stats(self, observations: th.Tensor) -> None:
        """Mean and std (floored) of the expert states, used when ``normalize_observations``."""
        x = observations.float().view(len(observations), -1)
        self.obs_mean.copy_(x.mean(0))
        self.obs_std.copy_(x.std(0, unbiased=False).clamp(min=self.OBS_STD_FLOOR))
        self.obs_stats_set.fill_(True)

    # ------------------------------------------------------------------ heads
    def features(self, obs: th.Tensor) -> th.Tensor:
        """The network's input: flat observations, standardised when ``normalize_observations`` (other networks
        of an algorithm, e.g. its critics, read the same input)."""
        # SB3's extract_features for a Box space and the fixed FlattenExtractor, without its two calls' overhead
        features = obs.float().flatten(1)
        if self.normalize_observations:
            features = ((features - self.obs_mean) / self.obs_std).clamp(-self.OBS_CLIP, self.OBS_CLIP)
        return features

    def _latent(self, obs: th.Tensor) -> th.Tensor:
        return self.latent(self.features(obs))

    def heads_from_latent(self, h: th.Tensor) -> tuple[th.Tensor, ...]:
        """:meth:`heads` from the last hidden layer's output."""
        if self.discrete:
            return (self.logits_head(h),)
        mean = self.mean_head(h)
        if self.bounded_mean:
            mean = self.squash(mean)
        return mean, self.log_std_head(h).clamp(*self.log_std_bounds)

    def squash(self, raw_mean: th.Tensor) -> th.Tensor:
        """``center + half_range * tanh(raw)``: a pre-squash action into the bounds (``bounded_mean``)."""
        return self.action_center + self.action_half_range * th.tanh(raw_mean)

    def raw_heads(self, obs: th.Tensor) -> tuple[th.Tensor, th.Tensor]:
        """(Box, ``bounded_mean``) the mean before :meth:`squash` and the log-std: a tanh-Gaussian's parameters."""
        h = self._latent(obs)
        return self.mean_head(h), self.log_std_head(h).clamp(*self.log_std_bounds)

    def heads(self, obs: th.Tensor) -> tuple[th.Tensor, ...]:
        """The network's outputs: ``(logits,)`` for Discrete, ``(mean, log_std)`` for Box."""
        return self.heads_from_latent(self._latent(obs))

    def stacked_heads(self, params: dict[str, th.Tensor], buffers: dict[str, th.Tensor], obs: th.Tensor,
                      raw: bool = False) -> tuple[th.Tensor, ...]:
        """:meth:`heads` (``raw``: :meth:`raw_heads`) of S networks of this architecture at once, for seeds trained in
        lockstep (:mod:`sb3_mbil.common.lockstep`): ``params`` and ``buffers`` are this module's named parameters and
        buffers stacked on a leading seed dimension, ``obs`` the flat states of shape (S, N, obs_dim); each linear
        layer is one batched matrix product (``baddbmm``) instead of S small ones."""
        def linear(name: str, x: th.Tensor) -> th.Tensor:
            bias = params.get(f"{name}.bias")
            return StackedLinear.apply(x, params[f"{name}.weight"], bias if bias is not None else
                                       th.zeros(x.shape[0], params[f"{name}.weight"].shape[1], device=x.device))

        x = obs.float()
        if self.normalize_observations:
            x = ((x - buffers["obs_mean"].unsqueeze(1)) / buffers["obs_std"].unsqueeze(1)).clamp(-self.OBS_CLIP,
                                                                                                   self.OBS_CLIP)
        for i, layer in enumerate(self.latent):
            x = linear(f"latent.{i}", x) if isinstance(layer, nn.Linear) else layer(x)
        if self.discrete:
            return (linear("logits_head", x),)
        mean, log_std = linear("mean_head", x), linear("log_std_head", x).clamp(*self.log_std_bounds)
        return (self.squash(mean) if self.bounded_mean and not raw else mean), log_std

    def log_prob_from_heads(self, heads: Sequence[th.Tensor], actions: th.Tensor) -> th.Tensor:
        """log pi(a | s) from :meth:`heads`: log-mass (Discrete) or log-density in raw action units (Box)."""
        if self.discrete:
            logp = th.log_softmax(heads[0], dim=-1)
            return logp.gather(1, actions.long().view(-1, 1)).squeeze(1)
        mean, log_std = heads
        z = (actions.view_as(mean) - mean) * th.exp(-log_std)
        return (-0.5 * z.pow(2) - log_std - 0.5 * LOG_2PI).sum(dim=1)

    def log_prob(self, obs: th.Tensor, actions: th.Tensor) -> th.Tensor:
        """log pi(a | s)."""
        return self.log_prob_from_heads(self.heads(obs), actions)

    def logits(self, obs: th.Tensor) -> th.Tensor:
        return self.heads(obs)[0]

    def mean_log_std(self, obs: th.Tensor) -> tuple[th.Tensor, th.Tensor]:
        mean, log_std = self.heads(obs)
        return mean, log_std

    def mean_action(self, obs: th.Tensor) -> th.Tensor:
        return self.heads(obs)[0]

    # ------------------------------------------------------------------ acting
    def forward(self, obs: th.Tensor, deterministic: bool = False) -> th.Tensor:
        return self._predict(obs, deterministic)

    def _predict(self, observation: th.Tensor, deterministic: bool = False) -> th.Tensor:
        heads = self.heads(observation)
        if self.discrete:
            if deterministic:
                return heads[0].argmax(dim=1)
            return th.distributions.Categorical(logits=heads[0]).sample()
        mean, log_std = heads
        actions = mean if deterministic else mean + th.randn_like(mean) * log_std.exp()
        return actions.view(-1, *self.action_space.shape)


MlpPolicy = ImitationPolicy
