"""Seeds in lockstep: several models of one algorithm, with the same settings and their own seeds and data, trained in
one process as one batched network.

Each model keeps everything a separate ``learn`` gives it: its own initial parameters, its own training random stream
(a generator per model, started where ``learn`` would start it, so it draws the same minibatches), its own data and
fitted models (MBIL's flows, MBIL-C's P), callbacks, logger and finite checks. Only the update is shared: the
policies' parameters are stacked on a leading seed dimension, their outputs computed for every seed at once
(:meth:`~sb3_mbil.common.policies.ImitationPolicy.stacked_heads`), the algorithm's own loss from those outputs
(``_loss_from_heads``) evaluated per seed with ``torch.func.vmap``, and one Adam steps the stacked parameters. Each
seed ends **bit for bit** where its separate run ends: the linear products are taken per seed as a single layer
takes them (:class:`~sb3_mbil.common.policies.StackedLinear`), and Adam and its weight decay are elementwise (the
tests compare every parameter after 1 000 updates).

During training each model's parameters are views of the stacked ones (its callbacks see it train); at the end each
model owns its parameters and its optimiser's state again, and is an ordinary model of its algorithm (``save``,
``load``, ``learn`` to continue).

    models = [BC("MlpPolicy", "CartPole-v1", expert_data=draw, seed=seed) for seed, draw in zip(seeds, draws)]
    learn_lockstep(models, 10_000)
    # or: models = train_seeds(BC, "CartPole-v1", draws, seeds, 10_000)
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import torch as th
from stable_baselines3.common.type_aliases import MaybeCallback
from torch.func import vmap

from sb3_mbil.common.offline import FINITE_CHECK_EVERY, OfflineAlgorithm, encode_numpy_state
from sb3_mbil.common.threads import training_cpu

#: updates between the checks that every model's minibatch has the form of the first's (and at the first)
FORM_CHECK_EVERY = 1000

#: constructor arguments that may differ between the seeds of one lockstep run
PER_MODEL_ARGUMENTS = {"self", "policy", "env", "expert_data", "seed", "verbose", "tensorboard_log", "device",
                       "_init_setup_model"}


def _settings(model: OfflineAlgorithm) -> dict[str, Any]:
    """The model's constructor settings that its loss reads (every argument but the per-model ones)."""
    names = [n for n in inspect.signature(type(model).__init__).parameters if n not in PER_MODEL_ARGUMENTS]
    return {n: getattr(model, n, None) for n in names}


def check_lockstep(models: Sequence[OfflineAlgorithm]) -> None:
    """Refuse, naming the model and the field, what cannot train as one batched network."""
    if not isinstance(models, Sequence) or len(models) == 0:
        raise ValueError(f"models: expected a non-empty list of models, found {models!r}")
    first = models[0]
    for n, model in enumerate(models):
        if not isinstance(model, OfflineAlgorithm):
            raise ValueError(f"models[{n}]: expected an sb3_mbil algorithm, found {type(model).__name__}")
        if type(model) is not type(first):
            raise ValueError(f"models[{n}]: expected every model to be a {type(first).__name__}, found a "
                             f"{type(model).__name__}")
        if not model.supports_lockstep():
            raise ValueError(f"models[{n}]: expected an algorithm whose update is one loss of the policy "
                             f"(BC, MBIL, MBIL-C, RCAL, IQ-Learn with Discrete actions), found {type(model).__name__} "
                             f"with {type(model.action_space).__name__} actions")
        if any(model is other for other in models[:n]):
            raise ValueError(f"models[{n}]: expected distinct models, found models[{n}] repeated")
        if n == 0:
            continue
        mine, theirs = _settings(model), _settings(first)
        for key in mine:
            if not _same(mine[key], theirs[key]):
                raise ValueError(f"models[{n}].{key}: expected the same setting as models[0] ({theirs[key]!r}: the "
                                 f"seeds share one loss), found {mine[key]!r}")
        if model.device != first.device:
            raise ValueError(f"models[{n}].device: expected {first.device}, found {model.device}")
        if model.num_timesteps != first.num_timesteps:
            raise ValueError(f"models[{n}].num_timesteps: expected {first.num_timesteps} like models[0] (the seeds "
                             f"step together), found {model.num_timesteps}")


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, type) or isinstance(b, type):
        return a is b
    if callable(a) and callable(b):  # schedules (e.g. a learning rate's): the same values from 1 to 0 of progress
        try:
            return a is b or all(a(p / 10) == b(p / 10) for p in range(11))
        except Exception:
            return False
    try:
        return bool(a == b)
    except Exception:
        return a is b


