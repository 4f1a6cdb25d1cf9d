//! A folder of images (PNG or JPEG) as a video: frames in name order (`frame_00000.png`, … as
//! `guava render --sequence` writes them), at a rate the caller gives, all of one size.

use std::path::{Path, PathBuf};

use super::{FrameSource, VideoError, VideoFrame, VideoInfo};
use crate::photo::SourceImage;

pub struct FrameFolder {
    info: VideoInfo,
    files: Vec<PathBuf>,
    next: usize,
}

/// The images of `dir` in name order.
pub fn images_in(dir: &Path) -> Result<Vec<PathBuf>, VideoError> {
    let name = dir.display().to_string();
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| VideoError::new(&name, e.to_string()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| ["png", "jpg", "jpeg"].contains(&e.to_ascii_lowercase().as_str()))
        })
        .collect();
    files.sort();
    Ok(files)
}

impl FrameFolder {
    /// The images of `dir` at `fps`; the first one gives the size.
    pub fn open(dir: &Path, fps: f32) -> Result<Self, VideoError> {
        let name = dir.display().to_string();
        if !(fps.is_finite() && fps > 0.0) {
            return Err(VideoError::new(&name, format!("a frame rate of {fps}")));
        }
        let files = images_in(dir)?;
        let first = files
            .first()
            .ok_or_else(|| VideoError::new(&name, "holds no PNG or JPEG images"))?;
        let (pixels, _) =
            SourceImage::decode(first).map_err(|e| VideoError::new(&e.file, e.problem))?;
        Ok(Self {
            info: VideoInfo {
                name,
                width: pixels.width(),
                height: pixels.height(),
                fps,
                frames: Some(files.len()),
            },
            files,
            next: 0,
        })
    }
}

impl FrameSource for FrameFolder {
    fn info(&self) -> &VideoInfo {
        &self.info
    }

    fn next_frame(&mut self) -> Option<Result<VideoFrame, VideoError>> {
        let path = self.files.get(self.next)?;
        let index = self.next;
        self.next += 1;
        let frame = SourceImage::decode(path)
            .map_err(|e| VideoError::new(&e.file, e.problem))
            .and_then(|(pixels, _)| {
                let size = (self.info.width, self.info.height);
                if pixels.dimensions() != size {
                    return Err(VideoError::new(
                        &path.display().to_string(),
                        format!(
                            "{}×{}, but the first frame is {}×{} (a video's frames share one size)",
                            pixels.width(),
                            pixels.height(),
                            size.0,
                            size.1
                        ),
                    ));
                }
                Ok(VideoFrame {
                    index,
                    time_s: index as f64 / f64::from(self.info.fps),
                    pixels,
                })
            });
        Some(frame)
    }
}
