"""Sizes of lossless encodings of a LeRobot export's depth (or any one-channel) camera.

    python python/bench/lerobot_depth_encodings.py --data DATASET/data/chunk-000/file-000.parquet \
        [--column observation.depth] [--frames 600]

Takes the first `--frames` cells of the column (minos writes depth as PFM files) and prints
the bytes of the same frames stored as:

1. the PFM files in zstd pages of 1 MB (what the Parquet column does), at zstd levels 1, 3,
   6 (minos's level), 9 and 19, with the compression speed on this machine;
2. float32 TIFF files, one per frame, written by Pillow through libtiff: Deflate without a
   predictor and with the floating-point predictor (Predictor 3), and the same with zstd
   (compression 50000) when this Pillow's libtiff has it.

Every TIFF is opened again with Pillow (as Hugging Face `datasets` does for LeRobot) and
must give the PFM's float32 values bit for bit; the script fails otherwise.
"""

import argparse
import io
import sys
import time

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
from PIL import Image, TiffImagePlugin


def pfm_values(cell: bytes) -> np.ndarray:
    """A minos PFM cell (`Pf`, little-endian, bottom row first) as a top-row-first array."""
    magic, size, _scale, body = cell.split(b"\n", 3)
    assert magic == b"Pf", magic
    w, h = map(int, size.split())
    return np.frombuffer(body, "<f4").reshape(h, w)[::-1].copy()


def zstd_pages(raw: bytes, level: int, page: int = 1 << 20) -> tuple[int, float]:
    codec = pa.Codec("zstd", compression_level=level)
    start = time.process_time()
    n = sum(len(codec.compress(raw[i : i + page])) for i in range(0, len(raw), page))
    return n, len(raw) / max(time.process_time() - start, 1e-9) / 1e6


def tiff(values: np.ndarray, compression: str, predictor: int) -> bytes:
    TiffImagePlugin.WRITE_LIBTIFF = True
    buf = io.BytesIO()
    Image.fromarray(values, mode="F").save(
        buf, "TIFF", compression=compression, tiffinfo={317: predictor}
    )
    data = buf.getvalue()
    back = np.array(Image.open(io.BytesIO(data)))
    if back.dtype != np.float32 or not np.array_equal(
        back.view(np.uint32), values.view(np.uint32)
    ):
        sys.exit(f"{compression} predictor {predictor}: Pillow does not give the values back")
    return data


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--column", default="observation.depth")
    ap.add_argument("--frames", type=int, default=600)
    a = ap.parse_args()
    table = pq.read_table(a.data, columns=[a.column]).slice(0, a.frames)
    cells = [c["bytes"] for c in table.column(0).to_pylist()]
    raw = b"".join(cells)
    print(f"{len(cells)} frames of {a.column}: {len(raw):,} bytes of PFM files")
    print("| encoding | bytes | compression speed |")
    print("|---|---|---|")
    for level in (1, 3, 6, 9, 19):
        n, speed = zstd_pages(raw, level)
        print(f"| PFM in zstd-{level} pages of 1 MB | {n:,} | {speed:.0f} MB/s |")
    values = [pfm_values(c) for c in cells]
    for compression, name in (("tiff_adobe_deflate", "Deflate"), ("zstd", "zstd")):
        for predictor, what in ((1, "no predictor"), (3, "floating-point predictor")):
            try:
                start = time.process_time()
                n = sum(len(tiff(v, compression, predictor)) for v in values)
                speed = len(raw) / max(time.process_time() - start, 1e-9) / 1e6
            except (OSError, ValueError) as e:
                print(f"| TIFF per frame, {name}, {what} | not written here: {e} | |")
                continue
            print(
                f"| TIFF per frame, {name}, {what} (read back exactly) | {n:,} "
                f"| {speed:.0f} MB/s (write + read) |"
            )


if __name__ == "__main__":
    main()
