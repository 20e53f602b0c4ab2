"""``minos export-dataset --video``: LeRobot 0.4's own ``LeRobotDataset`` decodes the colour
camera's H.264 video with its default backend (torchcodec) and with PyAV, every frame within
MIN_PSNR dB of the same run's lossless image export, and ``python -m minos.learn train``
trains on the video dataset. Skipped without torch, lerobot or the minos binary; the
torchcodec half is skipped, saying why, when torchcodec cannot load the FFmpeg libraries."""

import math

import pytest

torch = pytest.importorskip("torch", reason="needs torch (pip install torch)")
pytest.importorskip("lerobot", reason="needs lerobot (pip install lerobot)")

import minos  # noqa: E402
from conftest import cli  # noqa: E402
from lerobot.datasets.lerobot_dataset import LeRobotDataset  # noqa: E402

KEY = "observation.images.color"
# Over all frames and channels; a single frame may be a few dB lower.
MIN_PSNR = 32.0


@pytest.fixture(scope="module")
def datasets(world, minos_bin, tmp_path_factory):
    d = tmp_path_factory.mktemp("video")
    run = d / "run"
    minos.run(world.data, world.point, "oracle", run, size=32, format="parquet")
    video, images = d / "video", d / "images"
    cli(minos_bin, "export-dataset", "--run", run, "--out", video, "--video")
    cli(minos_bin, "export-dataset", "--run", run, "--out", images)
    return video, images


def psnr(a: torch.Tensor, b: torch.Tensor) -> float:
    mse = torch.mean((a.double() - b.double()) ** 2).item()
    return 10 * math.log10(255.0 ** 2 / max(mse, 1e-12))


def torchcodec_loads() -> str:
    """'' when torchcodec decodes here, else why not."""
    try:
        import torchcodec.decoders  # noqa: F401
        return ""
    except Exception as e:  # ImportError, or the FFmpeg libraries missing
        return f"{type(e).__name__}: {str(e).splitlines()[0] if str(e) else ''}"


def check_frames(video_root, image_root, backend: str):
    theirs = LeRobotDataset("minos/v", root=video_root, video_backend=backend)
    exact = LeRobotDataset("minos/i", root=image_root)
    assert theirs.meta.video_keys == [KEY]
    assert len(theirs) == len(exact) > 20
    decoded, raw = [], []
    for i in range(len(theirs)):
        a, b = theirs[i], exact[i]
        assert a[KEY].shape == b[KEY].shape == (3, 32, 32), (i, a[KEY].shape)
        assert a[KEY].dtype == torch.float32
        # Depth and everything else: the same values as the image export.
        assert torch.equal(a["observation.depth"], b["observation.depth"]), i
        assert torch.equal(a["action"], b["action"]), i
        x, y = (a[KEY] * 255).round(), (b[KEY] * 255).round()
        assert psnr(x, y) >= MIN_PSNR - 6, (i, psnr(x, y))
        decoded.append(x)
        raw.append(y)
    total = psnr(torch.stack(decoded), torch.stack(raw))
    assert total >= MIN_PSNR, total
    return total


def test_lerobots_default_backend_decodes_every_frame_close_to_the_images(datasets):
    from lerobot.datasets.video_utils import get_safe_default_codec

    if get_safe_default_codec() != "torchcodec":
        pytest.skip("lerobot's default video backend here is not torchcodec")
    why = torchcodec_loads()
    if why:
        pytest.skip(f"torchcodec (lerobot's default video backend) cannot load here: {why} "
                    "(install the FFmpeg libraries, e.g. apt-get install libavcodec59 "
                    "libavformat59 libavutil57 libswscale6 libavdevice59 libavfilter8)")
    check_frames(*datasets, backend="torchcodec")


def test_pyav_decodes_every_frame_close_to_the_images(datasets):
    pytest.importorskip("av", reason="needs PyAV (pip install av)")
    check_frames(*datasets, backend="pyav")


def test_the_learner_trains_on_a_video_dataset(datasets, tmp_path):
    from minos.learn.__main__ import main
    from minos.learn.data import load_lerobot

    video, images = datasets
    env_actions = ["forward", "turn_left", "turn_right", "stop"]
    demos = load_lerobot(video, env_actions, keys=["color", "goal"], num_workers=0)
    exact = load_lerobot(images, env_actions, keys=["color", "goal"], num_workers=0)
    assert demos.frames["color"].shape == exact.frames["color"].shape
    assert demos.frames["color"].dtype == torch.uint8
    assert torch.equal(demos.frames["goal"], exact.frames["goal"])
    assert psnr(demos.frames["color"], exact.frames["color"]) >= MIN_PSNR
    ckpt = tmp_path / "video.pt"
    assert main(["-q", "train", "--dataset", str(video), "--modalities", "V", "--agent",
                 "habitat", "--epochs", "1", "--out", str(ckpt)]) == 0
    assert ckpt.is_file()
