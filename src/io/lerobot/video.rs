//! Colour cameras as video (`--video`): each camera's frames, episode after episode, as
//! H.264 in MP4 files laid out as LeRobot v3.0 lays out its videos
//! (`videos/<key>/chunk-NNN/file-NNN.mp4`, a new file after [`VIDEO_FILE_MB`]).
//!
//! Encoding is OpenH264's (the `openh264` crate, built from its bundled source: no system
//! library or ffmpeg): High profile with CABAC entropy coding, rate control off at a constant
//! QP ([`VideoSettings`], 26 by default), one thread, no frame skipping: the same frames
//! give the same bytes. Every episode starts with an IDR
//! frame (and another comes every [`KEYFRAME_INTERVAL`] frames), so a reader seeks to an
//! episode or a frame without decoding what comes before it. Frame `k` of a file is shown at
//! `k / fps` seconds exactly (track timescale `1000 · fps`, 1000 ticks a frame), which is
//! what LeRobot's `from_timestamp + timestamp` queries find. The RGB → YUV 4:2:0 conversion
//! is defined here (BT.601 limited range, integer arithmetic, chroma the mean of each 2×2
//! block) and signalled in the stream's VUI, so it cannot change with a dependency's SIMD path.

use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use mp4::{AvcConfig, MediaConfig, Mp4Config, Mp4Sample, Mp4Writer, TrackConfig, TrackType};
use openh264::encoder::{
    Encoder, EncoderConfig, FrameType, IntraFramePeriod, Profile, RateControlMode, UsageType,
    VuiConfig,
};
use openh264::formats::YUVBuffer;
use openh264::OpenH264API;
use openh264_sys2::{SEncParamExt, ENCODER_OPTION_SVC_ENCODE_PARAM_EXT, PRO_HIGH};

use super::layout::FileIndex;

/// Largest video file before the next episode starts a new one (LeRobot's default), MB.
pub const VIDEO_FILE_MB: u64 = 200;

/// Frames between key (IDR) frames within an episode: a random frame is at most this many
/// frames of decoding away (LeRobot's own encoder uses 2). Longer intervals were measured:
/// 60 made `minos demo`-sized colour videos ≈ 1 % smaller (84² and 256²), 120 or more (one
/// key frame an episode) 1.2 %, for twice the decoding to reach a frame.
pub const KEYFRAME_INTERVAL: u32 = 30;

/// The codec's name as LeRobot's `info.json` records it (`video.codec`).
pub const CODEC: &str = "h264";

/// The quantiser of [`VideoSettings::default`]: ≈ 38.5 dB mean PSNR on 84² rendered rooms,
/// ≈ 42.3 dB at 256² (docs/PERFORMANCE.md).
pub const DEFAULT_QP: u8 = 26;

/// The largest quantiser H.264 has.
pub const MAX_QP: u8 = 51;

/// How colour cameras are encoded: the one choice a user makes, size against quality.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct VideoSettings {
    /// H.264's quantiser, the same for every frame (0 = finest, [`MAX_QP`] = coarsest; each
    /// 6 steps double the quantiser's step size). Measured on 84² rendered rooms: 26 gives
    /// ≈ 38.5 dB mean PSNR, 38 ≈ 31.7 dB in 42 % of the video bytes (docs/PERFORMANCE.md).
    pub qp: u8,
}

impl Default for VideoSettings {
    fn default() -> Self {
        VideoSettings { qp: DEFAULT_QP }
    }
}

impl VideoSettings {
    /// Settings with quantiser `qp`, or `None` when H.264 has no such quantiser.
    pub fn with_qp(qp: u8) -> Option<VideoSettings> {
        (qp <= MAX_QP).then_some(VideoSettings { qp })
    }

    /// How `info.json` describes the storage (`minos.storage`).
    pub fn storage(&self) -> String {
        format!(
            "H.264 (OpenH264, High profile, CABAC, constant QP {}, BT.601 limited range) in MP4, lossy",
            self.qp
        )
    }
}

/// The pixel format (`video.pix_fmt`).
pub const PIX_FMT: &str = "yuv420p";

/// Ticks of the track's clock per frame (the timescale is this × fps).
pub const TICKS_PER_FRAME: u32 = 1000;

