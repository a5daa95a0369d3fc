"""Seeds in lockstep (sb3_mbil.learn_lockstep): each seed ends where its separate run ends, as an ordinary model."""

import numpy as np
import pytest
import torch as th
from stable_baselines3.common.callbacks import BaseCallback

from sb3_mbil import BC, DSFN, MBIL, MBILC, RCAL, IQLearn, learn_lockstep, train_seeds
from sb3_mbil.common.type_aliases import PairSamples

FAST = {MBIL: {"flow_max_steps": 30, "noise_grid": (0.1,)}, MBILC: {"model_max_steps": 30, "model_noise_grid": (0.1,)}}


def draws(data, seeds):
    """One draw of the data per seed (trajectories in a seed-dependent order, so that the seeds' data differ)."""
    return [[data[(k + s) % len(data)] for k in range(len(data))][: 1 + s % len(data)] for s in seeds]


def max_gap(a, b):
    return max(float((p.detach() - q.detach()).abs().max()) for p, q in zip(a.policy.parameters(), b.policy.parameters()))


#: every lockstep algorithm for 1 000 updates on Discrete actions, and the Box losses and other terms for 300
CASES = [(BC, "CartPole-v1", {}, 1000), (MBIL, "CartPole-v1", {}, 1000), (MBILC, "CartPole-v1", {}, 1000),
         (RCAL, "CartPole-v1", {}, 1000), (IQLearn, "CartPole-v1", {}, 1000),
         (BC, "Pendulum-v1", {"observation_noise": 0.1}, 300),
         (BC, "Pendulum-v1", {"bc_loss": "tanh_nll", "policy_kwargs": {"bounded_mean": True}}, 300),
         (BC, "Pendulum-v1", {"policy_kwargs": {"normalize_observations": True, "bounded_mean": True}}, 300),
         (MBIL, "Pendulum-v1", {}, 300), (MBILC, "Pendulum-v1", {}, 300),
         (MBILC, "CartPole-v1", {"alpha_model": 0.5, "weight_decay": 1e-3, "logit_penalty": 0.1}, 300)]


@pytest.mark.parametrize("algo,env_id,kwargs,steps", CASES, ids=lambda v: getattr(v, "__name__", str(v)))
def test_lockstep_seeds_follow_their_separate_runs(algo, env_id, kwargs, steps, cartpole_data, pendulum_data):
    data = cartpole_data if env_id == "CartPole-v1" else pendulum_data
    seeds = [3, 4]
    settings = {**FAST.get(algo, {}), **kwargs}
    separate = []
    for s, d in zip(seeds, draws(data, seeds)):  # each built right before its learn, as a run of its own
        separate.append(algo("MlpPolicy", env_id, expert_data=d, seed=s, **settings))
        separate[-1].learn(steps)
    lockstep = learn_lockstep([algo("MlpPolicy", env_id, expert_data=d, seed=s, **settings)
                               for s, d in zip(seeds, draws(data, seeds))], steps)
    for one, other in zip(separate, lockstep):
        assert other.num_timesteps == one.num_timesteps == steps
        assert max_gap(one, other) <= 1e-5
        assert th.equal(one._rng_torch, other._rng_torch)  # the training stream went as far
        for p, q in zip(one.policy.parameters(), other.policy.parameters()):  # and the optimiser's state
            for key, value in one.policy.optimizer.state[p].items():
                assert th.allclose(value, other.policy.optimizer.state[q][key], atol=1e-6), key
        # each owns its tensors (no view of the stack is left)
        assert all(p.untyped_storage().nbytes() == p.nbytes for p in other.policy.parameters())


def test_a_lockstep_model_is_an_ordinary_model(cartpole_data, tmp_path):
    seeds = [0, 1]
    models = train_seeds(BC, "CartPole-v1", draws(cartpole_data, seeds), seeds, 300)
    separate = BC("MlpPolicy", "CartPole-v1", expert_data=draws(cartpole_data, seeds)[1], seed=1)
    separate.learn(300)
    models[1].save(tmp_path / "bc")
    loaded = BC.load(tmp_path / "bc", env="CartPole-v1", expert_data=draws(cartpole_data, seeds)[1])
    assert max_gap(loaded, separate) <= 1e-6
    # training continued after load follows the separate run continued in memory
    loaded.learn(200, reset_num_timesteps=False)
    separate.learn(200, reset_num_timesteps=False)
    assert max_gap(loaded, separate) <= 1e-5
    obs = np.asarray([d[0][0] for d in cartpole_data])
    assert np.array_equal(loaded.predict(obs, deterministic=True)[0], separate.predict(obs, deterministic=True)[0])


