"""docs/PYTHON.md against the bindings: every call its table of the pipeline functions shows
has the parameters and defaults the function has, in order, and leaves none out unless the row
says so (`…`) or the paragraph above the table covers it (`progress=`, `threads=`, `wait=`)."""

import ast
import inspect
import re
from pathlib import Path

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
