"""docs/PYTHON.md against the bindings: every call its table of the pipeline functions shows
has the parameters and defaults the function has, in order, and leaves none out unless the row
says so (`…`) or the paragraph above the table covers it (`progress=`, `threads=`, `wait=`)."""

import ast
import inspect
import re
from pathlib import Path

import numpy as np

import minos

DOC = Path(__file__).resolve().parents[2] / "docs" / "PYTHON.md"

#: Keywords the paragraph above the table describes for every call.
COMMON = {"progress", "threads", "wait"}


def _rows() -> list[tuple[str, list[str], bool]]:
    """(function, its parameters as the doc writes them, whether the row elides some) of each
    row of the table whose first cell is a call of `minos.<function>`."""
    rows = []
    for line in DOC.read_text().splitlines():
        m = re.match(r"\| `(\w+)\((.*?)\)`", line)
        if not m or not hasattr(minos, m.group(1)):
            continue
        params, depth, cur = [], 0, ""
        for ch in m.group(2):
            if ch == "," and depth == 0:
                params.append(cur.strip())
                cur = ""
                continue
            depth += ch in "([{"
            depth -= ch in ")]}"
            cur += ch
        if cur.strip():
            params.append(cur.strip())
        elided = "…" in params
        rows.append((m.group(1), [p for p in params if p != "…"], elided))
    return rows


def test_the_python_doc_shows_each_call_as_the_bindings_define_it():
    rows = _rows()
    # Every pipeline call the package exports has its row.
    calls = {n for n in minos.__all__ if n[0].islower() and callable(getattr(minos, n))}
    assert {r[0] for r in rows} == calls, (sorted(calls), rows)
    for name, params, elided in rows:
        sig = inspect.signature(getattr(minos, name)).parameters
        documented = []
        for p in params:
            key, _, default = p.partition("=")
            assert key in sig, f"{name}: the doc shows `{key}`, which it does not take"
            documented.append(key)
            want = sig[key].default
            if not default:
                assert want is inspect.Parameter.empty, f"{name}: `{key}` has a default ({want!r})"
            elif want is not Ellipsis:  # PyO3 shows computed defaults as `...`
                assert ast.literal_eval(default) == want, f"{name}: `{key}` defaults to {want!r}"
        order = [k for k in sig if k in documented]
        assert order == documented, f"{name}: the doc's order {documented}, the function's {order}"
        if not elided:
            left_out = [k for k in sig if k not in documented and k not in COMMON]
            assert not left_out, f"{name}: the doc leaves out {left_out}"


def test_the_python_doc_shows_the_environments_arguments_as_they_are():
    import pytest

    pytest.importorskip("gymnasium", reason="gymnasium is not installed")
    from minos.gym import NavEnv, VectorNavEnv

    text = " ".join(DOC.read_text().split())
    shown = re.search(r"`NavEnv\((.*?)\)` is a", text).group(1)
    params = [p.strip() for p in shown.split(",")]
    sig = inspect.signature(NavEnv.__init__).parameters
    keys = [p.partition("=")[0] for p in params]
    assert keys == [k for k in sig if k != "self"], (keys, list(sig))
    for p in params:
        key, _, default = p.partition("=")
        if default != "...":
            assert ast.literal_eval(default) == sig[key].default, key
    # VectorNavEnv takes NavEnv's arguments and `num_envs`, `threads`.
    vec = inspect.signature(VectorNavEnv.__init__).parameters
    assert set(vec) - {"self"} == set(keys) | {"num_envs", "threads"}, list(vec)
    assert vec["threads"].default is None


def _doc_keys(start: str) -> set[str]:
    """The backquoted words of the paragraph of docs/PYTHON.md that starts with ``start``."""
    text = DOC.read_text()
    i = text.index(start)
    para = text[i:text.find("\n- ", i + 1)]
    return set(re.findall(r"`(\w+)`", para))


def test_the_python_doc_names_every_info_key_the_environments_give(world):
    import pytest

    pytest.importorskip("gymnasium")
    from minos.gym import NavEnv, VectorNavEnv

    keys = _doc_keys("- Step and reset infos")
    env = NavEnv(data=world.data, episodes=world.point, size=8)
    _, info = env.reset(seed=0)
    _, _, _, _, step_info = env.step(0)
    assert set(info) == set(step_info)
    single = set(info)
    assert single <= keys, f"undocumented: {single - keys}"
    venv = VectorNavEnv(data=world.data, episodes=world.point, num_envs=2, size=8)
    venv.reset(seed=0)
    _, _, _, _, vinfo = venv.step(np.zeros(2, dtype=np.int64))
    plain = {k for k in vinfo if not k.startswith("_")}
    assert plain - single <= keys, f"undocumented: {plain - single - keys}"
    assert {k for k in vinfo if k.startswith("_")} == {"_" + k for k in plain}
    # Every key the paragraph names in backquotes is one an environment gives, or a word of
    # the prose around them.
    assert keys - single - plain <= {"None", "NavEnv", "VectorNavEnv", "_", "N"}, keys

    hook_keys = _doc_keys("- `success_fn(obs, info) -> bool`")
    seen = {}
    env = NavEnv(data=world.data, episodes=world.point, size=8,
                 success_fn=lambda o, i: seen.update(i) or False)
    env.reset(seed=0)
    env.step(0)
    assert set(seen) <= hook_keys, f"undocumented: {set(seen) - hook_keys}"
    assert {"reward", "success", "action", "episode"} <= set(seen)
