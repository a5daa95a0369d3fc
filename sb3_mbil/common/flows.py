"""Conditional density models and their fitting (maximum likelihood, Gaussian input noise, early stopping).

* :class:`ConditionalFlow`: log q(x | c) with a RealNVP of affine coupling blocks
  (zuko) fed by a conditioning network NN_c, as in the paper: NN_c(c) is the
  context of every coupling block, whose own hyper-network (NN_i) reads it.
* :class:`ConditionalCategorical`: log q(a | c) for a discrete variable, a proper mass.
* :class:`ConditionalGaussian`: log q(x | c), a diagonal Gaussian whose mean and std an MLP predicts.

Both standardise their inputs with statistics kept in module buffers and
return log-densities in the **raw** units of x (the standardisation Jacobian
``-sum(log sigma)`` is added back), so densities from different models of the
same variable are comparable.

Constant and binary dimensions: a constant dimension of x would make the flow a
spike (likelihood -> infinity at the data, -1e20 a little away). Such dimensions
get standardised to 0 with unit scale and are jittered with N(0, 1) during
fitting; binary dimensions get a noise floor of a quarter of their gap. Every
model sees the same jitter, so it cancels between models of the same variable.
"""

from __future__ import annotations

import copy
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from functools import partial

import numpy as np
import torch as th
import torch.distributions as _torch_dist
from gymnasium import spaces
from torch import nn

_validate_args = _torch_dist.Distribution._validate_args
import zuko  # noqa: E402  (importing zuko switches off torch.distributions validation process-wide)
from zuko.transforms import MonotonicAffineTransform  # noqa: E402

_torch_dist.Distribution.set_default_validate_args(_validate_args)  # give the process its setting back

EVAL_CHUNK = 4096


class Standardizer(nn.Module):
    """Per-dimension standardisation with buffers, and a per-dimension noise floor."""

    def __init__(self, dim: int):
        super().__init__()
        self.register_buffer("mean", th.zeros(dim))
        self.register_buffer("std", th.ones(dim))
        self.register_buffer("noise_floor", th.zeros(dim))

    @th.no_grad()
    def fit(self, x: th.Tensor) -> None:
        mean = x.mean(0)
        std = x.std(0, unbiased=False) if len(x) > 1 else th.zeros_like(mean)
        constant = std <= 1e-6 * (1.0 + mean.abs())
        floor = th.zeros_like(mean)
        for d in range(x.shape[1]):
            if constant[d]:
                continue
            values = th.unique(x[:, d])
            if len(values) == 2:  # binary dimension (e.g. LunarLander leg contacts)
                floor[d] = 0.25 * (values[1] - values[0]) / std[d]
        std = th.where(constant, th.ones_like(std), std)
        floor = th.where(constant, th.ones_like(floor), floor)
        self.mean.copy_(mean)
        self.std.copy_(std)
        self.noise_floor.copy_(floor)

    def forward(self, x: th.Tensor, noise: float = 0.0) -> th.Tensor:
        z = (x - self.mean) / self.std
        if noise > 0.0 or self.training:
            scale = th.clamp(self.noise_floor, min=noise) if self.training else th.full_like(self.std, noise)
            z = z + th.randn_like(z) * scale
        return z

    def log_abs_det(self) -> th.Tensor:
        """log |dz/dx| of the standardisation."""
        return -th.log(self.std).sum()


class ConditionalFlow(nn.Module):
    """log q(x | c): RealNVP (affine coupling blocks) on standardised x, conditioned on NN_c(c).

    :param x_dim: dimension of x
    :param c_dim: dimension of the condition c
    :param transforms: number of affine coupling blocks
    :param hidden: hidden layer sizes of each block's network NN_i
    :param embed_dim: output size of the conditioning network NN_c (0: feed c directly)
    :param scale_limit: bound on each block's |log scale| (tighter than zuko's default of 6.9)
    """

    def __init__(
        self,
        x_dim: int,
        c_dim: int,
        transforms: int = 4,
        hidden: Sequence[int] = (64, 64),
        embed_dim: int = 32,
        scale_limit: float = 3.0,
    ):
        super().__init__()
        self.x_norm = Standardizer(x_dim)
        self.c_norm = Standardizer(c_dim)
        if embed_dim > 0:  # NN_c
            self.embed = nn.Sequential(nn.Linear(c_dim, hidden[0]), nn.ReLU(), nn.Linear(hidden[0], embed_dim))
            context = embed_dim
        else:
            self.embed = nn.Identity()
            context = c_dim
        univariate = partial(MonotonicAffineTransform, slope=math.exp(-scale_limit))
        self.flow = zuko.flows.RealNVP(
            x_dim, context=context, transforms=transforms, hidden_features=tuple(hidden), univariate=univariate
        )

    def fit_statistics(self, x: th.Tensor, c: th.Tensor) -> None:
        self.x_norm.fit(x)
        self.c_norm.fit(c)

    def log_prob(self, x: th.Tensor, c: th.Tensor, noise: float = 0.0) -> th.Tensor:
        z = self.x_norm(x, noise)
        context = self.embed(self.c_norm(c, noise))
        return self.flow(context).log_prob(z) + self.x_norm.log_abs_det()


