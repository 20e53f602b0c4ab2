//! The checksum pass of `minos verify`: `cargo bench --bench verify`.
//!
//! Writes a LeRobot-like Parquet file (`MINOS_BENCH_VERIFY_MB`, default 256 MB: an image
//! column of incompressible bytes, zstd as minos writes it) into a temporary folder with a
//! provenance record, then measures on one thread `sha256_file` alone and the checksums of
//! the whole folder (what `minos verify` compares with the record). Throughput is bytes over
//! the thread's CPU time (steadier than wall time on a shared box), best of 5, file in the
//! page cache. The bar is ≥ 1 GB/s on one core.

use std::time::Instant;

use minos::provenance::{checksums, sha256_file};

/// CPU time (s) of the calling thread, from `/proc/thread-self/stat` (Linux).
fn thread_cpu() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/thread-self/stat").ok()?;
    let rest = stat.rsplit_once(')')?.1;
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

/// Best of 5 of `f`'s (CPU, wall) seconds.
fn best(mut f: impl FnMut()) -> (f64, f64) {
    let mut out = (f64::INFINITY, f64::INFINITY);
    for _ in 0..5 {
        let (c0, w0) = (thread_cpu().unwrap_or(0.0), Instant::now());
        f();
        let cpu = thread_cpu().unwrap_or(0.0) - c0;
        out = (out.0.min(cpu), out.1.min(w0.elapsed().as_secs_f64()));
    }
    out
}

fn main() {
    let mb: usize = std::env::var("MINOS_BENCH_VERIFY_MB")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(256);
    let dir = tempfile::tempdir().expect("tempdir");
    let file = dir.path().join("data/chunk-000/file-000.parquet");
    std::fs::create_dir_all(file.parent().expect("parent")).expect("mkdir");
    // Incompressible frames (xorshift), 16 KiB each, as one binary column.
    let frame = 16 * 1024;
    let rows = mb * 1024 * 1024 / frame;
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut builder = arrow::array::BinaryBuilder::new();
    let mut buf = vec![0u8; frame];
    for _ in 0..rows {
        for chunk in buf.chunks_mut(8) {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            chunk.copy_from_slice(&state.to_le_bytes()[..chunk.len()]);
        }
        builder.append_value(&buf);
    }
    let column: arrow::array::ArrayRef = std::sync::Arc::new(builder.finish());
    let batch = arrow::array::RecordBatch::try_from_iter([("image", column)]).expect("batch");
    let props = minos::parquet_io::writer_properties(1, None, &batch.schema());
    minos::parquet_io::write_batches(&file, batch.schema(), props, std::iter::once(Ok(batch)))
        .expect("write");
    let record = serde_json::json!({
        "format": minos::provenance::FORMAT,
        "files": checksums(dir.path(), &["meta/provenance.json"]).expect("checksums"),
    });
    minos::provenance::write_record(&dir.path().join("meta/provenance.json"), &record)
        .expect("record");
    let bytes = std::fs::metadata(&file).expect("size").len() as f64;
    println!(
        "checksum pass over a {:.0} MB Parquet file, one thread:",
        bytes / 1e6
    );
    let (cpu, wall) = best(|| {
        sha256_file(&file).expect("sha256");
    });
    println!(
        "  sha256_file              {:>7.0} MB/s CPU time ({:.0} MB/s wall)",
        bytes / cpu / 1e6,
        bytes / wall / 1e6
    );
    // What `verify` compares with the record: every file of the folder hashed.
    let (cpu, wall) = best(|| {
        checksums(dir.path(), &["meta/provenance.json"]).expect("checksums");
    });
    println!(
        "  checksums of the folder  {:>7.0} MB/s CPU time ({:.0} MB/s wall)",
        bytes / cpu / 1e6,
        bytes / wall / 1e6
    );
}