/// Why a video could not be written (the caller names the file).
#[derive(Debug, thiserror::Error)]
pub enum VideoError {
    /// File system error.
    #[error(transparent)]
    Io(#[from] std::io::Error),
    /// The H.264 encoder failed (`frame`: at which frame; none when it could not start).
    #[error("{}H.264 encoder", frame.map(|f| format!("frame {f}: ")).unwrap_or_default())]
    Encoder {
        /// The frame being encoded.
        frame: Option<u64>,
        /// Why.
        #[source]
        source: openh264::Error,
    },
    /// The MP4 container could not be written (`frame`: at which frame's sample).
    #[error("{}MP4 container", frame.map(|f| format!("frame {f}: ")).unwrap_or_default())]
    Container {
        /// The frame being written.
        frame: Option<u64>,
        /// Why.
        #[source]
        source: mp4::Error,
    },
    /// A frame whose size is not the video's.
    #[error("frame {frame}: {bytes} bytes where {width}×{height} RGB has {}", width * height * 3)]
    FrameSize {
        /// The frame.
        frame: u64,
        /// Its bytes.
        bytes: usize,
        /// The video's width.
        width: usize,
        /// The video's height.
        height: usize,
    },
    /// The encoder gave no picture for a frame.
    #[error("frame {0}: the H.264 encoder gave no picture")]
    NoPicture(u64),
    /// The encoder's first frame came without the parameter sets the container needs.
    #[error("the H.264 encoder's first frame has no parameter sets")]
    NoParameterSets,
    /// The file was used after it was closed.
    #[error("the video file is closed")]
    Closed,
    /// The file was closed without a frame.
    #[error("a video file without frames")]
    NoFrames,
}

/// Whether a camera of this shape can be a video feature: three 8-bit channels and even
/// sides (4:2:0 chroma covers 2×2 blocks) within H.264's level 5.2.
pub fn video_shape_ok(width: u32, height: u32) -> bool {
    width >= 16
        && height >= 16
        && width.is_multiple_of(2)
        && height.is_multiple_of(2)
        && width.max(height) <= 3840
        && width.min(height) <= 2160
}

/// RGB (interleaved, 8-bit) as planar YUV 4:2:0 (I420), BT.601 limited range.
pub fn rgb_to_i420(rgb: &[u8], width: usize, height: usize) -> Vec<u8> {
    let (cw, ch) = (width / 2, height / 2);
    let mut out = vec![0u8; width * height + 2 * cw * ch];
    let (y_plane, uv) = out.split_at_mut(width * height);
    let (u_plane, v_plane) = uv.split_at_mut(cw * ch);
    let px = |x: usize, y: usize| {
        let i = 3 * (y * width + x);
        (
            i32::from(rgb[i]),
            i32::from(rgb[i + 1]),
            i32::from(rgb[i + 2]),
        )
    };
    for y in 0..height {
        for x in 0..width {
            let (r, g, b) = px(x, y);
            y_plane[y * width + x] = (((66 * r + 129 * g + 25 * b + 128) >> 8) + 16) as u8;
        }
    }
    for j in 0..ch {
        for i in 0..cw {
            let (mut r, mut g, mut b) = (0, 0, 0);
            for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let p = px(2 * i + dx, 2 * j + dy);
                r += p.0;
                g += p.1;
                b += p.2;
            }
            // The block's mean, rounded, then the BT.601 chroma rows.
            let (r, g, b) = ((r + 2) >> 2, (g + 2) >> 2, (b + 2) >> 2);
            u_plane[j * cw + i] = (((-38 * r - 74 * g + 112 * b + 128) >> 8) + 128) as u8;
            v_plane[j * cw + i] = (((112 * r - 94 * g - 18 * b + 128) >> 8) + 128) as u8;
        }
    }
    out
}

/// The encoder's settings that the `openh264` crate sets (see the module documentation and
/// [`start_encoder`]).
fn encoder_config() -> EncoderConfig {
    EncoderConfig::new()
        .usage_type(UsageType::CameraVideoRealTime)
        .profile(Profile::Baseline)
        .rate_control_mode(RateControlMode::Off)
        .skip_frames(false)
        .scene_change_detect(false)
        .adaptive_quantization(false)
        .background_detection(false)
        .intra_frame_period(IntraFramePeriod::from_num_frames(KEYFRAME_INTERVAL))
        .num_threads(1)
        .vui(VuiConfig::bt601())
}

