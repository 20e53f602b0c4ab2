"""Rewrites a Parquet file made by minos the way users' tools write it back, for the test
that minos reads every variant (tests/episodes.rs, `episode_files_rewritten_by_*`).

usage: rewrite_parquet.py INPUT OUT_DIR

Writes OUT_DIR/<library>-<variant>-<compression>.parquet with each library found (pyarrow,
pandas, polars, duckdb), every standard compression, and the type variants each writes
(large and view strings and lists, dictionary-encoded strings, pandas' own dtypes), plus
OUT_DIR/<library>-filtered-*.parquet holding only the rows whose `task` is `objectgoal`.
Prints one line per file written and `skipped <library>: <why>` for a library it lacks or a
variant the library cannot write.
"""

import os
import sys

import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

src, out = sys.argv[1], sys.argv[2]
os.makedirs(out, exist_ok=True)
COMPRESSIONS = ["snappy", "gzip", "brotli", "lz4", "zstd", "none"]


def wrote(name):
    print(os.path.join(out, name + ".parquet"))


def path(name):
    return os.path.join(out, name + ".parquet")


def retype(t, kind):
    """Every string / list type of `t`, at any depth, made large when `kind` is "large"."""
    if pa.types.is_string(t) or pa.types.is_large_string(t) or pa.types.is_string_view(t):
        return pa.large_string() if kind == "large" else t
    if pa.types.is_list(t) or pa.types.is_large_list(t):
        inner = pa.field(t.value_field.name, retype(t.value_type, kind), t.value_field.nullable)
        return pa.large_list(inner) if kind == "large" else pa.list_(inner)
    if pa.types.is_fixed_size_list(t):
        inner = pa.field(t.value_field.name, retype(t.value_type, kind), t.value_field.nullable)
        return pa.list_(inner, t.list_size)
    return t


table = pq.read_table(src)

# pyarrow: every compression; large and view types; dictionary-encoded strings.
for c in COMPRESSIONS:
    pq.write_table(table, path(f"pyarrow-plain-{c}"), compression=c)
    wrote(f"pyarrow-plain-{c}")
schema = pa.schema([f.with_type(retype(f.type, "large")) for f in table.schema])
pq.write_table(table.cast(schema), path("pyarrow-large-zstd"), compression="zstd")
wrote("pyarrow-large-zstd")


def list_view(column):
    """A list column as a list_view of the same values (pyarrow casts no list to list_view)."""
    c = column.combine_chunks()
    sizes = pc.list_value_length(c).fill_null(0).cast(pa.int32())
    return pa.ListViewArray.from_arrays(c.offsets[:-1], sizes, c.values, mask=c.is_null())


views = table
for i, f in enumerate(table.schema):
    if pa.types.is_string(f.type):
        views = views.set_column(i, f.name, table.column(i).cast(pa.string_view()))
    elif pa.types.is_list(f.type):
        views = views.set_column(i, f.name, list_view(table.column(i)))
pq.write_table(views, path("pyarrow-view-zstd"), compression="zstd")
wrote("pyarrow-view-zstd")
dictionary = table
for i, f in enumerate(table.schema):
    if pa.types.is_string(f.type):
        dictionary = dictionary.set_column(i, f.name, pc.dictionary_encode(table.column(i)))
pq.write_table(dictionary, path("pyarrow-dictionary-snappy"), compression="snappy")
wrote("pyarrow-dictionary-snappy")

# pandas: its defaults (snappy, an index column when filtered) and each compression, with
# numpy and pyarrow dtypes; strings as a categorical.
import pandas as pd

df = pd.read_parquet(src)
for c in COMPRESSIONS:
    df.to_parquet(path(f"pandas-numpy-{c}"), compression=None if c == "none" else c)
    wrote(f"pandas-numpy-{c}")
pd.read_parquet(src, dtype_backend="pyarrow").to_parquet(path("pandas-arrow-snappy"))
wrote("pandas-arrow-snappy")
categorical = df.copy()
categorical["task"] = categorical["task"].astype("category")
categorical["max_steps"] = categorical["max_steps"].astype("int64")
categorical.to_parquet(path("pandas-categorical-snappy"))
wrote("pandas-categorical-snappy")
df[df["task"] == "objectgoal"].to_parquet(path("pandas-filtered-snappy"))
wrote("pandas-filtered-snappy")

try:
    import polars as pl
except ImportError as e:
    print(f"skipped polars: {e}")
else:
    frame = pl.read_parquet(src)
    for c in COMPRESSIONS:
        frame.write_parquet(path(f"polars-plain-{c}"), compression="uncompressed" if c == "none" else c)
        wrote(f"polars-plain-{c}")
    frame.filter(pl.col("task") == "objectgoal").write_parquet(path("polars-filtered-zstd"))
    wrote("polars-filtered-zstd")

try:
    import duckdb
except ImportError as e:
    print(f"skipped duckdb: {e}")
else:
    con = duckdb.connect()
    for c in COMPRESSIONS:
        codec = "uncompressed" if c == "none" else c
        con.execute(
            f"COPY (SELECT * FROM read_parquet('{src}')) TO '{path(f'duckdb-plain-{c}')}' "
            f"(FORMAT parquet, COMPRESSION {codec})"
        )
        wrote(f"duckdb-plain-{c}")
    con.execute(
        f"COPY (SELECT * FROM read_parquet('{src}') WHERE task = 'objectgoal') "
        f"TO '{path('duckdb-filtered-snappy')}' (FORMAT parquet)"
    )
    wrote("duckdb-filtered-snappy")
