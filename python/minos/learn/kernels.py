"""Which CPU kernels torch runs: the same bits on AVX2 and AVX-512 processors, or the fastest.

torch's CPU convolutions run through oneDNN, which picks its kernels by the processor's
instruction set: with AVX-512 it sums in another order than with AVX2 alone, the last bits of
a convolution differ, and a policy with an image trained for minutes on one machine is not
the one trained on the other — its DAgger rollouts take other paths, and a table row moves by
up to 25 points (docs/RESULTS.md, "Seeds"). So ``import minos.learn`` caps oneDNN at AVX2
(and asks MKL for its AVX2 code path) before torch's first convolution: the *portable*
kernels, the default. A complexity cell trained that way on a 2-core AMD EPYC with AVX-512
repeats, frame for frame, what an AVX2-only EPYC made (docs/RESULTS.md); training a policy
with an image costs about 1.5–2× the time there. Blind policies (no convolution) give the
same bits either way.

``MINOS_LEARN_KERNELS=native`` (or ``python -m minos.learn --kernels native``, or
:func:`select` before the first convolution) lets the libraries use every instruction the
processor has. A value the user set for ``ONEDNN_MAX_CPU_ISA`` or ``MKL_CBWR`` is kept; an
unknown ``MINOS_LEARN_KERNELS`` is named in a warning at import, and the portable kernels run.

The settings take effect only before the process's first convolution (oneDNN reads them
once); GPUs are not affected.
"""

from __future__ import annotations

import os
from typing import Optional

#: The environment variable that chooses the kernels: ``portable`` (default) or ``native``.
ENV = "MINOS_LEARN_KERNELS"

#: The kernel choices.
MODES = ("portable", "native")

#: What the portable kernels set: oneDNN's highest instruction set, and MKL's
#: conditional-numerical-reproducibility branch.
PORTABLE = {"ONEDNN_MAX_CPU_ISA": "AVX2", "MKL_CBWR": "AVX2"}

# The variables this module set (and so may unset for `native`).
_set_here: set[str] = set()


def select(mode: Optional[str] = None) -> str:
    """Applies ``mode`` (``None``: ``$MINOS_LEARN_KERNELS``, else ``portable``) and returns
    it. ``portable`` sets :data:`PORTABLE`'s variables the user has not set; ``native``
    removes those this module set. Raises ``ValueError`` for another mode."""
    if mode is None:
        mode = os.environ.get(ENV) or "portable"
    if mode not in MODES:
        raise ValueError(f"{ENV}: {mode!r} is not one of {', '.join(MODES)}")
    for key, value in PORTABLE.items():
        if mode == "portable" and key not in os.environ:
            os.environ[key] = value
            _set_here.add(key)
        elif mode == "native" and key in _set_here:
            os.environ.pop(key, None)
            _set_here.discard(key)
    os.environ[ENV] = mode
    return mode


def mode() -> str:
    """The kernels in use: ``portable`` when oneDNN is capped at AVX2, else ``native``."""
    return "portable" if os.environ.get("ONEDNN_MAX_CPU_ISA") == PORTABLE[
        "ONEDNN_MAX_CPU_ISA"] else "native"


def settings() -> dict:
    """What a result records: the mode and the variables that decide the kernels."""
    return {"mode": mode(), **{k: os.environ.get(k) for k in PORTABLE}}


__all__ = ["ENV", "MODES", "PORTABLE", "mode", "select", "settings"]