/// An encoder for `width`×`height` frames with the settings of the module documentation.
///
/// The `openh264` crate sets neither the constant quantiser (rate control off uses the
/// layer's `iDLayerQp`, 26 unless told) nor CABAC, and it initialises OpenH264 at the
/// first frame. So this encodes one grey frame (its bytes are dropped), then hands OpenH264
/// the crate's parameters with the quantiser, CABAC and High profile set: a new profile
/// makes OpenH264 start afresh (`WelsEncoderParamAdjust`), so the next frame is an IDR
/// frame with its own parameter sets, as from a new encoder.
fn start_encoder(
    width: usize,
    height: usize,
    settings: VideoSettings,
) -> Result<Encoder, VideoError> {
    let failed = |source| VideoError::Encoder {
        frame: None,
        source,
    };
    let mut encoder =
        Encoder::with_api_config(OpenH264API::from_source(), encoder_config()).map_err(failed)?;
    let grey = YUVBuffer::from_vec(vec![128u8; width * height * 3 / 2], width, height);
    encoder.encode(&grey).map_err(failed)?;
    let mut params = SEncParamExt::default();
    // SAFETY: the encoder is initialised (it encoded a frame); OpenH264 fills and reads a
    // whole `SEncParamExt`, which `params` is, for this option; only the quantiser, the
    // entropy coder and the profile change, all of which OpenH264 validates.
    let (got, set) = unsafe {
        let api = encoder.raw_api();
        let got = api.get_option(
            ENCODER_OPTION_SVC_ENCODE_PARAM_EXT,
            (&raw mut params).cast(),
        );
        params.sSpatialLayers[0].iDLayerQp = i32::from(settings.qp.min(MAX_QP));
        params.sSpatialLayers[0].uiProfileIdc = PRO_HIGH;
        params.iEntropyCodingModeFlag = 1;
        let set = api.set_option(
            ENCODER_OPTION_SVC_ENCODE_PARAM_EXT,
            (&raw mut params).cast(),
        );
        (got, set)
    };
    if got != 0 || set != 0 {
        return Err(failed(openh264::Error::msg(
            "OpenH264 refused the quantiser and entropy coder settings",
        )));
    }
    Ok(encoder)
}

/// A NAL unit's payload without its Annex B start code.
fn strip_start_code(nal: &[u8]) -> &[u8] {
    if nal.starts_with(&[0, 0, 0, 1]) {
        &nal[4..]
    } else if nal.starts_with(&[0, 0, 1]) {
        &nal[3..]
    } else {
        nal
    }
}

/// One camera's video file being filled.
pub struct VideoFile {
    /// Where it is in the `videos/<key>/` folder.
    pub index: FileIndex,
    /// Its path.
    pub path: PathBuf,
    width: u32,
    height: u32,
    fps: u32,
    encoder: Encoder,
    writer: Option<Mp4Writer<BufWriter<File>>>,
    pending: Option<BufWriter<File>>,
    /// Frames written so far.
    pub frames: u64,
    /// Bytes of encoded frames written so far.
    pub bytes: u64,
}