def mlp(n_in: int, hidden: Sequence[int], n_out: int) -> nn.Sequential:
    """ReLU MLP ``n_in -> hidden... -> n_out`` (linear output)."""
    layers: list[nn.Module] = []
    last = n_in
    for h in hidden:
        layers += [nn.Linear(last, h), nn.ReLU()]
        last = h
    layers.append(nn.Linear(last, n_out))
    return nn.Sequential(*layers)


class TupleInputs(nn.Module):
    """How the density models of a tuple (s, a, s', a') see it: actions as flat features (one-hot for Discrete),
    T's (x, c) = (s', (s, a)) and the next-action model's (x, c) = (a', (s, a, s'))."""

    def __init__(self, obs_dim: int, action_space: spaces.Space):
        super().__init__()
        self.obs_dim = obs_dim
        self.discrete = isinstance(action_space, spaces.Discrete)
        self.n_actions = int(action_space.n) if self.discrete else 0
        self.act_in = self.n_actions if self.discrete else int(math.prod(action_space.shape))

    def encode_action(self, a: th.Tensor) -> th.Tensor:
        """Actions as flat float features (one-hot for Discrete)."""
        if self.discrete:
            return nn.functional.one_hot(a.long().view(-1), self.n_actions).float()
        return a.float().view(len(a), -1)

    def transition_inputs(self, s: th.Tensor, a: th.Tensor, s_next: th.Tensor) -> tuple[th.Tensor, th.Tensor]:
        """(x, c) of T: x = s', c = (s, a)."""
        return s_next, th.cat([s, self.encode_action(a)], dim=1)

    def next_action_inputs(self, s, a, s_next, a_next) -> tuple[th.Tensor, th.Tensor]:
        """(x, c) of P(a' | s, a, s'): x = a', c = (s, a, s')."""
        x = a_next.long().view(-1) if self.discrete else a_next.float().view(len(a_next), -1)
        return x, th.cat([s, self.encode_action(a), s_next], dim=1)


class ConditionalCategorical(nn.Module):
    """log q(a | c) for a in {0, ..., n-1}: an MLP with a softmax output (a probability mass)."""

    def __init__(self, n: int, c_dim: int, hidden: Sequence[int] = (64, 64)):
        super().__init__()
        self.c_norm = Standardizer(c_dim)
        self.net = mlp(c_dim, hidden, n)

    def fit_statistics(self, x: th.Tensor, c: th.Tensor) -> None:
        self.c_norm.fit(c)

    def log_probs(self, c: th.Tensor, noise: float = 0.0) -> th.Tensor:
        """log q(. | c) over every value, shape (len(c), n)."""
        return th.log_softmax(self.net(self.c_norm(c, noise)), dim=-1)

    def log_prob(self, x: th.Tensor, c: th.Tensor, noise: float = 0.0) -> th.Tensor:
        return self.log_probs(c, noise).gather(1, x.long().view(-1, 1)).squeeze(1)