def _loss_from_heads(algorithm: OfflineAlgorithm) -> Callable:
    """``algorithm._loss_from_heads`` for one seed, its recorded values returned beside the loss (for ``vmap``)."""
    def loss(batch: Any, heads: tuple[th.Tensor, ...]) -> tuple[th.Tensor, dict[str, th.Tensor]]:
        algorithm._record_sink = {}
        try:
            value = algorithm._loss_from_heads(batch, heads)
            return value, dict(algorithm._record_sink)
        finally:
            algorithm._record_sink = None
    return loss


class _Stack:
    """The models' policy parameters stacked on a seed dimension, each model's parameters views of them."""

    def __init__(self, models: Sequence[OfflineAlgorithm]):
        self.models = list(models)
        policy = models[0].policy
        self.names = [n for n, p in policy.named_parameters() if p.requires_grad]
        self.params = {n: th.stack([m.policy.get_parameter(n).detach() for m in models]).requires_grad_(True)
                       for n in self.names}
        self.buffers = {n: th.stack([m.policy.get_buffer(n) for m in models]) for n, _ in policy.named_buffers()}
        for i, model in enumerate(models):
            for n in self.names:
                model.policy.get_parameter(n).data = self.params[n].data[i]
        source = policy.optimizer
        # one optimiser over the stacked tensors; Adam's update is elementwise, so each slice steps as its own model's
        # optimiser would (foreach: a few large kernels instead of many small ones, the same arithmetic)
        defaults = dict(source.defaults)
        if "foreach" in defaults and not defaults.get("fused"):
            defaults["foreach"] = True
        self.optimizer = type(source)([self.params[n] for n in self.names], **defaults)
        states = [m.policy.optimizer.state for m in models]
        if any(len(s) for s in states):  # continued training: stack each model's optimiser state
            for n in self.names:
                per_model = [m.policy.optimizer.state.get(m.policy.get_parameter(n), {}) for m in models]
                keys = set(per_model[0])
                if any(set(s) != keys for s in per_model) or not keys:
                    raise ValueError(f"models: expected every model's optimiser to hold state for {n} (all trained "
                                     "as far, or none trained), found some with and some without")
                self.optimizer.state[self.params[n]] = {
                    k: (th.stack([s[k] for s in per_model]) if per_model[0][k].dim() > 0 else per_model[0][k].clone())
                    for k in keys}

    def release(self, i: int) -> None:
        """Give model ``i`` its own parameters and optimiser state back (a copy of its slice)."""
        model = self.models[i]
        for n in self.names:
            param = model.policy.get_parameter(n)
            param.data = self.params[n].data[i].clone()
            state = self.optimizer.state.get(self.params[n])
            if state:
                model.policy.optimizer.state[param] = {
                    k: (v[i].clone() if th.is_tensor(v) and v.dim() > 0 else (v.clone() if th.is_tensor(v) else v))
                    for k, v in state.items()}


def _stack(items: list[Any]) -> Any:
    """Stack the models' batches field by field (tensors on a new seed dimension; ``None`` stays ``None``)."""
    first = items[0]
    if first is None:
        return None
    if isinstance(first, th.Tensor):
        return th.stack(items)
    fields = [_stack(list(column)) for column in zip(*items)]
    return type(first)(*fields) if hasattr(first, "_fields") else type(first)(fields)


def _in_dims(batch: Any) -> Any:
    """vmap's ``in_dims`` for a stacked batch: 0 for a tensor, None for an absent field."""
    if batch is None or isinstance(batch, th.Tensor):
        return None if batch is None else 0
    fields = [_in_dims(field) for field in batch]
    return type(batch)(*fields) if hasattr(batch, "_fields") else type(batch)(fields)


