"""minos.lerobot.LeRobotDataset: the items of LeRobot's own class, tensor for tensor, with
action chunks and state history read column by column. Skipped without torch or lerobot."""

import pytest

torch = pytest.importorskip("torch", reason="needs torch (pip install torch)")
pytest.importorskip("lerobot", reason="needs lerobot (pip install lerobot)")

import minos  # noqa: E402
from lerobot.datasets.lerobot_dataset import LeRobotDataset as Upstream  # noqa: E402
from minos.lerobot import LeRobotDataset  # noqa: E402


@pytest.fixture(scope="module")
def dataset(world, tmp_path_factory):
    out = tmp_path_factory.mktemp("lerobot") / "run"
    minos.run(world.data, world.point, "oracle", out, size=16, format="lerobot")
    return out / "lerobot"


def test_items_equal_lerobots_own_with_chunks_and_history(dataset):
    fps = Upstream("minos/t", root=dataset).fps
    deltas = {
        "action": [k / fps for k in range(4)],
        "observation.goal": [-2 / fps, -1 / fps, 0.0],
        "observation.depth": [-1 / fps, 0.0],
    }
    ours = LeRobotDataset("minos/t", root=dataset, delta_timestamps=deltas)
    theirs = Upstream("minos/t", root=dataset, delta_timestamps=deltas)
    assert len(ours) == len(theirs) > 20
    # Every frame: window starts (padding) and ends (clamped) of every episode included.
    for i in range(len(theirs)):
        a, b = ours[i], theirs[i]
        assert a.keys() == b.keys()
        for k, v in b.items():
            if isinstance(v, torch.Tensor):
                assert a[k].dtype == v.dtype and a[k].shape == v.shape, (i, k)
                assert torch.equal(a[k], v), (i, k)
            else:
                assert a[k] == v, (i, k)
    item = ours[0]
    assert item["action"].shape == (4, 9)
    assert item["observation.goal"].shape == (3, 3)
    assert item["observation.goal_is_pad"].tolist() == [True, True, False]
    assert item["observation.depth"].shape[:2] == (2, 1), "channel-first depth history"


def test_a_dataloader_batches_chunks(dataset):
    fps = Upstream("minos/t", root=dataset).fps
    ds = LeRobotDataset("minos/t", root=dataset,
                        delta_timestamps={"action": [k / fps for k in range(4)]})
    loader = torch.utils.data.DataLoader(ds, batch_size=16, num_workers=2, shuffle=True,
                                         generator=torch.Generator().manual_seed(0))
    seen = 0
    for batch in loader:
        assert batch["action"].shape[1:] == (4, 9)
        assert batch["observation.images.color"].shape[1] == 3
        seen += len(batch["index"])
    assert seen == len(ds)