class StopAt(BaseCallback):
    def __init__(self, step):
        super().__init__()
        self.step = step

    def _on_step(self):
        return self.num_timesteps < self.step


def test_a_callback_stops_its_own_seed_only(cartpole_data):
    seeds = [0, 1, 2]
    make = [lambda s=s, d=d: BC("MlpPolicy", "CartPole-v1", expert_data=d, seed=s)
            for s, d in zip(seeds, draws(cartpole_data, seeds))]
    models = learn_lockstep([m() for m in make], 400, callbacks=[None, StopAt(150), None])
    assert [m.num_timesteps for m in models] == [400, 150, 400]
    stopped = make[1]()
    stopped.learn(400, callback=StopAt(150))
    other = make[2]()
    other.learn(400)
    assert max_gap(models[1], stopped) <= 1e-6
    assert max_gap(models[2], other) <= 1e-5


def test_lockstep_refuses_what_cannot_share_one_loss(cartpole_data, pendulum_data):
    with pytest.raises(ValueError, match=r"models\[1\]\.alpha: expected the same setting"):
        learn_lockstep([MBIL("MlpPolicy", "CartPole-v1", expert_data=cartpole_data, seed=0),
                        MBIL("MlpPolicy", "CartPole-v1", expert_data=cartpole_data, seed=1, alpha=0.5)], 10)
    with pytest.raises(ValueError, match=r"models\[0\]: expected an algorithm whose update is one loss"):
        learn_lockstep([DSFN("MlpPolicy", "CartPole-v1", expert_data=cartpole_data, seed=0)], 10)
    with pytest.raises(ValueError, match=r"IQLearn with Box actions"):
        learn_lockstep([IQLearn("MlpPolicy", "Pendulum-v1", expert_data=pendulum_data, seed=0)], 10)
    with pytest.raises(ValueError, match=r"models\[1\]: expected every model to be a BC, found a RCAL"):
        learn_lockstep([BC("MlpPolicy", "CartPole-v1", expert_data=cartpole_data, seed=0),
                        RCAL("MlpPolicy", "CartPole-v1", expert_data=cartpole_data, seed=1)], 10)
    model = BC("MlpPolicy", "CartPole-v1", expert_data=cartpole_data, seed=0)
    with pytest.raises(ValueError, match=r"models\[1\]: expected distinct models"):
        learn_lockstep([model, model], 10)
    with pytest.raises(ValueError, match=r"models: expected a non-empty list"):
        learn_lockstep([], 10)


def test_a_non_finite_loss_in_one_seed_stops_with_its_term_and_step(cartpole_data):
    models = [BC("MlpPolicy", "CartPole-v1", expert_data=cartpole_data, seed=s) for s in (0, 1)]
    draw = models[1]._draw_batch

    def poisoned():  # seed 1's states turn infinite from its 30th update on
        batch = draw()
        if models[1].num_timesteps >= 29:
            return PairSamples(batch.observations * float("inf"), batch.actions)
        return batch

    models[1]._draw_batch = poisoned
    with pytest.raises(FloatingPointError, match=r"BC: train/bc_loss is nan at gradient step 30"):
        learn_lockstep(models, 200)
    assert all(not m._data_in_use for m in models)


def test_trained_models_continue_in_lockstep_with_their_optimiser_and_schedule(cartpole_data):
    def trained(seed):  # a schedule object of its own per model: equal values are the same setting
        model = BC("MlpPolicy", "CartPole-v1", expert_data=cartpole_data[seed:], seed=seed,
                   learning_rate=lambda progress: 1e-3 * progress)
        return model.learn(100)

    separate, lockstep = [trained(0), trained(1)], [trained(0), trained(1)]
    for model in separate:
        model.learn(100, reset_num_timesteps=False)
    learn_lockstep(lockstep, 100, reset_num_timesteps=False)
    for one, other in zip(separate, lockstep):
        assert other.num_timesteps == 200 and max_gap(one, other) == 0.0
        assert other.policy.optimizer.param_groups[0]["lr"] == one.policy.optimizer.param_groups[0]["lr"]
    assert learn_lockstep([BC("MlpPolicy", "CartPole-v1", expert_data=cartpole_data, seed=s) for s in (0, 1)], 0)
