//! The manifest `DATA/houses.parquet`: one row per scene, errors included, for filtering
//! (`minos split --where`) and statistics (`minos stats`).
//!
//! Columns (see `docs/FORMATS.md`): `id`, `dataset`, `source_path`, `nlevels`, `nrooms`,
//! `nobjects`, `floor_area`, `bbox_min_{x,y,z}`, `bbox_max_{x,y,z}`, `room_classes`,
//! `room_types`, `categories`, `coarse_categories`, `ntriangles`, `error`. On error rows every
//! statistic is null and `error` holds the one-line message.

use std::collections::BTreeSet;
use std::path::Path;
use std::sync::Arc;

use crate::invalid::Invalid;
use crate::parquet_io::{column, read_batches, write_batches, writer_properties, ParquetFileError};
use crate::scene::Scene;
use arrow::array::{
    Array, ArrayRef, Float64Array, ListArray, ListBuilder, RecordBatch, StringArray, StringBuilder,
    UInt32Array, UInt64Array,
};
use arrow::datatypes::{DataType, Field, Schema};

/// Errors reading or writing the manifest.
pub type ManifestError = ParquetFileError;

/// One scene's row in the manifest.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ManifestRow {
    /// Scene id.
    pub id: String,
    /// Dataset name (`suncg`, `mp3d`, …).
    pub dataset: String,
    /// Path of the scene's main source file.
    pub source_path: String,
    /// Number of levels.
    pub nlevels: u32,
    /// Number of rooms (regions for Matterport3D).
    pub nrooms: u32,
    /// Number of objects.
    pub nobjects: u32,
    /// Total room floor area in m².
    pub floor_area: f64,
    /// Scene box minimum corner.
    pub bbox_min: [f64; 3],
    /// Scene box maximum corner.
    pub bbox_max: [f64; 3],
    /// MINOS room class names present (sorted, distinct).
    pub room_classes: Vec<String>,
    /// Raw room type labels present (sorted, distinct).
    pub room_types: Vec<String>,
    /// Fine object categories present (sorted, distinct).
    pub categories: Vec<String>,
    /// Coarse object categories present (sorted, distinct).
    pub coarse_categories: Vec<String>,
    /// Triangles of all placed geometry.
    pub ntriangles: u64,
    /// Why the scene failed to load, or `None`.
    pub error: Option<String>,
}

impl ManifestRow {
    /// The row describing a loaded scene.
    pub fn from_scene(scene: &Scene, source_path: &str) -> Self {
        let sorted = |it: &mut dyn Iterator<Item = String>| -> Vec<String> {
            it.collect::<BTreeSet<_>>().into_iter().collect()
        };
        let bbox = scene.bbox();
        let corner = |v: glam::Vec3| [f64::from(v.x), f64::from(v.y), f64::from(v.z)];
        let (bbox_min, bbox_max) = if bbox.is_empty() {
            ([0.0; 3], [0.0; 3])
        } else {
            (corner(bbox.min), corner(bbox.max))
        };
        ManifestRow {
            id: scene.id.clone(),
            dataset: scene.dataset.name().to_string(),
            source_path: source_path.to_string(),
            nlevels: scene.levels.len() as u32,
            nrooms: scene.rooms().count() as u32,
            nobjects: scene.objects().count() as u32,
            floor_area: scene.floor_area(),
            bbox_min,
            bbox_max,
            room_classes: sorted(&mut scene.rooms().map(|r| r.class.name().to_string())),
            room_types: sorted(&mut scene.rooms().flat_map(|r| r.raw_types.iter().cloned())),
            categories: sorted(&mut scene.objects().filter_map(|o| o.categories.fine.clone())),
            coarse_categories: sorted(
                &mut scene.objects().filter_map(|o| o.categories.coarse.clone()),
            ),
            ntriangles: scene.triangle_count(),
            error: None,
        }
    }

    /// The row of a scene that failed to load.
    pub fn failed(id: &str, dataset: &str, source_path: &str, error: String) -> Self {
        ManifestRow {
            id: id.to_string(),
            dataset: dataset.to_string(),
            source_path: source_path.to_string(),
            error: Some(error),
            ..Default::default()
        }
    }