impl VideoFile {
    /// Creates `path` for frames of `width`×`height` at `fps`.
    pub fn create(
        path: PathBuf,
        index: FileIndex,
        width: u32,
        height: u32,
        fps: u32,
        settings: VideoSettings,
    ) -> Result<VideoFile, VideoError> {
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir)?;
        }
        let file = File::create(&path)?;
        let encoder = start_encoder(width as usize, height as usize, settings)?;
        Ok(VideoFile {
            index,
            path,
            width,
            height,
            fps: fps.max(1),
            encoder,
            writer: None,
            pending: Some(BufWriter::new(file)),
            frames: 0,
            bytes: 0,
        })
    }

    /// The time the next frame will be shown at, in seconds from the file's start.
    pub fn next_timestamp(&self) -> f64 {
        self.frames as f64 / f64::from(self.fps)
    }

    /// Encodes one frame (interleaved RGB, `width × height × 3` bytes); `episode_start`
    /// makes it a key frame.
    pub fn push(&mut self, rgb: &[u8], episode_start: bool) -> Result<(), VideoError> {
        let (w, h) = (self.width as usize, self.height as usize);
        if rgb.len() != w * h * 3 {
            return Err(VideoError::FrameSize {
                frame: self.frames,
                bytes: rgb.len(),
                width: w,
                height: h,
            });
        }
        let yuv = YUVBuffer::from_vec(rgb_to_i420(rgb, w, h), w, h);
        if episode_start && self.frames > 0 {
            self.encoder.force_intra_frame();
        }
        let stream = self
            .encoder
            .encode(&yuv)
            .map_err(|source| VideoError::Encoder {
                frame: Some(self.frames),
                source,
            })?;
        let is_sync = stream.frame_type() == FrameType::IDR;
        let (mut sps, mut pps, mut sample) = (None, None, Vec::new());
        for l in 0..stream.num_layers() {
            let Some(layer) = stream.layer(l) else {
                continue;
            };
            for k in 0..layer.nal_count() {
                let Some(nal) = layer.nal_unit(k).map(strip_start_code) else {
                    continue;
                };
                match nal.first().map(|b| b & 0x1f) {
                    Some(7) => sps = Some(nal.to_vec()),
                    Some(8) => pps = Some(nal.to_vec()),
                    Some(_) => {
                        sample.extend_from_slice(&(nal.len() as u32).to_be_bytes());
                        sample.extend_from_slice(nal);
                    }
                    None => {}
                }
            }
        }
        if sample.is_empty() {
            return Err(VideoError::NoPicture(self.frames));
        }
        if self.writer.is_none() {
            let (Some(sps), Some(pps)) = (sps, pps) else {
                return Err(VideoError::NoParameterSets);
            };
            let Some(out) = self.pending.take() else {
                return Err(VideoError::Closed);
            };
            let mut writer = Mp4Writer::write_start(
                out,
                &Mp4Config {
                    major_brand: mp4::FourCC { value: *b"isom" },
                    minor_version: 512,
                    compatible_brands: [b"isom", b"iso2", b"avc1", b"mp41"]
                        .into_iter()
                        .map(|b| mp4::FourCC { value: *b })
                        .collect(),
                    timescale: 1000,
                },
            )
            .map_err(|source| VideoError::Container {
                frame: None,
                source,
            })?;
            writer
                .add_track(&TrackConfig {
                    track_type: TrackType::Video,
                    timescale: TICKS_PER_FRAME * self.fps,
                    language: "und".into(),
                    media_conf: MediaConfig::AvcConfig(AvcConfig {
                        width: self.width as u16,
                        height: self.height as u16,
                        seq_param_set: sps,
                        pic_param_set: pps,
                    }),
                })
                .map_err(|source| VideoError::Container {
                    frame: None,
                    source,
                })?;
            self.writer = Some(writer);
        }
        let Some(writer) = self.writer.as_mut() else {
            return Err(VideoError::Closed);
        };
        self.bytes += sample.len() as u64;
        writer
            .write_sample(
                1,
                &Mp4Sample {
                    start_time: self.frames * u64::from(TICKS_PER_FRAME),
                    duration: TICKS_PER_FRAME,
                    rendering_offset: 0,
                    is_sync,
                    bytes: sample.into(),
                },
            )
            .map_err(|source| VideoError::Container {
                frame: Some(self.frames),
                source,
            })?;
        self.frames += 1;
        Ok(())
    }

    /// Writes the index (`moov`) and closes the file.
    pub fn close(mut self) -> Result<(), VideoError> {
        use std::io::Write;
        match self.writer.take() {
            Some(mut w) => {
                w.write_end().map_err(|source| VideoError::Container {
                    frame: None,
                    source,
                })?;
                Ok(w.into_writer().flush()?)
            }
            None => Err(VideoError::NoFrames),
        }
    }
}

