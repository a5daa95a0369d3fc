"""The README's tables are generated from the result files (python -m benchmarks.readme --overwrite)."""

import re
from pathlib import Path

import pytest

from benchmarks.readme import MARKERS, readme_blocks, replace_block

REPO = Path(__file__).resolve().parents[2]


def test_the_readme_tables_are_the_result_files_numbers(monkeypatch):
    monkeypatch.chdir(REPO)
    blocks, settings = readme_blocks()
    readme = (REPO / "README.md").read_text()
    for name, body in blocks.items():
        start, end = MARKERS[name]
        found = re.search(re.escape(start) + r"\n(.*?)\n" + re.escape(end), readme, re.S)
        assert found is not None, f"README: the markers of {name} are missing"
        assert found.group(1) == body, f"README's {name} table is stale: run python -m benchmarks.readme --overwrite"
    assert len(blocks["results"].splitlines()) <= 17  # header, rule and at most 15 lines
    assert {s.demonstrations for s in settings} >= {"deterministic"}


def test_a_block_without_its_markers_is_refused():
    with pytest.raises(ValueError, match="markers"):
        replace_block("no markers here", "results", "| x |")


def test_a_score_over_fewer_seeds_than_its_settings_others_says_how_many():
    from benchmarks.readme import Setting

    s = Setting("sampled", "Walker2d-v4", 1, scores={
        "bc": {i: 0.3 for i in range(10)}, "mbil_c": {i: 0.4 + 0.01 * i for i in range(10)},
        "mbil": {0: 0.5, 1: 0.35}})
    assert s.cell("bc") == "0.30"
    assert s.cell("mbil_c") == "0.45+"
    assert s.cell("mbil") == "0.42 (2 seeds)"


def test_the_which_table_has_one_sampled_row_per_number_of_trajectories():
    from benchmarks.readme import Setting, which_table

    def setting(env, n, bc, mbil):
        s = Setting("sampled", env, n, scores={"bc": {i: bc for i in range(3)}, "mbil": {i: mbil + 0.01 * i for i in range(3)},
                                               "mbil_c": {i: bc for i in range(3)}})
        s.names = {"bc": "bc_wd0", "mbil": "mbil", "mbil_c": "mbil_c"}
        return s

    table = which_table([], [setting("CartPole-v1", 15, 0.9, 0.5), setting("CartPole-v1", 1, 0.3, 0.3),
                             setting("Acrobot-v1", 15, 0.8, 0.4)], many_csv="/nonexistent.csv")
    rows = [line.split(" | ") for line in table.splitlines()[2:]]
    assert [r[1] for r in rows] == ["1", "15"]
    assert rows[1][2].startswith("`bc`") and rows[1][3] == "0.80-0.90"
    assert "CartPole-v1, Acrobot-v1 so far" in rows[1][4]
