//! Where each file of a LeRobot v3.0 dataset lives, relative to the dataset's root: LeRobot's
//! layout, spelled once for the writer, the dataset card, `minos verify` and `minos merge`.

use std::path::Path;

/// `meta/info.json`: format version, fps, features, totals, splits, path templates.
pub const INFO: &str = "meta/info.json";

/// `meta/stats.json`: per-feature statistics of the whole dataset.
pub const STATS: &str = "meta/stats.json";

/// `meta/tasks.parquet`: the tasks (instructions), as a pandas index.
pub const TASKS: &str = "meta/tasks.parquet";

/// `meta/episodes/`: the folder of the per-episode tables ([`FileIndex::path`]).
pub const EPISODES: &str = "meta/episodes";

/// `meta/provenance.json`: minos's provenance record, written last.
pub const PROVENANCE: &str = "meta/provenance.json";

/// `README.md`: the dataset card.
pub const CARD: &str = "README.md";

/// `data/`: the folder of the frame tables ([`FileIndex::path`]).
pub const DATA: &str = "data";

/// Files per chunk folder (LeRobot's default).
pub const CHUNK_SIZE: usize = 1000;

/// LeRobot's `data_path` template, as `meta/info.json` states it.
pub const DATA_PATH: &str = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet";

/// LeRobot's `video_path` template, as `meta/info.json` states it.
pub const VIDEO_PATH: &str = "videos/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4";

/// The folder of the video files, one folder per camera key.
pub const VIDEOS: &str = "videos";

/// The `meta/episodes` column holding one field of a camera's video place for each episode:
/// `videos/<key>/<field>`, `field` one of `chunk_index`, `file_index`, `from_timestamp`,
/// `to_timestamp`.
pub fn video_column(key: &str, field: &str) -> String {
    format!("{VIDEOS}/{key}/{field}")
}

/// A file's place: chunk folder and file number.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Default)]
pub struct FileIndex {
    /// `chunk-NNN`.
    pub chunk: usize,
    /// `file-NNN`.
    pub file: usize,
}

impl FileIndex {
    /// The next file (a new chunk after [`CHUNK_SIZE`] files), as LeRobot numbers them.
    pub fn next(self) -> FileIndex {
        if self.file + 1 == CHUNK_SIZE {
            FileIndex {
                chunk: self.chunk + 1,
                file: 0,
            }
        } else {
            FileIndex {
                chunk: self.chunk,
                file: self.file + 1,
            }
        }
    }

    /// `<dir>/chunk-NNN/file-NNN.parquet` ([`DATA`] or [`EPISODES`] as `dir`).
    pub fn path(self, dir: &str) -> String {
        format!(
            "{dir}/chunk-{:03}/file-{:03}.parquet",
            self.chunk, self.file
        )
    }

    /// `videos/<key>/chunk-NNN/file-NNN.mp4`: a camera's video file ([`VIDEO_PATH`]).
    pub fn video(self, key: &str) -> String {
        format!(
            "{VIDEOS}/{key}/chunk-{:03}/file-{:03}.mp4",
            self.chunk, self.file
        )
    }

    /// The chunk and file numbers in a `chunk-NNN/file-NNN.<ext>` path, if it is one.
    pub fn of_path(path: &Path) -> Option<FileIndex> {
        let file = path
            .file_stem()?
            .to_str()?
            .strip_prefix("file-")?
            .parse()
            .ok()?;
        let chunk = path
            .parent()?
            .file_name()?
            .to_str()?
            .strip_prefix("chunk-")?
            .parse()
            .ok()?;
        Some(FileIndex { chunk, file })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn file_indices_roll_into_a_new_chunk_after_chunk_size_files() {
        let mut i = FileIndex::default();
        for _ in 0..CHUNK_SIZE - 1 {
            i = i.next();
        }
        assert_eq!(
            i,
            FileIndex {
                chunk: 0,
                file: 999
            }
        );
        assert_eq!(i.next(), FileIndex { chunk: 1, file: 0 });
    }

    #[test]
    fn paths_follow_the_templates_info_json_states() {
        let i = FileIndex { chunk: 2, file: 17 };
        // The templates with LeRobot's python format spec filled in by hand.
        let data = DATA_PATH
            .replace("{chunk_index:03d}", "002")
            .replace("{file_index:03d}", "017");
        let video = VIDEO_PATH
            .replace("{video_key}", "observation.images.color")
            .replace("{chunk_index:03d}", "002")
            .replace("{file_index:03d}", "017");
        assert_eq!(i.path(DATA), data);
        assert_eq!(i.video("observation.images.color"), video);
        assert_eq!(i.path(EPISODES), "meta/episodes/chunk-002/file-017.parquet");
        assert_eq!(FileIndex::of_path(Path::new(&data)), Some(i));
        assert_eq!(FileIndex::of_path(Path::new(&video)), Some(i));
        assert_eq!(
            FileIndex::of_path(Path::new("data/chunk-x/file-001.parquet")),
            None
        );
        // LeRobot 0.4.4's episode metadata names a video's place `videos/<key>/<field>`.
        assert_eq!(
            video_column("observation.images.color", "from_timestamp"),
            "videos/observation.images.color/from_timestamp"
        );
    }
}