/// The path of a camera's video file under the dataset root.
pub fn video_file_path(root: &Path, key: &str, index: FileIndex) -> PathBuf {
    root.join(index.video(key))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grey_levels_map_to_studio_range_luma_and_neutral_chroma() {
        // Black, white and mid grey: Y 16, 235, 126; U = V = 128 (BT.601 limited range).
        for (v, y) in [(0u8, 16u8), (255, 235), (128, 126)] {
            let rgb = vec![v; 4 * 4 * 3];
            let yuv = rgb_to_i420(&rgb, 4, 4);
            assert!(yuv[..16].iter().all(|p| *p == y), "{v}: {:?}", &yuv[..16]);
            assert!(yuv[16..].iter().all(|p| *p == 128), "{v}: {:?}", &yuv[16..]);
        }
        // Pure red: Y 82, U 90, V 240 (the textbook BT.601 values).
        let red: Vec<u8> = [255u8, 0, 0].repeat(4);
        let yuv = rgb_to_i420(&red, 2, 2);
        assert_eq!(yuv, vec![82, 82, 82, 82, 90, 240]);
    }

    /// A moving gradient with a square: frames that differ, as a camera's do.
    fn frame(k: usize, w: usize, h: usize) -> Vec<u8> {
        let mut f = Vec::with_capacity(w * h * 3);
        for y in 0..h {
            for x in 0..w {
                let inside = (x + 2 * k) % w < 12 && y > 8 && y < 24;
                f.extend_from_slice(&[
                    ((x * 255) / w) as u8,
                    ((y * 255) / h) as u8,
                    if inside { 230 } else { 40 },
                ]);
            }
        }
        f
    }

    fn write(path: &Path, frames: &[Vec<u8>], episode_starts: &[usize]) {
        write_with(path, frames, episode_starts, VideoSettings::default());
    }

    fn write_with(
        path: &Path,
        frames: &[Vec<u8>],
        episode_starts: &[usize],
        settings: VideoSettings,
    ) {
        let mut v = VideoFile::create(
            path.to_path_buf(),
            FileIndex::default(),
            48,
            32,
            10,
            settings,
        )
        .expect("create");
        for (k, f) in frames.iter().enumerate() {
            v.push(f, episode_starts.contains(&k)).expect("push");
        }
        v.close().expect("close");
    }

    #[test]
    fn the_same_frames_give_the_same_bytes_and_decode_back_close() {
        let dir = tempfile::tempdir().expect("tempdir");
        let frames: Vec<Vec<u8>> = (0..12).map(|k| frame(k, 48, 32)).collect();
        let (a, b) = (dir.path().join("a.mp4"), dir.path().join("b.mp4"));
        write(&a, &frames, &[0, 5]);
        write(&b, &frames, &[0, 5]);
        let bytes = std::fs::read(&a).expect("read");
        assert_eq!(bytes, std::fs::read(&b).expect("read"));
        let v = super::super::video_read::read_video(&a, true).expect("decodes");
        assert_eq!((v.codec.as_str(), v.width, v.height), ("avc1", 48, 32));
        assert_eq!(v.timescale, 10 * TICKS_PER_FRAME);
        let times: Vec<u64> = v.samples.iter().map(|s| s.0).collect();
        assert_eq!(times, (0..12).map(|k| k * 1000).collect::<Vec<u64>>());
        // Key frames where episodes start (and nowhere else within 30 frames).
        let keys: Vec<usize> = (0..12).filter(|k| v.samples[*k].1).collect();
        assert_eq!(keys, vec![0, 5]);
        assert_eq!(v.frames.len(), 12);
        for (k, (raw, dec)) in frames.iter().zip(&v.frames).enumerate() {
            let db = psnr(raw, dec);
            // Hard-edged saturated shapes are the worst case for 4:2:0 chroma (≈ 30 dB
            // here); rendered rooms decode at 38–42 dB (tests/lerobot_video.rs).
            assert!(db > 28.0, "frame {k}: {db:.1} dB");
        }
        // Damaged index or data: a one-line error, never a panic.
        let cut = dir.path().join("cut.mp4");
        std::fs::write(&cut, &bytes[..bytes.len() / 2]).expect("write");
        let e = super::super::video_read::read_video(&cut, true).expect_err("cut");
        assert!(!e.to_string().contains('\n'), "{e}");
        // The MP4 reader's own error is kept as the cause.
        assert!(
            matches!(e, super::super::video_read::VideoReadError::Mp4(_)),
            "{e:?}"
        );
        assert!(std::error::Error::source(&e).is_some_and(|c| c.is::<mp4::Error>()));
    }

    /// PSNR of a decoded frame against the raw one, dB.
    fn psnr(raw: &[u8], decoded: &[u8]) -> f64 {
        let mse = raw
            .iter()
            .zip(decoded)
            .map(|(x, y)| (f64::from(*x) - f64::from(*y)).powi(2))
            .sum::<f64>()
            / raw.len() as f64;
        10.0 * (255.0f64 * 255.0 / mse.max(1e-9)).log10()
    }

    /// Mean PSNR of decoded frames against the raw ones, dB.
    fn mean_psnr(raw: &[Vec<u8>], decoded: &[Vec<u8>]) -> f64 {
        raw.iter()
            .zip(decoded)
            .map(|(a, b)| psnr(a, b))
            .sum::<f64>()
            / raw.len() as f64
    }

    #[test]
    fn the_quantiser_trades_bytes_for_quality_in_a_high_profile_cabac_stream() {
        let dir = tempfile::tempdir().expect("tempdir");
        let frames: Vec<Vec<u8>> = (0..20).map(|k| frame(k, 48, 32)).collect();
        let mut last: Option<(u64, f64)> = None;
        for qp in [16u8, 26, 38] {
            let path = dir.path().join(format!("q{qp}.mp4"));
            let settings = VideoSettings::with_qp(qp).expect("a quantiser");
            write_with(&path, &frames, &[0], settings);
            let bytes = std::fs::read(&path).expect("read");
            // The stream says what it is: High profile (profile_idc 100) in the SPS, CABAC
            // (entropy_coding_mode_flag, the bit after the PPS's two ids) in the PPS.
            let mp4 = mp4::Mp4Reader::read_header(std::io::Cursor::new(&bytes), bytes.len() as u64)
                .expect("an MP4");
            let track = mp4.tracks().values().next().expect("a track");
            let sps = track.sequence_parameter_set().expect("SPS");
            let pps = track.picture_parameter_set().expect("PPS");
            assert_eq!(sps[1], 100, "qp {qp}: profile_idc");
            let mut bits = BitReader::new(&pps[1..]);
            let (_pps_id, _sps_id) = (bits.ue(), bits.ue());
            assert_eq!(bits.bit(), 1, "qp {qp}: entropy_coding_mode_flag");
            let v = super::super::video_read::read_video(&path, true).expect("decodes");
            assert_eq!(v.frames.len(), frames.len());
            let psnr = mean_psnr(&frames, &v.frames);
            // A coarser quantiser: fewer bytes, a lower PSNR, still the same pictures.
            if let Some((size, quality)) = last {
                assert!(
                    (bytes.len() as u64) < size,
                    "qp {qp}: {} bytes",
                    bytes.len()
                );
                assert!(psnr < quality, "qp {qp}: {psnr:.2} dB");
            }
            assert!(psnr > 24.0, "qp {qp}: {psnr:.2} dB");
            last = Some((bytes.len() as u64, psnr));
        }
        assert!(VideoSettings::with_qp(MAX_QP).is_some());
        assert!(VideoSettings::with_qp(MAX_QP + 1).is_none());
        assert!(VideoSettings::default()
            .storage()
            .contains("constant QP 26"));
    }

    /// Reads an H.264 RBSP's bits (enough for the PPS's first fields).
    struct BitReader<'a> {
        bytes: &'a [u8],
        at: usize,
    }

    impl<'a> BitReader<'a> {
        fn new(bytes: &'a [u8]) -> Self {
            BitReader { bytes, at: 0 }
        }

        fn bit(&mut self) -> u32 {
            let b = self.bytes[self.at / 8] >> (7 - self.at % 8) & 1;
            self.at += 1;
            u32::from(b)
        }

        /// An unsigned Exp-Golomb number.
        fn ue(&mut self) -> u32 {
            let mut zeros = 0;
            while self.bit() == 0 {
                zeros += 1;
            }
            (0..zeros).fold(0, |v, _| (v << 1) | self.bit()) + (1 << zeros) - 1
        }
    }

    #[test]
    fn shapes_h264_cannot_take_are_refused() {
        assert!(video_shape_ok(84, 84) && video_shape_ok(256, 256) && video_shape_ok(640, 480));
        assert!(!video_shape_ok(85, 84) && !video_shape_ok(84, 9) && !video_shape_ok(4096, 16));
    }
}