    /// True when the scene loaded.
    pub fn is_ok(&self) -> bool {
        self.error.is_none()
    }
}

fn schema() -> Arc<Schema> {
    let list = || DataType::List(Arc::new(Field::new("item", DataType::Utf8, true)));
    let mut fields = vec![
        Field::new("id", DataType::Utf8, false),
        Field::new("dataset", DataType::Utf8, false),
        Field::new("source_path", DataType::Utf8, false),
        Field::new("nlevels", DataType::UInt32, true),
        Field::new("nrooms", DataType::UInt32, true),
        Field::new("nobjects", DataType::UInt32, true),
        Field::new("floor_area", DataType::Float64, true),
    ];
    for c in [
        "bbox_min_x",
        "bbox_min_y",
        "bbox_min_z",
        "bbox_max_x",
        "bbox_max_y",
        "bbox_max_z",
    ] {
        fields.push(Field::new(c, DataType::Float64, true));
    }
    for c in [
        "room_classes",
        "room_types",
        "categories",
        "coarse_categories",
    ] {
        fields.push(Field::new(c, list(), true));
    }
    fields.push(Field::new("ntriangles", DataType::UInt64, true));
    fields.push(Field::new("error", DataType::Utf8, true));
    Arc::new(Schema::new(fields))
}

fn to_batch(rows: &[ManifestRow]) -> Result<RecordBatch, arrow::error::ArrowError> {
    let ok = |r: &ManifestRow| r.is_ok();
    let strs = |f: fn(&ManifestRow) -> &str| -> ArrayRef {
        Arc::new(StringArray::from_iter_values(rows.iter().map(f)))
    };
    let u32s = |f: fn(&ManifestRow) -> u32| -> ArrayRef {
        Arc::new(
            rows.iter()
                .map(|r| ok(r).then(|| f(r)))
                .collect::<UInt32Array>(),
        )
    };
    let f64s = |f: &dyn Fn(&ManifestRow) -> f64| -> ArrayRef {
        Arc::new(
            rows.iter()
                .map(|r| ok(r).then(|| f(r)))
                .collect::<Float64Array>(),
        )
    };
    let lists = |f: fn(&ManifestRow) -> &Vec<String>| -> ArrayRef {
        let mut b = ListBuilder::new(StringBuilder::new());
        for r in rows {
            if ok(r) {
                for s in f(r) {
                    b.values().append_value(s);
                }
                b.append(true);
            } else {
                b.append(false);
            }
        }
        Arc::new(b.finish())
    };
    let mut columns: Vec<ArrayRef> = vec![
        strs(|r| &r.id),
        strs(|r| &r.dataset),
        strs(|r| &r.source_path),
        u32s(|r| r.nlevels),
        u32s(|r| r.nrooms),
        u32s(|r| r.nobjects),
        f64s(&|r| r.floor_area),
    ];
    for axis in 0..3 {
        columns.push(f64s(&|r| r.bbox_min[axis]));
    }
    for axis in 0..3 {
        columns.push(f64s(&|r| r.bbox_max[axis]));
    }
    columns.push(lists(|r| &r.room_classes));
    columns.push(lists(|r| &r.room_types));
    columns.push(lists(|r| &r.categories));
    columns.push(lists(|r| &r.coarse_categories));
    columns.push(Arc::new(
        rows.iter()
            .map(|r| ok(r).then_some(r.ntriangles))
            .collect::<UInt64Array>(),
    ));
    columns.push(Arc::new(
        rows.iter()
            .map(|r| r.error.as_deref())
            .collect::<StringArray>(),
    ));
    RecordBatch::try_new(schema(), columns)
}

/// Writes the manifest atomically (rows in the order given; callers sort by id).
pub fn write_manifest(path: &Path, rows: &[ManifestRow]) -> Result<(), ManifestError> {
    let batch = to_batch(rows).map_err(|e| ParquetFileError::format(path, e))?;
    let props = writer_properties(3, None, &batch.schema());
    write_batches(path, batch.schema(), props, [Ok(batch)])
}

