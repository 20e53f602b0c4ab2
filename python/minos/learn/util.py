"""Seeds, devices, progress reporting and atomic checkpoint files."""

from __future__ import annotations

import os
import random
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Callable, Iterator, Optional, Union

import numpy as np
import torch

#: A progress sink: None (silent), True (a tqdm bar when tqdm is installed), a tqdm-like
#: object (``update(n)``, ``total``) or a callable ``f(done, total)`` — as ``minos.run``'s.
ProgressArg = Union[None, bool, Callable[[int, int], Any], Any]


def seed_everything(seed: int) -> None:
    """Seeds Python's, NumPy's and torch's generators (CPU and CUDA)."""
    random.seed(seed)
    np.random.seed(seed % 2**32)
    torch.manual_seed(seed)
    if torch.cuda.is_available():
        torch.cuda.manual_seed_all(seed)


def pick_device(device: Optional[str] = None) -> torch.device:
    """``None``/``"auto"``: CUDA when present, else the CPU; otherwise the named device."""
    if device in (None, "auto"):
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    return torch.device(device)


class Progress:
    """Reports ``done`` out of ``total`` to a :data:`ProgressArg`; ``close()`` when done."""

    def __init__(self, sink: ProgressArg, total: int, desc: str = ""):
        self.total = total
        self.done = 0
        self.bar = None
        self.fn: Optional[Callable[[int, int], Any]] = None
        self.owned = False
        if sink is True:
            try:
                from tqdm.auto import tqdm

                self.bar = tqdm(total=total, desc=desc, leave=False)
                self.owned = True
            except ImportError:
                pass
        elif callable(sink) and not hasattr(sink, "update"):
            self.fn = sink
        elif sink is not None and sink is not False:
            self.bar = sink
            try:
                self.bar.total = total
                if desc and hasattr(self.bar, "set_description"):
                    self.bar.set_description(desc)
            except AttributeError:
                pass

    def to(self, done: int, postfix: Optional[dict] = None) -> None:
        """Moves to ``done``."""
        if self.bar is not None:
            self.bar.update(done - self.done)
            if postfix and hasattr(self.bar, "set_postfix"):
                self.bar.set_postfix(postfix, refresh=False)
        if self.fn is not None:
            self.fn(done, self.total)
        self.done = done

    def __call__(self, done: int, total: int) -> None:
        if total != self.total:
            self.total = total
            if self.bar is not None and hasattr(self.bar, "total"):
                self.bar.total = total
        self.to(done)

    def close(self) -> None:
        if self.owned and self.bar is not None:
            self.bar.close()


@contextmanager
def torch_threads(n: int) -> Iterator[None]:
    """Runs the block with ``n`` torch CPU threads. Rollouts use 1: a policy's batch of N
    frames is small, and torch's spinning worker threads otherwise compete with the
    environment's Rust threads (4× slower evaluation on two cores)."""
    before = torch.get_num_threads()
    torch.set_num_threads(n)
    try:
        yield
    finally:
        torch.set_num_threads(before)


def save_atomic(obj: Any, path: Path) -> None:
    """``torch.save`` into ``path`` through a temporary file (an interrupted save never
    leaves a half-written checkpoint)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".tmp")
    torch.save(obj, tmp)
    os.replace(tmp, path)


__all__ = ["Progress", "ProgressArg", "pick_device", "save_atomic", "seed_everything",
           "torch_threads"]