def _check_forms(batches: list[Any]) -> None:
    """Every model's batch has the form of models[0]'s: the same fields, present or absent, of the same shapes."""
    def form(batch):
        if batch is None or isinstance(batch, th.Tensor):
            return None if batch is None else (tuple(batch.shape), batch.dtype)
        if not isinstance(batch, tuple):
            raise TypeError(f"_draw_batch: expected tensors in (named) tuples, found {type(batch).__name__}")
        return type(batch), tuple(form(field) for field in batch)

    reference = form(batches[0])
    for n, batch in enumerate(batches[1:], start=1):
        if form(batch) != reference:
            raise ValueError(f"models[{n}]: expected a minibatch of the same form as models[0]'s (the same settings on "
                             f"data of the same kind), found {form(batch)} against {reference}")


def learn_lockstep(models: Sequence[OfflineAlgorithm], total_timesteps: int,
                   callbacks: Sequence[MaybeCallback] | None = None, log_interval: int = 1000,
                   tb_log_name: str | None = None, reset_num_timesteps: bool = True,
                   progress_bar: bool = False) -> list[OfflineAlgorithm]:
    """Train ``models`` (one algorithm, the same settings; their own seeds and data) for ``total_timesteps`` gradient
    steps each, as one batched network; each ends bit for bit as its own ``learn(total_timesteps)`` would have left it
    (see the module's docstring). ``callbacks``: one per model (or None); a callback that stops its model's training
    releases that model while the others go on. Returns the models."""
    check_lockstep(models)
    models = list(models)
    if callbacks is None:
        callbacks = [None] * len(models)
    if len(callbacks) != len(models):
        raise ValueError(f"callbacks: expected one per model ({len(models)}), found {len(callbacks)}")
    with training_cpu(models[0]):
        return _learn(models, total_timesteps, list(callbacks), log_interval, tb_log_name, reset_num_timesteps,
                      progress_bar)


def _learn(models, total_timesteps, callbacks, log_interval, tb_log_name, reset_num_timesteps, progress_bar):
    started: list[OfflineAlgorithm] = []
    try:
        totals = []
        for n, model in enumerate(models):
            _start_stream(model)
            with model._training_rng():  # the models' fits draw from each model's own stream, as in learn
                total, callbacks[n] = model._begin_learning(total_timesteps, callbacks[n], tb_log_name,
                                                            reset_num_timesteps, progress_bar)
            started.append(model)
            totals.append(total)
            generator = th.Generator(device=model.device)
            if len(model._rng_torch):
                generator.set_state(model._rng_torch)
            model._lockstep_generator = generator
        total = totals[0]
        stack = _Stack(models)
        loss_of, losses, batch_dims = _loss_from_heads(models[0]), None, None
        raw = models[0]._raw_heads()
        active = list(range(len(models)))
        last: list[Any] = [None] * len(models)
        lead = models[0]
        # a callback may read the logs or stop its model at any step: then the values are handed over every step
        has_callbacks = any(not _is_empty(c) for c in callbacks)
        window_start = lead.num_timesteps + 1
        window: list[dict[str, th.Tensor]] = []  # the recorded values since the last flush, [seeds] each

        def flush(first_step: int) -> None:  # into each model's window, where its finite checks and logs read them
            if window:
                columns = {key: th.stack([r[key] for r in window]) for key in window[0]}
                for n in active:
                    for key, values in columns.items():
                        models[n]._window.setdefault(key, []).append((first_step, values[:, n]))
                window.clear()

        while lead.num_timesteps < total and active and not lead.training_complete():
            step = lead.num_timesteps
            for n in active:
                models[n]._update_current_progress_remaining(step, total)
            for group in stack.optimizer.param_groups:
                group["lr"] = lead.lr_schedule(lead._current_progress_remaining)
            for n in active:
                last[n] = models[n]._draw_batch()
            # a model released early keeps its slot with another's batch (its slice is no longer read)
            batches = [last[n] if n in active else last[active[0]] for n in range(len(models))]
            if losses is None or step % FORM_CHECK_EVERY == 0:
                _check_forms(batches)
            batch = _stack(batches)
            inputs = th.stack([models[n]._policy_inputs(b) for n, b in enumerate(batches)])
            in_dims = _in_dims(batch)
            if losses is None or in_dims != batch_dims:  # MBIL-C's fused update adds fields every 10th step
                losses, batch_dims = vmap(loss_of, in_dims=(in_dims, 0)), in_dims
            # the policies' outputs as batched matrix products; the loss per seed with vmap; seed i's gradient is its
            # own loss's (its outputs depend on its parameters alone)
            heads = lead.policy.stacked_heads(stack.params, stack.buffers, inputs, raw=raw)
            loss, records = losses(batch, heads)
            stack.optimizer.zero_grad(set_to_none=True)
            loss.sum().backward()
            stack.optimizer.step()
            records = {key: value.detach() for key, value in records.items()}
            if window and set(records) != set(window[0]):
                flush(window_start)
            if not window:
                window_start = step + 1
            window.append(records)
            logs = log_interval > 0 and (step + 1) % log_interval == 0
            if (step + 1) % FINITE_CHECK_EVERY == 0 or logs or step + 1 >= total or has_callbacks:
                flush(window_start)
            for n in list(active):
                model = models[n]
                if logs:  # SB3 logs the learning rate it set (the stack's is set every step)
                    model._update_learning_rate(model._optimizers())
                if not model._end_step(callbacks[n], log_interval):
                    _finish(stack, n, callbacks[n])
                    active.remove(n)
        flush(window_start if window else 0)
        for n in active:
            _finish(stack, n, callbacks[n])
        return models
    finally:
        for model in started:
            model._data_in_use = False
            model._record_sink = None
            generator = getattr(model, "_lockstep_generator", None)
            if generator is not None:
                model._rng_torch = generator.get_state()
            model._lockstep_generator = None
            for p in model.policy.parameters():  # never leave a model holding a view of the stack
                if p.data.storage_offset() or p.data.untyped_storage().nbytes() != p.data.nbytes:
                    p.data = p.data.clone()


