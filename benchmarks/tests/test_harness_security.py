"""The harness never runs a policy_kwargs override: settings are parsed, not evaluated."""

import pytest


def test_the_harness_never_runs_a_policy_kwargs_override(tmp_path):
    from benchmarks.harness.grid import tuned_settings

    marker = tmp_path / "ran"
    with pytest.raises(ValueError, match="policy_kwargs: expected"):
        tuned_settings("bc", "CartPole-v1", {"policy_kwargs": f"dict(a=open({str(marker)!r}, 'w'))"})
    assert not marker.exists()
    assert tuned_settings("bc", "Hopper-v4")["policy_kwargs"]["net_arch"] == [256, 256]
