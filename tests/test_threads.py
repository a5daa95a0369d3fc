"""Training never thrashes the cores: learn runs with one intra-op thread, flushes subnormal floats, and restores the
caller's settings."""

import pytest
import torch as th
from stable_baselines3.common.callbacks import BaseCallback

import sb3_mbil.mbil.mbil
import sb3_mbil.mbil_c.models
from sb3_mbil import BC, MBIL, MBILC, learn_lockstep, load_demonstrations
from sb3_mbil.common.threads import flushing_subnormals


class ThreadsSeen(BaseCallback):
    def __init__(self):
        super().__init__()
        self.seen = set()

    def _on_training_start(self):
        self.seen.add(th.get_num_threads())

    def _on_step(self):
        self.seen.add(th.get_num_threads())
        return True


@pytest.fixture
def caller_threads():
    previous = th.get_num_threads()
    th.set_num_threads(3)
    yield 3
    th.set_num_threads(previous)


@pytest.mark.parametrize("cls, kwargs", [(BC, {}), (MBIL, dict(flow_max_steps=20, noise_grid=(0.1,), flow_hidden=(16,)))])
def test_learn_trains_with_one_thread_and_restores_the_callers(caller_threads, cls, kwargs, monkeypatch):
    monkeypatch.delenv("SB3_MBIL_TORCH_THREADS", raising=False)
    demo = load_demonstrations("CartPole-v1").sample(1, seed=0)
    model = cls("MlpPolicy", "CartPole-v1", expert_data=demo, seed=0, **kwargs)
    seen = ThreadsSeen()
    model.learn(5, callback=seen)
    assert seen.seen == {1}
    assert th.get_num_threads() == caller_threads


def test_the_thread_count_can_be_set_and_is_restored_after_an_error(caller_threads, monkeypatch):
    demo = load_demonstrations("CartPole-v1").sample(1, seed=0)
    model = BC("MlpPolicy", "CartPole-v1", expert_data=demo, seed=0)
    monkeypatch.setenv("SB3_MBIL_TORCH_THREADS", "2")
    seen = ThreadsSeen()
    model.learn(2, callback=seen)
    assert seen.seen == {2}
    model.torch_threads = 0  # torch's own (the caller's) setting
    seen = ThreadsSeen()
    model.learn(2, callback=seen)
    assert seen.seen == {caller_threads}
    model.torch_threads = None
    monkeypatch.setenv("SB3_MBIL_TORCH_THREADS", "many")
    with pytest.raises(ValueError, match="SB3_MBIL_TORCH_THREADS: expected an integer >= 0"):
        model.learn(2)
    monkeypatch.setenv("SB3_MBIL_TORCH_THREADS", "1")

    class Boom(BaseCallback):
        def _on_step(self):
            raise RuntimeError("boom")

    with pytest.raises(RuntimeError, match="boom"):
        model.learn(2, callback=Boom())
    assert th.get_num_threads() == caller_threads


class FlushSeen(BaseCallback):
    def __init__(self):
        super().__init__()
        self.seen = set()

    def _on_step(self):
        self.seen.add(flushing_subnormals())
        return True


def test_learn_flushes_subnormals_and_restores_the_callers_mode(monkeypatch):
    """Weight decay drives unused weights through the subnormal range, where the CPU is many times slower: training
    flushes them (benchmarks/probe_subnormals.py) unless SB3_MBIL_FLUSH_SUBNORMALS=0, and gives the mode back."""
    monkeypatch.delenv("SB3_MBIL_FLUSH_SUBNORMALS", raising=False)
    assert not flushing_subnormals()
    demo = load_demonstrations("CartPole-v1").sample(1, seed=0)
    models = [BC("MlpPolicy", "CartPole-v1", expert_data=demo, seed=s) for s in (0, 1)]
    seen = [FlushSeen(), FlushSeen()]
    learn_lockstep(models, 3, callbacks=seen)
    assert seen[0].seen == seen[1].seen == {True}
    assert not flushing_subnormals()
    seen = FlushSeen()
    models[0].learn(3, callback=seen)
    assert seen.seen == {True}
    assert not flushing_subnormals()
    monkeypatch.setenv("SB3_MBIL_FLUSH_SUBNORMALS", "0")
    seen = FlushSeen()
    models[0].learn(3, callback=seen)
    assert seen.seen == {False}
    monkeypatch.setenv("SB3_MBIL_FLUSH_SUBNORMALS", "yes")
    with pytest.raises(ValueError, match="SB3_MBIL_FLUSH_SUBNORMALS: expected 0 or 1, found 'yes'"):
        models[0].learn(3)
    monkeypatch.setenv("SB3_MBIL_FLUSH_SUBNORMALS", "1")
    th.set_flush_denormal(True)  # a caller that flushes already keeps flushing
    try:
        models[0].learn(3)
        assert flushing_subnormals()
    finally:
        th.set_flush_denormal(False)


@pytest.mark.parametrize("cls, module, fit, kwargs", [
    (MBIL, sb3_mbil.mbil.mbil, "fit_flows", dict(flow_max_steps=20, noise_grid=(0.1,), flow_hidden=(16,))),
    (MBILC, sb3_mbil.mbil_c.models, "fit_models", dict(alpha_model=0.0, model_max_steps=20)),
])
def test_a_fit_called_outside_learn_trains_as_learn_does(caller_threads, cls, module, fit, kwargs, monkeypatch):
    """MBIL's fit_flows and MBIL-C's fit_models, called by a user before learn: one thread, subnormals flushed, and
    the caller's settings back afterwards."""
    monkeypatch.delenv("SB3_MBIL_TORCH_THREADS", raising=False)
    monkeypatch.delenv("SB3_MBIL_FLUSH_SUBNORMALS", raising=False)
    seen = []
    real = module.fit_conditional_density

    def spy(*args, **kw):
        seen.append((th.get_num_threads(), flushing_subnormals()))
        return real(*args, **kw)

    monkeypatch.setattr(module, "fit_conditional_density", spy)
    demo = load_demonstrations("CartPole-v1").sample(1, seed=0)
    getattr(cls("MlpPolicy", "CartPole-v1", expert_data=demo, seed=0, **kwargs), fit)()
    assert seen and set(seen) == {(1, True)}
    assert th.get_num_threads() == caller_threads
    assert not flushing_subnormals()
