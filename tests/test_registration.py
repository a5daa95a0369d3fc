"""Adding an algorithm is its folder and one registry line: a toy algorithm in a package of its own is picked up by
the zoo bridge (sampler, converter, hyperparameters), the harness and the SB3 contract."""

import sys
import textwrap

import gymnasium as gym
import numpy as np
import optuna
import pytest

import sb3_mbil
from sb3_mbil import load_demonstrations

TOY = {
    "toyalgo/__init__.py": "from toyalgo.toy import Toy\n",
    "toyalgo/toy.py": '''
        """A toy algorithm: BC with a halved learning rate (objective: the BC loss)."""
        from sb3_mbil.bc import BC


        class Toy(BC):
            """min_theta  L_BC(pi_theta, D), trained at half the given learning rate."""

            def _setup_lr_schedule(self):
                super()._setup_lr_schedule()
                schedule = self.lr_schedule
                self.lr_schedule = lambda progress: 0.5 * schedule(progress)
        ''',
    "toyalgo/zoo.py": '''
        from sb3_mbil.common.zoo_params import common_params, convert_policy_params


        def sample_params(trial, n_actions, n_envs, additional_args):
            return convert_params(common_params(trial))


        def convert_params(params):
            return convert_policy_params(params)
        ''',
    "toyalgo/toy.yml": "CartPole-v1:\n  n_timesteps: 20\n  policy: 'MlpPolicy'\n  expert_pool: CartPole-v1\n",
}


@pytest.fixture
def toy(tmp_path, monkeypatch):
    for name, text in TOY.items():
        path = tmp_path / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(textwrap.dedent(text))
    monkeypatch.syspath_prepend(str(tmp_path))
    from toyalgo import Toy

    monkeypatch.setitem(sb3_mbil.ALGORITHMS, "toy", Toy)  # the one line of a registration
    from sb3_mbil import zoo

    monkeypatch.setattr(zoo, "SAMPLERS", zoo._PerAlgorithm("sample_params"))
    monkeypatch.setattr(zoo, "CONVERTERS", zoo._PerAlgorithm("convert_params"))
    yield Toy
    sys.modules.pop("toyalgo", None)
    sys.modules.pop("toyalgo.toy", None)
    sys.modules.pop("toyalgo.zoo", None)


def test_a_toy_algorithm_is_picked_up_by_the_zoo_the_harness_and_the_contract(toy, tmp_path):
    from sb3_mbil import zoo
    from sb3_mbil.benchmark.grid import Run, run_one, tuned_settings

    zoo.check_registration()  # sampler, converter and hyperparameter file found from the folder
    trial = optuna.create_study(sampler=optuna.samplers.RandomSampler(seed=0)).ask()
    params = zoo.SAMPLERS["toy"](trial, 2, 1, {})
    assert set(params) >= {"learning_rate", "batch_size", "policy_kwargs"}
    assert tuned_settings("toy", "CartPole-v1")["n_timesteps"] == 20
    row = run_one(Run("toy", "CartPole-v1", 1, 0), n_episodes=2)
    assert row["algo"] == "toy" and row["gradient_steps"] == 20
    # the SB3 contract: learn, save, load (safe), the same predictions
    demos = load_demonstrations("CartPole-v1").sample(1, seed=0)
    model = toy("MlpPolicy", "CartPole-v1", expert_data=demos, seed=0, **params).learn(10)
    model.save(tmp_path / "toy.zip")
    loaded = toy.load(tmp_path / "toy.zip", safe=True)
    obs = np.stack([gym.make("CartPole-v1").observation_space.sample() for _ in range(8)])
    np.testing.assert_array_equal(model.predict(obs, deterministic=True)[0], loaded.predict(obs, deterministic=True)[0])
