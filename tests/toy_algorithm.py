"""A toy algorithm in a package of its own, registered with one line (the ``toy`` fixture), for the library's and
the harness's registration tests."""

import sys
import textwrap

import pytest

import sb3_mbil

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
