"""Checks behind the LeRobot export size figures (docs/PERFORMANCE.md, Colour as video).

    python python/bench/lerobot_sizes.py psnr IMAGES VIDEO [--decoder torchcodec]
    python python/bench/lerobot_sizes.py same NEW OLD [--step N]
    python python/bench/lerobot_sizes.py png-estimate PNG_RUN IMAGES

`psnr`: decodes the colour MP4 of the `--video` export VIDEO with PyAV (FFmpeg's H.264
decoder, converted to `rgb24`), or with torchcodec (LeRobot's default video backend, which
needs the system's FFmpeg libraries), and compares every frame with the PPM cell of the image
export IMAGES of the same run: mean and worst per-frame PSNR.

`same`: loads both exports with LeRobot's `LeRobotDataset(repo_id, root=...)` and checks
that every item's tensors are equal (`torch.equal`, same dtype and shape) and names the
`meta/episodes` columns LeRobot keeps that differ (a dataset that now fits one data file has
other `data/file_index` values). Exits non-zero on the first different tensor.

`png-estimate`: the size the image export would have with colour stored as PNG (the
encoding of the LeRobot export until `c47128b`): the export IMAGES less its colour column,
plus the colour cells of PNG_RUN (the same run made with `minos run --image-encoding png`,
whose cells minos's PNG encoder wrote) as a zstd-1 Parquet column, as that export held them.
"""

import argparse
import glob
import io
import subprocess
import sys

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq


def data_file(root: str) -> str:
    files = sorted(glob.glob(f"{root}/data/*/*.parquet"))
    if not files:
        sys.exit(f"{root}: no data files")
    return files[0]


def ppm(cell: bytes) -> np.ndarray:
    _, size, _, body = cell.split(b"\n", 3)
    w, h = map(int, size.split())
    return np.frombuffer(body, np.uint8).reshape(h, w, 3)


def decoded_frames(video: str, decoder: str):
    """The frames of one MP4, in order, as (h, w, 3) uint8 arrays."""
    if decoder == "torchcodec":
        from torchcodec.decoders import VideoDecoder

        frames = VideoDecoder(video)
        for k in range(len(frames)):
            yield frames[k].permute(1, 2, 0).numpy()
        return
    import av

    with av.open(video) as container:
        for frame in container.decode(video=0):
            yield frame.to_ndarray(format="rgb24")


def psnr(a: argparse.Namespace) -> None:
    cells = []
    for f in sorted(glob.glob(f"{a.images}/data/*/*.parquet")):
        t = pq.read_table(f, columns=["observation.images.color"])
        cells += [c["bytes"] for c in t.column(0).to_pylist()]
    values = []
    for video in sorted(glob.glob(f"{a.video}/videos/observation.images.color/*/*.mp4")):
        for frame in decoded_frames(video, a.decoder):
            k = len(values)
            if k >= len(cells):
                sys.exit(f"{video}: more decoded frames than the {len(cells)} images")
            got = frame.astype(np.float64)
            mse = ((got - ppm(cells[k]).astype(np.float64)) ** 2).mean()
            values.append(10 * np.log10(255**2 / max(mse, 1e-10)))
    if len(values) != len(cells):
        sys.exit(f"{len(values)} decoded frames for {len(cells)} images")
    v = np.array(values)
    print(f"{a.decoder}, {len(v)} frames: mean {v.mean():.2f} dB, worst {v.min():.2f} dB")


def same(a: argparse.Namespace) -> None:
    import torch
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    new = LeRobotDataset(repo_id="new", root=a.new)
    old = LeRobotDataset(repo_id="old", root=a.old)
    if len(new) != len(old):
        sys.exit(f"{len(new)} frames against {len(old)}")
    en, eo = new.meta.episodes.to_pandas(), old.meta.episodes.to_pandas()
    if list(en.columns) != list(eo.columns):
        sys.exit(f"episode columns {list(en.columns)} against {list(eo.columns)}")
    differ = [c for c in en.columns if en[c].to_json() != eo[c].to_json()]
    print(f"meta/episodes: {len(en.columns)} columns loaded, differing: {differ}")
    n = 0
    for i in range(0, len(new), a.step):
        x, y = new[i], old[i]
        for k, t in x.items():
            if isinstance(t, torch.Tensor):
                u = y[k]
                if t.dtype != u.dtype or t.shape != u.shape or not torch.equal(t, u):
                    sys.exit(f"frame {i}: {k} differs")
        n += 1
    print(f"{n} of {len(new)} items equal, tensor for tensor")


def png_estimate(a: argparse.Namespace) -> None:
    run = pq.read_table(f"{a.png_run}/observations.parquet")
    column = next(c for c in run.column_names if "color" in c)
    cells = run.column(column).to_pylist()
    buf = io.BytesIO()
    pq.write_table(
        pa.table({"c": pa.array(cells, pa.binary())}),
        buf,
        compression="zstd",
        compression_level=1,
        use_dictionary=False,
    )
    png = len(buf.getvalue())
    meta = pq.ParquetFile(data_file(a.images)).metadata
    colour = sum(
        meta.row_group(g).column(c).total_compressed_size
        for g in range(meta.num_row_groups)
        for c in range(meta.num_columns)
        if meta.row_group(g).column(c).path_in_schema.startswith("observation.images.color")
    )
    total = int(subprocess.check_output(["du", "-sb", a.images]).split()[0])
    print(
        f"PNG cells {sum(map(len, cells)):,} B ({png:,} B as a zstd-1 column); colour column "
        f"of {a.images}: {colour:,} B of {total:,} B; PNG export ≈ {total - colour + png:,} B"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(required=True)
    p = sub.add_parser("psnr")
    p.add_argument("images")
    p.add_argument("video")
    p.add_argument("--decoder", choices=("pyav", "torchcodec"), default="pyav")
    p.set_defaults(run=psnr)
    p = sub.add_parser("same")
    p.add_argument("new")
    p.add_argument("old")
    p.add_argument("--step", type=int, default=1)
    p.set_defaults(run=same)
    p = sub.add_parser("png-estimate")
    p.add_argument("png_run")
    p.add_argument("images")
    p.set_defaults(run=png_estimate)
    a = ap.parse_args()
    a.run(a)


if __name__ == "__main__":
    main()
