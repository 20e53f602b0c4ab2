//! Reading back a video file of [`super::video`]: the MP4 index (the `mp4` crate) and every
//! frame decoded with OpenH264's decoder (the crate family that encoded it), for
//! `minos verify` and the tests.

use std::fs::File;
use std::io::BufReader;
use std::path::Path;

use openh264::decoder::{Decoder, DecoderConfig};
use openh264::formats::YUVSource;
use openh264::OpenH264API;

use crate::escape::{catch_quietly, Panicked};
use crate::invalid::Invalid;

/// Why a video file cannot be read back: one line, what is wrong without the path (the
/// caller names the file).
#[derive(Debug, thiserror::Error)]
pub enum VideoReadError {
    /// The file could not be opened or measured.
    #[error("{0}")]
    Io(#[source] std::io::Error),
    /// The MP4 reader panicked on it.
    #[error("unreadable MP4")]
    Unreadable(#[source] Panicked),
    /// The MP4 reader refused it.
    #[error("MP4")]
    Mp4(#[source] mp4::Error),
    /// Its tracks are not one H.264 video track with its parameter sets, or a sample's
    /// NAL units are cut short.
    #[error("{0}")]
    Layout(#[source] Invalid),
    /// The H.264 decoder failed.
    #[error("H.264 decoder")]
    Decoder(#[source] openh264::Error),
    /// One frame (0-based) could not be read or decoded.
    #[error("frame {frame}")]
    Frame {
        /// The frame.
        frame: u32,
        /// Why.
        #[source]
        source: Box<VideoReadError>,
    },
}

impl VideoReadError {
    fn frame(frame: u32) -> impl Fn(VideoReadError) -> VideoReadError {
        move |e| VideoReadError::Frame {
            frame,
            source: Box::new(e),
        }
    }
}

fn layout(problem: impl Into<Invalid>) -> VideoReadError {
    VideoReadError::Layout(problem.into())
}

/// A video file's index and, when asked for, its frames.
#[derive(Debug, Clone, PartialEq)]
pub struct VideoContents {
    /// The codec's four-character code (`avc1`).
    pub codec: String,
    /// Frame width declared by the track.
    pub width: u32,
    /// Frame height declared by the track.
    pub height: u32,
    /// Ticks per second of the track's clock.
    pub timescale: u32,
    /// Each frame's presentation time in ticks and whether it is a key frame.
    pub samples: Vec<(u64, bool)>,
    /// The decoded frames, RGB interleaved (empty unless decoding was asked for).
    pub frames: Vec<Vec<u8>>,
    /// Each decoded frame's size (width, height).
    pub decoded_sizes: Vec<(u32, u32)>,
}

/// Annex B byte stream of an MP4 sample (4-byte lengths → start codes).
fn annex_b(sample: &[u8], out: &mut Vec<u8>) -> Result<(), Invalid> {
    let mut rest = sample;
    while !rest.is_empty() {
        if rest.len() < 4 {
            return Err("a NAL unit length is cut short".into());
        }
        let n = u32::from_be_bytes([rest[0], rest[1], rest[2], rest[3]]) as usize;
        if n == 0 || rest.len() - 4 < n {
            return Err(format!("a NAL unit of {n} bytes where {} remain", rest.len() - 4).into());
        }
        out.extend_from_slice(&[0, 0, 0, 1]);
        out.extend_from_slice(&rest[4..4 + n]);
        rest = &rest[4 + n..];
    }
    Ok(())
}

/// Reads the video file `path`: its one video track's index, and every frame decoded when
/// `decode` is set. The error is one line (what is wrong, without the path).
pub fn read_video(path: &Path, decode: bool) -> Result<VideoContents, VideoReadError> {
    let file = File::open(path).map_err(VideoReadError::Io)?;
    let size = file.metadata().map_err(VideoReadError::Io)?.len();
    catch_quietly(|| read_from(BufReader::new(file), size, decode))
        .map_err(VideoReadError::Unreadable)?
}

fn read_from(
    reader: BufReader<File>,
    size: u64,
    decode: bool,
) -> Result<VideoContents, VideoReadError> {
    let mut mp4 = mp4::Mp4Reader::read_header(reader, size).map_err(VideoReadError::Mp4)?;
    let videos: Vec<&mp4::Mp4Track> = mp4
        .tracks()
        .values()
        .filter(|t| matches!(t.track_type(), Ok(mp4::TrackType::Video)))
        .collect();
    let [t] = videos[..] else {
        return Err(layout(format!(
            "{} video tracks where one is expected",
            videos.len()
        )));
    };
    let track = t.track_id();
    let (width, height) = (u32::from(t.width()), u32::from(t.height()));
    let timescale = t.timescale();
    let codec = t.box_type().map(|b| b.to_string()).unwrap_or_default();
    let sps = t
        .sequence_parameter_set()
        .map(<[u8]>::to_vec)
        .unwrap_or_default();
    let pps = t
        .picture_parameter_set()
        .map(<[u8]>::to_vec)
        .unwrap_or_default();
    if codec != "avc1" {
        return Err(layout(format!(
            "codec `{codec}` where `avc1` (H.264) is expected"
        )));
    }
    if sps.is_empty() || pps.is_empty() {
        return Err(layout("the H.264 track has no parameter sets"));
    }
    let count = mp4.sample_count(track).map_err(VideoReadError::Mp4)?;
    let mut decoder = if decode {
        Some(
            Decoder::with_api_config(OpenH264API::from_source(), DecoderConfig::new())
                .map_err(VideoReadError::Decoder)?,
        )
    } else {
        None
    };
    let mut out = VideoContents {
        codec,
        width,
        height,
        timescale,
        samples: Vec::with_capacity(count as usize),
        frames: Vec::new(),
        decoded_sizes: Vec::new(),
    };
    let mut packet = Vec::new();
    for id in 1..=count {
        let in_frame = VideoReadError::frame(id - 1);
        let sample = mp4
            .read_sample(track, id)
            .map_err(|e| in_frame(VideoReadError::Mp4(e)))?
            .ok_or_else(|| in_frame(layout("missing")))?;
        out.samples.push((sample.start_time, sample.is_sync));
        let Some(decoder) = decoder.as_mut() else {
            continue;
        };
        packet.clear();
        if id == 1 {
            for ps in [&sps, &pps] {
                packet.extend_from_slice(&[0, 0, 0, 1]);
                packet.extend_from_slice(ps);
            }
        }
        annex_b(&sample.bytes, &mut packet).map_err(|e| in_frame(VideoReadError::Layout(e)))?;
        let picture = decoder
            .decode(&packet)
            .map_err(|e| in_frame(VideoReadError::Decoder(e)))?;
        if let Some(p) = picture {
            let (w, h) = p.dimensions();
            let mut rgb = vec![0u8; w * h * 3];
            p.write_rgb8(&mut rgb);
            out.decoded_sizes.push((w as u32, h as u32));
            out.frames.push(rgb);
        }
    }
    if let Some(decoder) = decoder.as_mut() {
        for p in decoder.flush_remaining().map_err(VideoReadError::Decoder)? {
            let (w, h) = p.dimensions();
            let mut rgb = vec![0u8; w * h * 3];
            p.write_rgb8(&mut rgb);
            out.decoded_sizes.push((w as u32, h as u32));
            out.frames.push(rgb);
        }
    }
    Ok(out)
}
