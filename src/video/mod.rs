//! Video in (the base layer, beside the photo): the frames of an H.264 video in an MP4 or MOV
//! file, or of a folder of images, one after another with their times. `guava track`, `guava eval
//! --video` and the viewer's live driving read every video through [`FrameSource`]; a webcam is
//! one more source behind the `webcam` cargo feature.

/// The clip shipped for trying live driving and self-reenactment (a Pexels video; credits in
/// assets/CREDITS.md).
pub const DEMO_VIDEO: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/assets/videos/pexels_3063838_woman_emotions.mp4"
);

mod folder;

mod mp4_file;
#[cfg(feature = "webcam")]
pub mod webcam;

pub use folder::{FrameFolder, images_in};
pub use mp4_file::Mp4Video;

use std::path::Path;

use image::RgbaImage;

/// A video that cannot be read, naming the file (and the frame, where one is at fault).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{file}: {problem}")]
pub struct VideoError {
    pub file: String,
    pub problem: String,
}

impl VideoError {
    pub fn new(file: &str, problem: impl Into<String>) -> Self {
        Self {
            file: file.into(),
            problem: problem.into(),
        }
    }
}

/// One picture of a video: its place, when it is shown, and its pixels (opaque RGBA, upright).
#[derive(Clone, Debug)]
pub struct VideoFrame {
    /// 0, 1, … in the order shown.
    pub index: usize,
    /// Seconds from the first frame.
    pub time_s: f64,
    pub pixels: RgbaImage,
}

/// What a source says of itself before its first frame.
#[derive(Clone, Debug, PartialEq)]
pub struct VideoInfo {
    /// The file, folder or device, for messages and tracking files.
    pub name: String,
    pub width: u32,
    pub height: u32,
    /// Frames per second (the mean over the file for a file; what the device delivers for a
    /// camera).
    pub fps: f32,
    /// How many frames there are, when known ahead (files and folders; not a camera).
    pub frames: Option<usize>,
}

/// Frames one after another: a file, a folder or a camera. (Not `Send` by itself: a camera is
/// opened and read on one thread.)
pub trait FrameSource {
    fn info(&self) -> &VideoInfo;
    /// The next frame, `None` after the last one. An error names the file and the frame; the
    /// frames before it stay good.
    fn next_frame(&mut self) -> Option<Result<VideoFrame, VideoError>>;
}

/// Frames already in memory (a test's, a clip made by the program), as a source.
pub struct FrameList {
    info: VideoInfo,
    frames: std::vec::IntoIter<VideoFrame>,
}

impl FrameList {
    /// `frames` (all of one size, in order) of a video `name` at `fps`.
    pub fn new(name: &str, fps: f32, frames: Vec<VideoFrame>) -> Self {
        let (width, height) = frames.first().map_or((0, 0), |f| f.pixels.dimensions());
        Self {
            info: VideoInfo {
                name: name.into(),
                width,
                height,
                fps,
                frames: Some(frames.len()),
            },
            frames: frames.into_iter(),
        }
    }
}

impl FrameSource for FrameList {
    fn info(&self) -> &VideoInfo {
        &self.info
    }

    fn next_frame(&mut self) -> Option<Result<VideoFrame, VideoError>> {
        self.frames.next().map(Ok)
    }
}

/// Opens `path`: a folder of images (`fps` says their rate; their names give their order) or an
/// MP4/MOV file with an H.264 video track.
pub fn open(path: &Path, fps: f32) -> Result<Box<dyn FrameSource + Send>, VideoError> {
    Ok(if path.is_dir() {
        Box::new(FrameFolder::open(path, fps)?)
    } else {
        Box::new(Mp4Video::open(path)?)
    })
}

/// Every frame of `source` (for short clips and tests; trackers take them one at a time).
pub fn read_all(source: &mut dyn FrameSource) -> Result<Vec<VideoFrame>, VideoError> {
    std::iter::from_fn(|| source.next_frame()).collect()
}
