"""The reference policy: a small CNN over the image modalities, an MLP over the vector ones,
and a GRU (or nothing) before the action head.

Images (camera, depth, semantic) are stacked as channels at ``image_size``² (84² as in the
MINOS paper) and go through the Atari-style network the paper's A3C/DFP agents used (conv
8×8/4 → 4×4/2 → 3×3/1, then a linear layer); vectors (measurements, forces, previous action)
through a two-layer MLP. The GRU is the default because a PointGoal agent with a goal vector
is not quite Markov in a furnished house: it has to remember which way round an obstacle it
already tried (MINOS's A3C-LSTM and Habitat's baselines are recurrent for the same reason);
``memory="none"`` gives the feed-forward variant (DFP-like, no state), which trains faster.

Inputs are frames as :mod:`minos.learn.features` lays them out (uint8 images, depth in
metres, label ids); all scaling happens here, so dataset and environment frames go through
the same code.

``stop``: the MINOS paper's agents had no stop action (an episode ends on arrival, the
success test after a step), so by default a policy never stops: its ``stop`` frames are not
trained on and its ``stop`` logit is masked. ``use_stop=True`` learns and uses ``stop``, for
environments made with ``require_stop=True`` (Habitat's rule).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Optional

import torch
import torch.nn.functional as F
from torch import nn

from .features import is_image_key, normalised_vector, vector_width

SEMANTIC_IDS = 256  # label ids ≥ this share the last embedding
SEMANTIC_DIM = 4
DEPTH_MAX_M = 10.0


@dataclass
class PolicySpec:
    """Everything needed to rebuild a policy (stored in checkpoints)."""

    keys: list[str]
    channels: dict[str, int]  # image key → channels as stored (camera 1 or 3; depth 1; ...)
    num_actions: int
    env_actions: list[str]
    modalities: list[str]
    image_size: int = 84
    hidden: int = 128
    memory: str = "gru"
    conv: tuple = (16, 32, 32)  # channels of the three conv layers (DQN's: 32, 64, 64)
    use_stop: bool = False  # False: never `stop` (episodes end on arrival, as MINOS's)
    extra: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> "PolicySpec":
        d = dict(d)
        d["conv"] = tuple(d.get("conv", (16, 32, 32)))
        return cls(**d)


class NavPolicy(nn.Module):
    """``forward(frames, hidden) -> (logits, hidden)`` over a batch of sequences, or
    :meth:`act` one step for N environments."""

    def __init__(self, spec: PolicySpec):
        super().__init__()
        if spec.memory not in ("gru", "none"):
            raise ValueError(f"memory: `{spec.memory}` is neither `gru` nor `none`")
        self.spec = spec
        self.image_keys = [k for k in spec.keys if is_image_key(k)]
        self.vector_keys = [k for k in spec.keys if not is_image_key(k)]
        h = spec.hidden
        width = 0
        if self.image_keys:
            if "semantic" in self.image_keys:
                self.semantic = nn.Embedding(SEMANTIC_IDS, SEMANTIC_DIM)
            cin = sum(SEMANTIC_DIM if k == "semantic" else spec.channels[k]
                      for k in self.image_keys)
            c1, c2, c3 = spec.conv
            self.cnn = nn.Sequential(
                nn.Conv2d(cin, c1, 8, stride=4), nn.ReLU(),
                nn.Conv2d(c1, c2, 4, stride=2), nn.ReLU(),
                nn.Conv2d(c2, c3, 3, stride=1), nn.ReLU(), nn.Flatten(),
            )
            with torch.no_grad():
                n = self.cnn(torch.zeros(1, cin, spec.image_size, spec.image_size)).shape[1]
            self.image_fc = nn.Sequential(nn.Linear(n, h), nn.ReLU())
            width += h
        vw = vector_width(self.vector_keys)
        if vw:
            self.mlp = nn.Sequential(nn.Linear(vw, 128), nn.ReLU(), nn.Linear(128, 128), nn.ReLU())
            width += 128
        if width == 0:
            raise ValueError("a policy needs at least one input")
        self.fuse = nn.Sequential(nn.Linear(width, h), nn.ReLU())
        self.gru = nn.GRU(h, h, batch_first=True) if spec.memory == "gru" else None
        self.head = nn.Linear(h, spec.num_actions)
        mask = torch.zeros(spec.num_actions)
        if not spec.use_stop and "stop" in spec.env_actions:
            mask[spec.env_actions.index("stop")] = float("-inf")
        self.register_buffer("action_mask", mask, persistent=False)

    def _images(self, frames: dict[str, torch.Tensor]) -> torch.Tensor:
        s = self.spec.image_size
        parts = []
        for k in self.image_keys:
            v = frames[k]
            if k == "semantic":
                ids = v[:, 0].long().clamp(0, SEMANTIC_IDS - 1)
                if ids.shape[-1] != s:
                    ids = F.interpolate(ids[:, None].float(), size=(s, s),
                                        mode="nearest")[:, 0].long()
                parts.append(self.semantic(ids).permute(0, 3, 1, 2))
                continue
            x = v.float()
            if k == "depth":
                x = x.clamp(0.0, DEPTH_MAX_M) / DEPTH_MAX_M
            else:
                x = x / 255.0
            if x.shape[-1] != s:
                x = F.interpolate(x, size=(s, s), mode="area")
            parts.append(x)
        return torch.cat(parts, dim=1)

    def encode(self, frames: dict[str, torch.Tensor]) -> torch.Tensor:
        """Frames (N, …) → features (N, hidden), before the memory."""
        feats = []
        if self.image_keys:
            feats.append(self.image_fc(self.cnn(self._images(frames))))
        vec = normalised_vector(frames, self.vector_keys)
        if vec is not None:
            feats.append(self.mlp(vec))
        return self.fuse(torch.cat(feats, dim=1))

    def forward(self, frames: dict[str, torch.Tensor], mask: torch.Tensor,
                hidden: Optional[torch.Tensor] = None) -> torch.Tensor:
        """Padded sequences: ``frames`` hold the M valid frames in (batch, time) order and
        ``mask`` (B, T) says where they go; returns the (M, actions) logits. Each sequence
        starts from ``hidden`` (zeros: an episode's start)."""
        z = self.encode(frames)
        if self.gru is None:
            return self.head(z)
        b, t = mask.shape
        seq = z.new_zeros(b, t, z.shape[1])
        seq[mask] = z
        out, _ = self.gru(seq, hidden)
        return self.head(out[mask])

    def initial_state(self, n: int, device: torch.device | str = "cpu") -> Optional[torch.Tensor]:
        """The recurrent state of ``n`` fresh episodes (None without memory)."""
        if self.gru is None:
            return None
        return torch.zeros(1, n, self.spec.hidden, device=device)

    @torch.no_grad()
    def act(self, frames: dict[str, torch.Tensor], state: Optional[torch.Tensor]
            ) -> tuple[torch.Tensor, Optional[torch.Tensor]]:
        """One step for N environments: logits (N, actions) and the next state (``stop``'s
        logit is −inf unless the spec's ``use_stop``)."""
        z = self.encode(frames)
        if self.gru is None:
            return self.head(z) + self.action_mask, None
        out, state = self.gru(z[:, None], state)
        return self.head(out[:, 0]) + self.action_mask, state


__all__ = ["NavPolicy", "PolicySpec"]