def _start_stream(model: OfflineAlgorithm) -> None:
    """A model that never trained starts its training stream at its first ``learn`` from torch's and numpy's global
    generators as they are then (SB3's way): right after its construction, the state its seed left. Models built
    one after the other share the global generators, so here each gets the state its own construction left: that of
    a twin built from its seed and settings (without data). Without a seed, a fresh random stream."""
    if len(model._rng_torch):
        return  # continues the stream its last learn left
    if model.seed is None:
        generator = th.Generator()
        generator.seed()
        model._rng_torch = generator.get_state()
        model._rng_numpy = encode_numpy_state(np.random.RandomState(generator.initial_seed() % 2**32).get_state())
        return
    with th.random.fork_rng(devices=[]):
        numpy_state = np.random.get_state()
        try:
            twin = type(model)(model.policy_class, model.env, seed=model.seed, **_settings(model))
            twin._capture_rng()
        finally:
            np.random.set_state(numpy_state)
    model._rng_torch, model._rng_numpy = twin._rng_torch, twin._rng_numpy


def _is_empty(callback) -> bool:
    """SB3's callback for ``callback=None`` (a list without callbacks, maybe under a progress bar's)."""
    from stable_baselines3.common.callbacks import CallbackList

    return isinstance(callback, CallbackList) and not callback.callbacks


def _finish(stack: _Stack, n: int, callback) -> None:
    model = stack.models[n]
    model._update_learning_rate(model._optimizers())
    stack.release(n)
    model._finish_learning(callback)


def train_seeds(algorithm: type[OfflineAlgorithm], env, draws: Sequence[Any], seeds: Sequence[int],
                total_timesteps: int, policy: str = "MlpPolicy", **kwargs) -> list[OfflineAlgorithm]:
    """Train these seeds of this algorithm on these draws (one expert data per seed) in lockstep: the models a
    separate ``algorithm(policy, env, expert_data=draw, seed=seed, **kwargs).learn(total_timesteps)`` per seed gives.
    ``env``: an env id (each model makes its own env) or an env per seed."""
    if len(draws) != len(seeds):
        raise ValueError(f"draws: expected one per seed ({len(seeds)}), found {len(draws)}")
    envs = env if isinstance(env, (list, tuple)) else [env] * len(seeds)
    if len(envs) != len(seeds):
        raise ValueError(f"env: expected an env id or one env per seed ({len(seeds)}), found {len(envs)}")
    models = [algorithm(policy, e, expert_data=draw, seed=seed, **kwargs) for e, draw, seed in zip(envs, draws, seeds)]
    return learn_lockstep(models, total_timesteps)
