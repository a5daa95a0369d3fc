"""Policy export (sb3_mbil.export_policy): the ONNX graph, run by onnxruntime without our package, gives the
actions of ``predict(..., deterministic=True)`` on the expert states, for every algorithm and action space."""

import numpy as np
import onnxruntime as ort  # the test extra installs it
import pytest
from test_algorithms import CASES, make

from sb3_mbil import export_policy


@pytest.fixture
def data(cartpole_data, pendulum_data):
    return {"CartPole-v1": cartpole_data, "Pendulum-v1": pendulum_data}


@pytest.mark.parametrize("algo, env_id", CASES)
def test_exported_policy_acts_like_predict(algo, env_id, data, tmp_path):
    kwargs = {"policy_kwargs": {"normalize_observations": True, "bounded_mean": True}} if env_id == "Pendulum-v1" else {}
    model = make(algo, env_id, data[env_id], **kwargs).learn(100)
    path = export_policy(model, tmp_path / "policy.onnx")
    states = model.expert_pairs().observations.numpy()
    states = np.concatenate([states, states * 3.0])  # and states outside the data (clipping, saturation)
    exported = ort.InferenceSession(str(path)).run(None, {"observation": states})[0]
    expected, _ = model.predict(states, deterministic=True)
    if env_id == "CartPole-v1":
        assert exported.dtype == np.int64
        np.testing.assert_array_equal(exported.reshape(expected.shape), expected)
    else:
        np.testing.assert_allclose(exported.reshape(expected.shape), expected, atol=1e-5)
        assert np.all(np.abs(exported) <= 2.0)


def test_export_refuses_what_it_cannot_export(tmp_path):
    with pytest.raises(ValueError, match="model: expected an SB3 model with a policy"):
        export_policy(object(), tmp_path / "x.onnx")
    assert not (tmp_path / "x.onnx").exists()
