"""Which pool, in which version, a result row drew from: rows name their pool in the settings column and were
run at a commit; a pool regenerated since is read back from that commit's history, so each row is measured against
the expert it imitated."""

from __future__ import annotations

import ast
import logging
import re
import subprocess
import tempfile
from pathlib import PurePosixPath

from sb3_mbil.common.demonstrations import POOL_DIR, Demonstrations, load_demonstrations


def row_pool(r: dict) -> str:
    """The pool a result row drew from: ``expert_pool`` in its settings column, else the env's shipped pool."""
    try:
        settings = dict(ast.literal_eval(r["settings"])) if r.get("settings") else {}
    except (ValueError, SyntaxError):  # a setting whose repr is no literal (a class in policy_kwargs)
        found = re.search(r"\('expert_pool', '([^']*)'\)", r["settings"])
        settings = {"expert_pool": found.group(1)} if found else {}
    return settings.get("expert_pool") or r["env"]


def _git(*args: str) -> bytes | None:
    """``git`` in the working directory (the checkout whose result files are summarised), or None."""
    try:
        out = subprocess.run(["git", *args], capture_output=True, timeout=60)
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout if out.returncode == 0 else None


def pool_version(name: str, commit: str | None) -> str:
    """The git blob of the shipped pool ``name`` at ``commit`` (a result row's), or ``"current"``: the pool as it
    is installed (the same file, a pool that is not a shipped file, no git checkout in the working directory, or a
    commit git does not know). Pools are regenerated (Walker2d-v4 and Ant-v4 were): a row is measured
    against the pool it drew from, not the one that replaced it. A pool not yet committed at the row's commit is
    the version of its next commit (runs start while a new pool is on disk)."""
    path = POOL_DIR / f"{name}.npz"
    if not commit or commit == "unknown" or not path.is_file():
        return "current"
    rel = PurePosixPath("sb3_mbil", "data", f"{name}.npz")
    rev = commit.removesuffix("-dirty")
    then = _git("rev-parse", f"{rev}:{rel.as_posix()}")
    if then is None and _git("cat-file", "-e", f"{rev}^{{commit}}") is not None:
        later = (_git("log", "--reverse", "--format=%H", f"{rev}..HEAD", "--", rel.as_posix()) or b"").split()
        then = _git("rev-parse", f"{later[0].decode()}:{rel.as_posix()}") if later else None
    now = _git("hash-object", str(path))
    if then is None or now is None or then.strip() == now.strip():
        return "current"
    return then.decode().strip()


def load_pool_version(name: str, version: str):
    """The pool ``name`` at ``version`` (:func:`pool_version`), read from git when it is not the current file."""
    if version == "current":
        return load_demonstrations(name)
    blob = _git("cat-file", "blob", version)
    if blob is None:
        raise FileNotFoundError(f"pool {name}: git blob {version} is not in this checkout")
    with tempfile.TemporaryDirectory() as tmp:
        path = f"{tmp}/{name}.npz"
        with open(path, "wb") as f:
            f.write(blob)
        demos = Demonstrations.load(path)
    demos.metadata["pool"] = f"{name}@{version[:10]}"
    return demos


def pool_experts(rows: list[dict]) -> dict[str, float]:
    """Per env, the mean return of the pool its runs drew from (``expert_pool`` in the settings column, else the
    env's shipped pool, in the version of the rows' commit, :func:`pool_version`): the expert a curve is measured
    against."""
    pools: dict[str, set] = {}
    versions: dict[tuple[str, str], str] = {}
    for r in rows:
        name = row_pool(r)
        key = (name, r.get("commit") or "")
        if key not in versions:
            versions[key] = pool_version(*key)
        pools.setdefault(r["env"], set()).add((name, versions[key]))
    expert = {}
    for env, found in sorted(pools.items()):
        if len({name for name, _ in found}) > 1:
            raise ValueError(f"expert_pool: expected one pool per env, found {sorted({n for n, _ in found})} for {env}")
        if len(found) > 1:
            raise ValueError(f"expert_pool: expected one version of the pool per env, found {len(found)} for {env} "
                             "(rows run before and after the pool was regenerated; summarise them apart)")
        name, version = found.pop()
        try:
            expert[env] = float(load_pool_version(name, version).episode_returns.mean())
        except FileNotFoundError:
            logging.getLogger("sb3_mbil.curves").warning("%s: the pool %s is not on this machine: no expert fraction",
                                                         env, name)
    return expert
