"""Logging and progress: tensorboard runs named after the algorithm, holding each algorithm's training terms;
progress lines while the density models are fitted (verbose >= 1)."""

import re

import pytest
from tensorboard.backend.event_processing.event_accumulator import EventAccumulator
from test_algorithms import make

from sb3_mbil import BC, MBIL, MBILC


@pytest.mark.parametrize("algo, tags", [(MBIL, {"train/balance_loss", "train/bc_loss", "flows/target_mean"}),
                                        (MBILC, {"train/balance_loss", "train/bc_loss"}),
                                        (BC, {"train/bc_loss"})])
def test_tensorboard_run_is_named_after_the_algorithm_and_holds_its_terms(algo, tags, cartpole_data, tmp_path):
    model = make(algo, "CartPole-v1", cartpole_data, tensorboard_log=str(tmp_path))
    model.learn(40, log_interval=10)
    model.learn(20, log_interval=10, reset_num_timesteps=False)  # continued training: the same run
    runs = sorted(p.name for p in tmp_path.iterdir())
    assert runs == [f"{algo.__name__}_1"]
    events = EventAccumulator(str(tmp_path / runs[0]))
    events.Reload()
    scalars = set(events.Tags()["scalars"])
    assert tags <= scalars, scalars
    steps = [e.step for e in events.Scalars("train/bc_loss")]
    assert steps == [10, 20, 30, 40, 50, 60]


@pytest.mark.parametrize("algo, models, kwargs", [(MBIL, ["P(a' | s, a, s')"], {}),
                                                   (MBIL, ["T(s' | s, a)", "P(a' | s, a, s')"], {"fit_transition": True}),
                                                   (MBILC, ["P(a' | s, a, s')", "T(s' | s, a)"], {"alpha_model": 1.0})])
def test_fitting_prints_progress_when_verbose(algo, models, kwargs, cartpole_data, capsys):
    make(algo, "CartPole-v1", cartpole_data, verbose=1, **kwargs).learn(1)
    out = capsys.readouterr().out
    assert "expert tuples" in out
    assert (algo is not MBIL) or (("T(s' | s, a)" in out) == bool(kwargs))  # MBIL fits T only when asked
    for name in models:
        assert re.search(re.escape(f"{algo.__name__}: {name}: noise ") + r"[0-9.]+: held-out log-likelihood -?[0-9.]+ at step", out)
    make(algo, "CartPole-v1", cartpole_data, verbose=0).learn(1)
    assert capsys.readouterr().out == ""
