//! A LeRobot-style copy of a run (`--format lerobot`): one Parquet file per episode under
//! `data/chunk-000/`, `meta/info.json` with the features and fps, `meta/episodes.jsonl` and
//! `meta/tasks.jsonl`, so imitation-learning code that reads that layout trains on it.

use std::fs::File;
use std::path::Path;
use std::sync::Arc;

use arrow::array::{
    Array, ArrayRef, BinaryArray, BooleanArray, Float32Array, Float32Builder, Int64Array,
    ListArray, ListBuilder, RecordBatch, UInt32Array,
};
use arrow::datatypes::{DataType, Field, Schema};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use serde_json::json;

use crate::atomic::write_bytes_atomic;
use crate::episode::Episode;
use crate::sim::sensors::{dtype_of, CameraSensor};

/// Episodes per chunk folder.
const CHUNK: usize = 1000;

fn read_all(path: &Path) -> Result<Vec<RecordBatch>, String> {
    let f = File::open(path).map_err(|e| format!("{}: {e}", path.display()))?;
    ParquetRecordBatchReaderBuilder::try_new(f)
        .and_then(|b| b.build())
        .map_err(|e| format!("{}: {e}", path.display()))?
        .map(|b| b.map_err(|e| format!("{}: {e}", path.display())))
        .collect()
}

