"""Export the deterministic actor of any of our models to ONNX, to deploy without this package (or torch).

    from sb3_mbil import MBIL, export_policy
    export_policy(MBIL.load("mbil.zip"), "mbil.onnx")

    import onnxruntime as ort                      # on the robot: onnxruntime and numpy only
    session = ort.InferenceSession("mbil.onnx")
    action = session.run(None, {"observation": obs[None].astype("float32")})[0]

The graph is the policy's own ``predict(obs, deterministic=True)``: input standardisation (when the policy
has it), the network, the greedy action (Discrete, int64) or the mean action clipped to the action bounds
(Box, float32), for a batch of flat observations. Needs the ``export`` extra (onnx, onnxscript).

Image observations: SB3 trains on them channels first (it wraps an env whose images are height-width-channel in
``VecTransposeImage``), while the env returns them channels last. The exported graph takes the observations as the
env returns them: when the model's env is so wrapped (or ``input_layout="env"``), the graph takes (H, W, C) images,
flattened, and transposes them itself, as ``predict`` does; ``input_layout="policy"`` takes the policy's (C, H, W).
"""

from __future__ import annotations

import os
from pathlib import Path

import torch as th
from gymnasium import spaces
from torch import nn

from sb3_mbil.common.files import atomic_write


class DeterministicActor(nn.Module):
    """``predict(obs, deterministic=True)`` of an SB3 policy as a plain module (batch of flat float32 observations)."""

    def __init__(self, policy, channels_last: bool = False):
        super().__init__()
        self.policy = policy
        self.channels_last = channels_last
        self.discrete = isinstance(policy.action_space, spaces.Discrete)
        if not self.discrete:
            self.register_buffer("low", th.as_tensor(policy.action_space.low, dtype=th.float32))
            self.register_buffer("high", th.as_tensor(policy.action_space.high, dtype=th.float32))

    def forward(self, observation: th.Tensor) -> th.Tensor:
        shape = self.policy.observation_space.shape
        if self.channels_last:  # the env's (H, W, C) images to the policy's (C, H, W)
            obs = observation.reshape(observation.shape[0], shape[1], shape[2], shape[0]).permute(0, 3, 1, 2)
        else:
            obs = observation.reshape(observation.shape[0], *shape)
        action = self.policy._predict(obs, deterministic=True)
        if self.discrete:
            return action.long()
        return th.maximum(th.minimum(action, self.high), self.low)  # SB3's predict clips to the bounds


def export_policy(model, path: str | os.PathLike, input_layout: str | None = None) -> Path:
    """Write the model's deterministic actor to ``path`` (ONNX; input ``observation`` of shape (batch, obs_dim),
    output ``action``). Written whole or not at all. Returns the path.

    :param input_layout: ``"env"``: image observations as the env returns them, (H, W, C) flattened; ``"policy"``:
        as the policy sees them, (C, H, W) flattened. Default: ``"env"`` when the model's env is wrapped in SB3's
        ``VecTransposeImage``, else ``"policy"`` (the two are the same for vector observations).
    """
    from stable_baselines3.common.vec_env import VecTransposeImage, is_vecenv_wrapped

    if input_layout is None:
        env = getattr(model, "env", None)
        input_layout = "env" if env is not None and is_vecenv_wrapped(env, VecTransposeImage) else "policy"
    if input_layout not in ("env", "policy"):
        raise ValueError(f"input_layout: expected 'env' or 'policy', found {input_layout!r}")

    policy = getattr(model, "policy", None)
    if policy is None or not isinstance(policy.observation_space, spaces.Box):
        raise ValueError(f"model: expected an SB3 model with a policy over a Box observation space, found {type(model).__name__}")
    if not isinstance(policy.action_space, (spaces.Discrete, spaces.Box)):
        raise ValueError(f"model: expected a Discrete or Box action space, found {policy.action_space}")
    try:
        import onnx  # noqa: F401
        import onnxscript  # noqa: F401
    except ImportError as e:
        raise ImportError(f"export_policy needs the export extra: pip install 'sb3_mbil[export]' ({e})") from None
    path = Path(path)
    channels_last = input_layout == "env" and len(policy.observation_space.shape) == 3
    actor = DeterministicActor(policy, channels_last).to("cpu").eval()
    was_training = policy.training
    policy.set_training_mode(False)
    obs_dim = int(th.tensor(policy.observation_space.shape).prod())
    example = th.zeros(2, obs_dim, dtype=th.float32)
    try:
        with atomic_write(path) as tmp, th.no_grad():
            program = th.onnx.export(actor, (example,), input_names=["observation"], output_names=["action"],
                                     dynamic_shapes={"observation": {0: th.export.Dim("batch")}}, dynamo=True,
                                     verbose=False)
            program.save(str(tmp))
    finally:
        policy.set_training_mode(was_training)
    return path
