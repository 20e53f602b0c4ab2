//! The provenance records of a DATA folder's scenes: what a run or an episode file says
//! about the scenes it used (checksums of the compiled scene, its sources, its variant).

use std::path::Path;

use super::DataDir;
use crate::file_error::FileError;
use crate::provenance::sha256_file;

/// The DATA folder's provenance record, at its root.
pub const DATA_RECORD: &str = "provenance.json";

/// Writes `DATA/provenance.json`, the DATA folder's provenance record: the minos that last
/// wrote it and the sha256 of every file the folder holds (no command line, time or host: the
/// same DATA gives the same record). The drivers that write DATA rewrite it when they finish:
/// an unsharded ingest, an unsharded bake, a split and `variants`.
pub fn write_data_record(data: &DataDir) -> Result<(), FileError> {
    let files = crate::provenance::checksums(data.root(), &[DATA_RECORD])?;
    let record = serde_json::json!({
        "format": crate::provenance::FORMAT,
        "kind": "data",
        "minos": crate::provenance::MINOS,
        "files": files,
    });
    crate::provenance::write_record(&data.root().join(DATA_RECORD), &record)
}

/// The scenes `ids` (`<scene>` or `<scene>@<variant>`; sorted, each once) as provenance
/// records them: the id, the sha256 of its compiled scene in `data`, of each source file the
/// compiled scene names and of the variant's description. A file that cannot be read (moved
/// sources) has `null` for its checksum.
pub fn scene_records<'a>(
    data: &DataDir,
    ids: impl IntoIterator<Item = &'a str>,
) -> Vec<serde_json::Value> {
    let ids: std::collections::BTreeSet<&str> = ids.into_iter().collect();
    let sum = |p: &Path| sha256_file(p).ok().map(|s| s.sha256);
    ids.into_iter()
        .map(|id| {
            let r = crate::scene::SceneRef::parse(id);
            let compiled = data.scene_path(&r.scene);
            let sources: Vec<serde_json::Value> = super::scene_file::read_header(&compiled)
                .map(|h| h.sources)
                .unwrap_or_default()
                .iter()
                .map(|s| serde_json::json!({"path": s, "sha256": sum(Path::new(s))}))
                .collect();
            let mut record = serde_json::json!({
                "id": id,
                "compiled_sha256": sum(&compiled),
                "sources": sources,
            });
            if let Some(v) = &r.variant {
                record["variant_sha256"] = serde_json::json!(sum(&data.variant_path(v)));
            }
            record
        })
        .collect()
}