fn col<'a, T: 'static>(b: &'a RecordBatch, name: &str) -> Result<&'a T, String> {
    b.column_by_name(name)
        .and_then(|c| c.as_any().downcast_ref::<T>())
        .ok_or_else(|| format!("column `{name}` missing"))
}

/// Writes the layout into `dir` from the run's per-episode part files (`parts[i]` = the
/// trajectory and observation parts of `episodes[i]`).
pub fn write(
    dir: &Path,
    episodes: &[(Episode, std::path::PathBuf, std::path::PathBuf)],
    cameras: &[CameraSensor],
    fps: f32,
) -> Result<(), String> {
    let mut tasks: Vec<String> = episodes
        .iter()
        .map(|(e, _, _)| e.task.name().to_string())
        .collect();
    tasks.sort();
    tasks.dedup();
    let mut global = 0i64;
    let mut lines = String::new();
    for (index, (ep, traj, obs)) in episodes.iter().enumerate() {
        let t = read_all(traj)?;
        let o = read_all(obs)?;
        let t = arrow::compute::concat_batches(
            &t.first().map(|b| b.schema()).ok_or("empty trajectory")?,
            &t,
        )
        .map_err(|e| e.to_string())?;
        let o = arrow::compute::concat_batches(
            &o.first().map(|b| b.schema()).ok_or("empty observations")?,
            &o,
        )
        .map_err(|e| e.to_string())?;
        let n = t.num_rows();
        let mut state = ListBuilder::new(Float32Builder::new());
        for i in 0..n {
            for c in ["x", "y", "z", "yaw", "tilt"] {
                state
                    .values()
                    .append_value(col::<Float32Array>(&t, c)?.value(i));
            }
            state.append(true);
        }
        let steps = col::<UInt32Array>(&t, "step")?;
        let task_index = tasks.iter().position(|x| x == ep.task.name()).unwrap_or(0) as i64;
        let mut fields = vec![
            Field::new(
                "observation.state",
                DataType::List(Arc::new(Field::new("item", DataType::Float32, true))),
                false,
            ),
            Field::new(
                "action",
                DataType::List(Arc::new(Field::new("item", DataType::Float32, true))),
                false,
            ),
            Field::new("episode_index", DataType::Int64, false),
            Field::new("frame_index", DataType::Int64, false),
            Field::new("timestamp", DataType::Float32, false),
            Field::new("next.reward", DataType::Float32, false),
            Field::new("next.done", DataType::Boolean, false),
            Field::new("next.success", DataType::Boolean, false),
            Field::new("index", DataType::Int64, false),
            Field::new("task_index", DataType::Int64, false),
        ];
        let mut columns: Vec<ArrayRef> = vec![
            Arc::new(state.finish()),
            Arc::new(col::<ListArray>(&t, "action_strengths")?.clone()),
            Arc::new(Int64Array::from(vec![index as i64; n])),
            Arc::new(
                (0..n)
                    .map(|i| i64::from(steps.value(i)))
                    .collect::<Int64Array>(),
            ),
            Arc::new(
                (0..n)
                    .map(|i| steps.value(i) as f32 / fps)
                    .collect::<Float32Array>(),
            ),
            Arc::new(col::<Float32Array>(&t, "reward")?.clone()),
            Arc::new(col::<BooleanArray>(&t, "done")?.clone()),
            Arc::new(col::<BooleanArray>(&t, "success")?.clone()),
            Arc::new((0..n).map(|i| global + i as i64).collect::<Int64Array>()),
            Arc::new(Int64Array::from(vec![task_index; n])),
        ];
        for c in cameras {
            let images = col::<BinaryArray>(&o, &c.name)?;
            if images.len() != n {
                return Err(format!(
                    "episode {}: {} observations for {n} steps",
                    ep.episode_id,
                    images.len()
                ));
            }
            fields.push(Field::new(
                format!("observation.images.{}", c.name),
                DataType::Binary,
                false,
            ));
            columns.push(Arc::new(images.clone()));
        }
        let schema = Arc::new(Schema::new(fields));
        let batch = RecordBatch::try_new(schema.clone(), columns).map_err(|e| e.to_string())?;
        let path = dir.join(format!(
            "data/chunk-{:03}/episode_{index:06}.parquet",
            index / CHUNK
        ));
        let mut buf = Vec::new();
        {
            let mut w = parquet::arrow::ArrowWriter::try_new(&mut buf, schema, None)
                .map_err(|e| e.to_string())?;
            w.write(&batch).map_err(|e| e.to_string())?;
            w.close().map_err(|e| e.to_string())?;
        }
        write_bytes_atomic(&path, &buf).map_err(|e| format!("{}: {e}", path.display()))?;
        lines.push_str(&json!({"episode_index": index, "episode_id": ep.episode_id, "tasks": [ep.task.name()], "length": n}).to_string());
        lines.push('\n');
        global += n as i64;
    }
    write_bytes_atomic(&dir.join("meta/episodes.jsonl"), lines.as_bytes())
        .map_err(|e| e.to_string())?;
    let tasks_jsonl: String = tasks
        .iter()
        .enumerate()
        .map(|(i, t)| format!("{}\n", json!({"task_index": i, "task": t})))
        .collect();
    write_bytes_atomic(&dir.join("meta/tasks.jsonl"), tasks_jsonl.as_bytes())
        .map_err(|e| e.to_string())?;
    let mut features = serde_json::Map::new();
    features.insert(
        "observation.state".into(),
        json!({"dtype": "float32", "shape": [5], "names": ["x", "y", "z", "yaw", "tilt"]}),
    );
    features.insert("action".into(), json!({"dtype": "float32", "shape": [8], "names": ["forward", "backward", "strafe_left", "strafe_right", "turn_left", "turn_right", "look_up", "look_down"]}));
    for c in cameras {
        let (dtype, channels) = dtype_of(c);
        features.insert(format!("observation.images.{}", c.name), json!({"dtype": dtype, "shape": [c.resolution[1], c.resolution[0], channels], "names": ["height", "width", "channel"], "encoding": "raw-le"}));
    }
    for (k, d) in [
        ("episode_index", "int64"),
        ("frame_index", "int64"),
        ("timestamp", "float32"),
        ("next.reward", "float32"),
        ("next.done", "bool"),
        ("next.success", "bool"),
        ("index", "int64"),
        ("task_index", "int64"),
    ] {
        features.insert(k.into(), json!({"dtype": d, "shape": [1], "names": null}));
    }
    let info = json!({
        "codebase_version": "v2.0",
        "robot_type": "minos-agent",
        "fps": fps,
        "total_episodes": episodes.len(),
        "total_frames": global,
        "total_tasks": tasks.len(),
        "chunks_size": CHUNK,
        "total_chunks": episodes.len().div_ceil(CHUNK),
        "data_path": "data/chunk-{episode_chunk:03d}/episode_{episode_index:06d}.parquet",
        "features": features,
    });
    write_bytes_atomic(
        &dir.join("meta/info.json"),
        &serde_json::to_vec_pretty(&info).map_err(|e| e.to_string())?,
    )
    .map_err(|e| e.to_string())?;
    Ok(())
}
