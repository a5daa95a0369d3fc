"""The harness's faults and bad inputs: results files parsed as records and appended whole, script options checked
with one line naming them, every tried fault of benchmarks/robustness.py a clean error."""

import os
import subprocess
import sys
import pytest
from pathlib import Path
from benchmarks.harness.cli import harness_env


# ---------------------------------------------------------------------------------------------- results CSV
def _grid_csv(tmp_path):
    from benchmarks.harness.grid import RESULT_COLUMNS as COLUMNS

    path = tmp_path / "grid.csv"
    from benchmarks.harness.results import append_rows

    append_rows(path, [{c: f"{c}{i}" for c in COLUMNS} | {"algo": "bc", "env": "CartPole-v1", "n_trajectories": "1",
                                                          "seed": str(i)} for i in range(3)], COLUMNS)
    return path, COLUMNS


@pytest.mark.parametrize("cut", [40, 5])
def test_an_interrupted_last_line_is_dropped_said_and_redone_on_a_fresh_line(tmp_path, cut, caplog):
    from benchmarks.harness.grid import KEY_COLUMNS as KEY
    from benchmarks.harness.results import append_rows, finished_keys, read_result_rows

    path, columns = _grid_csv(tmp_path)
    whole = path.read_bytes()
    path.write_bytes(whole[:-cut])  # the last row cut mid-line (truncate -s -40)
    with pytest.raises(ValueError, match=r"grid.csv:4: expected complete lines, found an unterminated last line"):
        read_result_rows(path)  # reports refuse it
    keys = finished_keys(path, KEY)  # resume drops it, saying so, and redoes that run
    assert ("bc", "CartPole-v1", "1", "2") not in keys and len(keys) == 2
    assert "dropped an incomplete last line" in caplog.text
    append_rows(path, [{c: "x" for c in columns} | {"algo": "bc", "env": "CartPole-v1", "n_trajectories": "1", "seed": "2"}],
                columns)
    rows = read_result_rows(path)
    assert len(rows) == 3 and rows[-1]["seed"] == "2" and all(len(r) == len(columns) for r in rows)


def test_a_malformed_middle_line_is_refused_with_path_and_line(tmp_path):
    from benchmarks.harness.grid import KEY_COLUMNS as KEY
    from benchmarks.harness.results import finished_keys, read_result_rows

    path, _ = _grid_csv(tmp_path)
    lines = path.read_text().splitlines(keepends=True)
    lines[2] = lines[2].rstrip("\r\n") + ",glued,on\r\n"
    path.write_text("".join(lines))
    for reader in (read_result_rows, lambda p: finished_keys(p, KEY)):
        with pytest.raises(ValueError, match=r"grid.csv:3: expected \d+ fields \(the header's\), found \d+"):
            reader(path)
    out = subprocess.run([sys.executable, "-m", "benchmarks.plot_results", "--csv", str(path), "--out", str(tmp_path / "p.png")],
                         capture_output=True, text=True, env=harness_env(), timeout=300)
    assert out.returncode == 2 and "grid.csv:3: expected" in out.stderr and "Traceback" not in out.stderr


# ---------------------------------------------------------------------------------------------- script options
@pytest.mark.parametrize("args, message", [
    (["-m", "benchmarks.run_grid", "--episodes", "-3"], "argument --episodes: expected an integer >= 1, found -3"),
    (["-m", "benchmarks.run_grid", "--seeds", "5-1"], "argument --seeds: expected increasing seed ranges"),
    (["-m", "benchmarks.run_grid", "--algos", "nope"], "argument --algos: invalid choice: 'nope'"),
    (["-m", "benchmarks.run_curves", "--envs", "Hopper-v4", "--updates", "0", "--csv", "x.csv"], "argument --updates: expected an integer >= 1"),
    (["-m", "benchmarks.compare", "--seed", "abc"], "argument --seed: expected an integer seed >= 0, found 'abc'"),
    (["-m", "benchmarks.bench_speed", "--steps", "1.5"], "argument --steps: expected an integer >= 1, found '1.5'"),
    (["scripts/generate_expert_data.py", "--env", "CartPole-v1", "--n-trajectories", "2", "--min-return", "nan"],
     "argument --min-return: expected a finite number, found 'nan'"),
])
def test_script_options_are_checked_with_one_line_naming_them(args, message, tmp_path):
    repo = Path(__file__).resolve().parents[2]
    command = args if args[0] == "-m" else [str(repo / args[0]), *args[1:]]
    out = subprocess.run([sys.executable, *command], capture_output=True, text=True, cwd=tmp_path, env=harness_env(),
                         timeout=300)
    assert out.returncode == 2 and message in out.stderr and "Traceback" not in out.stderr, out.stderr[-2000:]
    assert not (tmp_path / "x.csv").exists()


def test_every_tried_fault_gives_a_clean_error():
    """benchmarks/robustness_report.py's cases: each a clean error naming its field, none unclear or silent."""
    from benchmarks.robustness import run_cases, table

    cases = run_cases()
    assert len(cases) > 200
    assert all(c.outcome == "clean" for c in cases), table(cases)


def test_results_files_are_parsed_as_csv_records_and_appended_whole(tmp_path, monkeypatch):
    from benchmarks.harness import results
    from benchmarks.harness.results import append_rows, drop_incomplete_last_line, finished_keys, read_result_rows

    path, columns = tmp_path / "r.csv", ["algo", "seed", "settings"]
    append_rows(path, [{"algo": "bc", "seed": 0, "settings": "a\nb"}], columns)  # a quoted field with a newline
    append_rows(path, [{"algo": "bc", "seed": 1, "settings": "c"}], columns)
    assert drop_incomplete_last_line(path) is None
    assert [r["settings"] for r in read_result_rows(path)] == ["a\nb", "c"]
    with open(path, "a") as f:
        f.write('bc,2,"unterminated\nquote')  # an interrupted append inside a quoted field
    assert drop_incomplete_last_line(path) is not None
    assert finished_keys(path, ("algo", "seed")) == {("bc", "0"), ("bc", "1")}
    with open(path, "a") as f:
        f.write("bc,3,x\x00y\n")  # a NUL byte in the last record: dropped, its run redone
    drop_incomplete_last_line(path)
    assert finished_keys(path, ("algo", "seed")) == {("bc", "0"), ("bc", "1")}
    text = path.read_text()
    path.write_text(text.replace("c\n", "c\x00\n") + "bc,4,z\n")  # a NUL byte inside the file: refused, with the line
    with pytest.raises(ValueError, match=r"r.csv:4: expected text, found a NUL byte"):
        read_result_rows(path)
    path.write_text(text)

    real_fsync = os.fsync

    def full_disk(fd):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(results.os, "fsync", full_disk)
    with pytest.raises(OSError, match="No space left"):
        append_rows(path, [{"algo": "bc", "seed": 5 + i, "settings": ""} for i in range(60)], columns)
    monkeypatch.setattr(results.os, "fsync", real_fsync)
    assert path.read_text() == text  # none of the 60 rows: the run is redone whole
