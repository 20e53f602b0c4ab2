"""LeRobot's ``LeRobotDataset`` for minos exports, with action chunks read column by column.

    from minos.lerobot import LeRobotDataset
    ds = LeRobotDataset("minos/run", root="RUN/lerobot",
                        delta_timestamps={"action": [0, 0.1, 0.2, 0.3]})

A subclass of ``lerobot.datasets.lerobot_dataset.LeRobotDataset`` (lerobot ≥ 0.4) that returns
the same items, tensor for tensor — it changes one thing: how the frames of a
``delta_timestamps`` window are read. LeRobot 0.4.4 reads them with
``hf_dataset[key][indices]``; with LeRobot's transform set, Hugging Face ``datasets`` (4.x)
formats *every* column of those rows to serve one, so a 4-step action chunk decodes the
cameras of four more frames per item (≈ 440 frames/s through a 2-worker ``DataLoader`` on a
2-core machine, against ≈ 1,300 without a chunk). This class reads each queried key from a
view of the table holding that column alone, with the same transform (≈ 1,100–1,200 frames/s
with the chunk; ``python/bench/lerobot_loading.py``). Anything else — video keys, padding,
image transforms, episodes subsets — is LeRobot's own code.

Requires ``lerobot`` (``pip install lerobot``); importing this module without it raises
``ImportError`` naming the package.
"""

from __future__ import annotations

try:
    import torch
    from lerobot.datasets.lerobot_dataset import LeRobotDataset as _LeRobotDataset
except ImportError as e:  # pragma: no cover - exercised only without lerobot
    raise ImportError(
        f"minos.lerobot needs lerobot (pip install lerobot): {e}"
    ) from e

__all__ = ["LeRobotDataset"]


class LeRobotDataset(_LeRobotDataset):
    """``lerobot``'s ``LeRobotDataset`` whose ``delta_timestamps`` windows read only the
    queried columns (see the module documentation); same constructor, same items."""

    def _column_view(self, key: str):
        """The table restricted to `key`, formatted as the full table is (cached per table:
        LeRobot replaces ``hf_dataset`` when it loads new episodes)."""
        views = self.__dict__.setdefault("_minos_column_views", {})
        table = self.hf_dataset
        cached = views.get(key)
        if cached is not None and cached[0] is table:
            return cached[1]
        view = table.select_columns([key])
        fmt = table.format
        if fmt["type"] == "custom":
            view.set_transform(fmt["format_kwargs"]["transform"])
        else:
            view.set_format(fmt["type"], **fmt["format_kwargs"])
        views[key] = (table, view)
        return view

    def _query_hf_dataset(self, query_indices: dict[str, list[int]]) -> dict:
        if getattr(self.hf_dataset, "_format_type", None) != "custom":
            # Other formats already read one column at a time.
            return super()._query_hf_dataset(query_indices)
        result: dict = {}
        for key, q_idx in query_indices.items():
            if key in self.meta.video_keys:
                continue
            rows = (
                q_idx
                if self._absolute_to_relative_idx is None
                else [self._absolute_to_relative_idx[i] for i in q_idx]
            )
            result[key] = torch.stack(self._column_view(key)[rows][key])
        return result