class ConditionalGaussian(nn.Module):
    """log q(x | c) = sum_d log N(x_d; mu_d(c), sigma_d(c)^2): an MLP with mean and log-std heads.

    The mean and std are predicted in standardised x units and returned in raw units (the
    standardisation Jacobian is added back, as in :class:`ConditionalFlow`). Much cheaper than a flow;
    :meth:`mean_std` gives the parameters (for closed-form KL divergences and sampling).
    """

    LOG_STD_BOUNDS = (-7.0, 2.0)

    def __init__(self, x_dim: int, c_dim: int, hidden: Sequence[int] = (64, 64)):
        super().__init__()
        self.x_norm = Standardizer(x_dim)
        self.c_norm = Standardizer(c_dim)
        self.net = mlp(c_dim, hidden, 2 * x_dim)

    def fit_statistics(self, x: th.Tensor, c: th.Tensor) -> None:
        self.x_norm.fit(x)
        self.c_norm.fit(c)

    def _standardised(self, c: th.Tensor, noise: float = 0.0) -> tuple[th.Tensor, th.Tensor]:
        mean, log_std = self.net(self.c_norm(c, noise)).chunk(2, dim=-1)
        return mean, log_std.clamp(*self.LOG_STD_BOUNDS)

    def mean_std(self, c: th.Tensor) -> tuple[th.Tensor, th.Tensor]:
        """Mean and standard deviation of x given c, in raw units."""
        mean, log_std = self._standardised(c)
        return self.x_norm.mean + self.x_norm.std * mean, self.x_norm.std * log_std.exp()

    def log_prob(self, x: th.Tensor, c: th.Tensor, noise: float = 0.0) -> th.Tensor:
        z = self.x_norm(x, noise)
        mean, log_std = self._standardised(c, noise)
        logp = -0.5 * ((z - mean) * th.exp(-log_std)).pow(2) - log_std - 0.5 * math.log(2 * math.pi)
        return logp.sum(dim=-1) + self.x_norm.log_abs_det()


@th.no_grad()
def evaluate_log_prob(model: nn.Module, x: th.Tensor, c: th.Tensor) -> th.Tensor:
    """Clean log-likelihoods (no noise, eval mode), in chunks."""
    was_training = model.training
    model.eval()
    out = th.cat([model.log_prob(x[i : i + EVAL_CHUNK], c[i : i + EVAL_CHUNK]) for i in range(0, len(x), EVAL_CHUNK)])
    model.train(was_training)
    return out