/// Reads every row of a manifest.
pub fn read_manifest(path: &Path) -> Result<Vec<ManifestRow>, ManifestError> {
    let reader = read_batches(path)?.conform_to(&schema());
    let mut rows = Vec::new();
    for batch in reader {
        let batch = batch.map_err(|e| ParquetFileError::format(path, e))?;
        read_batch(&batch, &mut rows).map_err(|e| ParquetFileError::format(path, e))?;
    }
    Ok(rows)
}

fn read_batch(batch: &RecordBatch, rows: &mut Vec<ManifestRow>) -> Result<(), Invalid> {
    let id = column::<StringArray>(batch, "id")?;
    let dataset = column::<StringArray>(batch, "dataset")?;
    let source = column::<StringArray>(batch, "source_path")?;
    let nlevels = column::<UInt32Array>(batch, "nlevels")?;
    let nrooms = column::<UInt32Array>(batch, "nrooms")?;
    let nobjects = column::<UInt32Array>(batch, "nobjects")?;
    let area = column::<Float64Array>(batch, "floor_area")?;
    let bbox: Vec<&Float64Array> = [
        "bbox_min_x",
        "bbox_min_y",
        "bbox_min_z",
        "bbox_max_x",
        "bbox_max_y",
        "bbox_max_z",
    ]
    .iter()
    .map(|c| column::<Float64Array>(batch, c))
    .collect::<Result<_, _>>()?;
    let lists: Vec<&ListArray> = [
        "room_classes",
        "room_types",
        "categories",
        "coarse_categories",
    ]
    .iter()
    .map(|c| column::<ListArray>(batch, c))
    .collect::<Result<_, _>>()?;
    let ntri = column::<UInt64Array>(batch, "ntriangles")?;
    let error = column::<StringArray>(batch, "error")?;
    let list_at = |l: &ListArray, i: usize| -> Vec<String> {
        if l.is_null(i) {
            return Vec::new();
        }
        let v = l.value(i);
        v.as_any()
            .downcast_ref::<StringArray>()
            .map(|s| s.iter().flatten().map(str::to_string).collect())
            .unwrap_or_default()
    };
    let num = |a: &Float64Array, i: usize| if a.is_null(i) { 0.0 } else { a.value(i) };
    let int = |a: &UInt32Array, i: usize| if a.is_null(i) { 0 } else { a.value(i) };
    for i in 0..batch.num_rows() {
        rows.push(ManifestRow {
            id: id.value(i).to_string(),
            dataset: dataset.value(i).to_string(),
            source_path: source.value(i).to_string(),
            nlevels: int(nlevels, i),
            nrooms: int(nrooms, i),
            nobjects: int(nobjects, i),
            floor_area: num(area, i),
            bbox_min: [num(bbox[0], i), num(bbox[1], i), num(bbox[2], i)],
            bbox_max: [num(bbox[3], i), num(bbox[4], i), num(bbox[5], i)],
            room_classes: list_at(lists[0], i),
            room_types: list_at(lists[1], i),
            categories: list_at(lists[2], i),
            coarse_categories: list_at(lists[3], i),
            ntriangles: if ntri.is_null(i) { 0 } else { ntri.value(i) },
            error: (!error.is_null(i)).then(|| error.value(i).to_string()),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_round_trip_through_parquet_with_nulls_for_failures() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("houses.parquet");
        let good = ManifestRow {
            id: "a".into(),
            dataset: "suncg".into(),
            source_path: "house/a/house.json".into(),
            nlevels: 1,
            nrooms: 3,
            nobjects: 12,
            floor_area: 42.5,
            bbox_min: [0.0, 0.0, 0.0],
            bbox_max: [5.0, 2.7, 8.5],
            room_classes: vec!["bedroom".into(), "kitchen".into()],
            room_types: vec!["Bedroom".into(), "Kitchen".into()],
            categories: vec!["chair".into()],
            coarse_categories: vec!["chair".into()],
            ntriangles: 1234,
            error: None,
        };
        let bad = ManifestRow::failed("b", "suncg", "house/b/house.json", "boom".into());
        write_manifest(&path, &[good.clone(), bad.clone()]).unwrap();
        let back = read_manifest(&path).unwrap();
        assert_eq!(back, vec![good, bad]);
    }
}