def block_split(groups: np.ndarray, fraction: float, seed: int, block: int = 20) -> tuple[np.ndarray, np.ndarray]:
    """Hold out whole blocks of consecutive samples (inside each trajectory) for validation.

    Blocks limit the leak between a held-out sample and its neighbours in time.
    Returns (train indices, validation indices).
    """
    n = len(groups)
    if not 0.0 < fraction < 1.0:
        raise ValueError(f"validation_fraction: expected a value in (0, 1), found {fraction}")
    if n < 4:
        raise ValueError(f"expert data: expected at least 4 tuples to hold some out for validation, found {n}")
    block = max(1, min(block, n // 10))
    # block id: consecutive positions inside the same group
    starts = np.r_[0, np.flatnonzero(np.diff(groups)) + 1]
    pos = np.arange(n) - np.repeat(starts, np.diff(np.r_[starts, n]))
    block_id = np.unique(np.stack([groups, pos // block], 1), axis=0, return_inverse=True)[1].reshape(-1)
    n_blocks = int(block_id.max()) + 1
    rng = np.random.default_rng(seed)
    n_val = min(max(1, int(round(fraction * n_blocks))), n_blocks - 1)
    val_blocks = rng.choice(n_blocks, size=n_val, replace=False)
    is_val = np.isin(block_id, val_blocks)
    return np.flatnonzero(~is_val), np.flatnonzero(is_val)


@dataclass
class FitReport:
    """What the fit chose and measured (log-likelihoods in nats per sample, raw units)."""

    noise: float
    steps: int
    heldout_ll: float
    train_ll: float
    seconds: float
    candidates: dict = field(default_factory=dict)  # noise -> {"heldout_ll", "steps"}

    def as_dict(self) -> dict:
        return asdict(self)


def fit_conditional_density(
    make_model: Callable[[], nn.Module],
    x: th.Tensor,
    c: th.Tensor,
    train_idx: np.ndarray,
    val_idx: np.ndarray,
    *,
    noise_grid: Sequence[float],
    learning_rate: float,
    batch_size: int,
    max_steps: int,
    eval_every: int,
    patience: int,
    refit: bool,
    seed: int,
    min_delta: float = 0.0,
    log: Callable[[str], None] | None = None,
) -> tuple[nn.Module, FitReport]:
    """Maximum likelihood with Gaussian input noise; noise level and step count chosen on held-out data.

    For each noise level: train on the train split, evaluating the clean held-out
    log-likelihood every ``eval_every`` steps, stop after ``patience`` evaluations
    without a gain of more than ``min_delta`` nats per sample over the last gain that counted,
    and keep the best point. The noise level with the best held-out log-likelihood wins;
    with ``refit`` the model is then retrained on all the data with that noise for the chosen number of steps.
    ``log`` receives one line per noise level (progress: the algorithms pass ``print`` when ``verbose >= 1``).
    """
    start = time.process_time()
    tr, va = th.as_tensor(train_idx, device=x.device), th.as_tensor(val_idx, device=x.device)
    candidates: dict[str, dict] = {}
    best: tuple[float, float, int, dict] | None = None  # (val LL, noise, steps, state)
    fits = _train_candidates(make_model, x, c, tr, va, noise_grid, learning_rate, batch_size, max_steps, eval_every,
                             patience, seed, min_delta)
    for k, noise in enumerate(noise_grid):
        if fits is None:
            model, val_ll, steps, state = _train(
                make_model, x, c, tr, va, noise, learning_rate, batch_size, max_steps, eval_every, patience, seed + k,
                min_delta,
            )
        else:
            model, val_ll, steps, state = fits[k]
        candidates[f"{noise:g}"] = {"heldout_ll": val_ll, "steps": steps}
        if log is not None:
            log(f"noise {noise:g}: held-out log-likelihood {val_ll:.3f} at step {steps} ({time.process_time() - start:.1f} s)")
        if best is None or val_ll > best[0]:
            best = (val_ll, float(noise), steps, state)
    assert best is not None
    val_ll, noise, steps, state = best
    if refit:
        everything = th.arange(len(x), device=x.device)
        model, _, _, _ = _train(
            make_model, x, c, everything, None, noise, learning_rate, batch_size, steps, eval_every, patience, seed
        )
    else:
        with th.random.fork_rng(devices=[]):  # the fit never draws from the caller's random stream
            model = make_model().to(x.device)
        model.load_state_dict(state)
    model.eval()
    train_ll = float(evaluate_log_prob(model, x[tr], c[tr]).mean())
    report = FitReport(noise, steps, val_ll, train_ll, time.process_time() - start, candidates)
    return model, report


def _train(make_model, x, c, tr, va, noise, lr, batch_size, max_steps, eval_every, patience, seed, min_delta=0.0):
    """Train one model; with a validation split, early-stop on its clean log-likelihood."""
    with th.random.fork_rng(devices=[]):
        th.manual_seed(seed)
        model = make_model().to(x.device)
        model.fit_statistics(x[tr], c[tr])
        model.train()
        opt = th.optim.Adam(model.parameters(), lr=lr, foreach=True)
        best_ll, best_step, best_state, bad = -math.inf, 0, copy.deepcopy(model.state_dict()), 0
        mark = -math.inf  # the held-out LL that the patience counts from (the last gain of more than min_delta)
        for step in range(1, max_steps + 1):
            idx = tr[th.randint(0, len(tr), (batch_size,), device=x.device)]
            loss = -model.log_prob(x[idx], c[idx], noise).mean()
            if th.isfinite(loss):
                opt.zero_grad(set_to_none=True)
                loss.backward()
                nn.utils.clip_grad_norm_(model.parameters(), 10.0)
                opt.step()
            if va is not None and (step % eval_every == 0 or step == max_steps):
                ll = float(evaluate_log_prob(model, x[va], c[va]).mean())
                ll = ll if math.isfinite(ll) else -math.inf
                if ll > best_ll:
                    best_ll, best_step, best_state = ll, step, copy.deepcopy(model.state_dict())
                if ll > mark + min_delta:
                    mark, bad = ll, 0
                else:
                    bad += 1
                    if bad >= patience:
                        break
        if va is None:
            best_step, best_state = max_steps, model.state_dict()
        model.load_state_dict(best_state)
        model.eval()
    return model, best_ll, best_step, best_state


class _NonFinite(Exception):
    """A candidate's loss turned non-finite in a stacked fit: the candidates are fitted one by one instead."""


def _train_candidates(make_model, x, c, tr, va, noise_grid, lr, batch_size, max_steps, eval_every, patience, seed,
                      min_delta=0.0):
    """The noise candidates of a :class:`ConditionalCategorical` fitted at once, each bit for bit what :func:`_train`
    gives it (its own seed ``seed + k`` and random stream, its own early stopping): the candidates' networks stacked
    as one batched network (:class:`~sb3_mbil.common.policies.StackedLinear`), clipped and stepped per candidate
    exactly as ``clip_grad_norm_`` and Adam do. None (fit them one by one) for other models, one candidate, or when a
    loss turns non-finite."""
    from sb3_mbil.common.policies import StackedLinear

    if len(noise_grid) < 2 or va is None:
        return None
    models, generators = [], []
    for k in range(len(noise_grid)):
        with th.random.fork_rng(devices=[]):
            th.manual_seed(seed + k)
            model = make_model().to(x.device)
            if not isinstance(model, ConditionalCategorical):
                return None
            model.fit_statistics(x[tr], c[tr])
            model.train()
            generator = th.Generator(device=x.device)
            generator.set_state(th.get_rng_state())
        models.append(model)
        generators.append(generator)
    try:
        return _fit_stacked(models, generators, x, c, tr, va, noise_grid, lr, batch_size, max_steps, eval_every,
                            patience, StackedLinear, min_delta)
    except _NonFinite:
        return None


def _fit_stacked(models, generators, x, c, tr, va, noise_grid, lr, batch_size, max_steps, eval_every, patience,
                 stacked_linear, min_delta=0.0):
    n = len(models)
    names = [name for name, _ in models[0].named_parameters()]
    params = {name: th.stack([m.get_parameter(name).detach() for m in models]).requires_grad_(True) for name in names}
    opt = th.optim.Adam([params[name] for name in names], lr=lr, foreach=True)
    mean = th.stack([m.c_norm.mean for m in models]).unsqueeze(1)
    std = th.stack([m.c_norm.std for m in models]).unsqueeze(1)
    scale = th.stack([th.clamp(m.c_norm.noise_floor, min=noise) for m, noise in zip(models, noise_grid)]).unsqueeze(1)
    layers = list(models[0].net)

    def log_probs(z: th.Tensor) -> th.Tensor:  # the candidates' log q(. | c) at their standardised inputs
        for i, layer in enumerate(layers):
            z = stacked_linear.apply(z, params[f"net.{i}.weight"], params[f"net.{i}.bias"]) \
                if isinstance(layer, nn.Linear) else layer(z)
        return th.log_softmax(z, dim=-1)

    def state(k: int) -> dict:
        out = copy.deepcopy(models[k].state_dict())
        out.update({name: params[name][k].detach().clone() for name in names})
        return out

    best = [(-math.inf, 0, state(k), 0) for k in range(n)]  # (held-out LL, step, state, evaluations without gain)
    marks = [-math.inf] * n  # the held-out LL each candidate's patience counts from
    active = list(range(n))
    x_va, c_va = x[va], c[va]
    for step in range(1, max_steps + 1):
        batches = []
        for k in range(n):  # a stopped candidate takes another's rows (its slice is no longer read)
            if k in active:
                idx = tr[th.randint(0, len(tr), (batch_size,), device=x.device, generator=generators[k])]
                eps = th.randn((batch_size, c.shape[1]), generator=generators[k], device=x.device, dtype=c.dtype)
                batches.append((idx, eps))
            else:
                batches.append(None)
        batches = [b if b is not None else batches[active[0]] for b in batches]
        idx = th.stack([b[0] for b in batches])
        z = (c[idx] - mean) / std + th.stack([b[1] for b in batches]) * scale
        picked = log_probs(z).gather(2, x[idx].long().unsqueeze(-1)).squeeze(-1)
        losses = [-picked[k].mean() for k in range(n)]
        if not all(bool(th.isfinite(losses[k])) for k in active):
            raise _NonFinite
        opt.zero_grad(set_to_none=True)
        th.stack(losses).sum().backward()
        for k in range(n):  # clip_grad_norm_(candidate k's parameters, 10.0)
            grads = [params[name].grad[k] for name in names]
            total = th.nn.utils.get_total_norm(grads, 2.0)
            th._foreach_mul_(grads, th.clamp(10.0 / (total + 1e-6), max=1.0))
        opt.step()
        if step % eval_every == 0 or step == max_steps:
            with th.no_grad():  # evaluate_log_prob's chunks, so that every product has its shape there
                held_out = th.cat([
                    log_probs((c_va[i:i + EVAL_CHUNK] - mean) / std).gather(
                        2, x_va[i:i + EVAL_CHUNK].long().view(1, -1, 1).expand(n, -1, 1)).squeeze(-1)
                    for i in range(0, len(x_va), EVAL_CHUNK)], dim=1)
            for k in list(active):
                ll = float(held_out[k].contiguous().mean())
                ll = ll if math.isfinite(ll) else -math.inf
                best_ll, best_step, best_state, bad = best[k]
                if ll > best_ll:
                    best_ll, best_step, best_state = ll, step, state(k)
                if ll > marks[k] + min_delta:
                    marks[k], bad = ll, 0
                else:
                    bad += 1
                best[k] = (best_ll, best_step, best_state, bad)
                if bad >= patience:
                    active.remove(k)
        if not active:
            break
    out = []
    for k, model in enumerate(models):
        best_ll, best_step, best_state, _ = best[k]
        model.load_state_dict(best_state)
        model.eval()
        out.append((model, best_ll, best_step, best_state))
    return out
