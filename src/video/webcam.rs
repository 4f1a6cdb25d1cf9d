//! A camera as a frame source (the `webcam` cargo feature, off by default): nokhwa's native
//! backends (V4L2 on Linux, AVFoundation on macOS, Media Foundation on Windows), frames decoded
//! to RGB at the camera's highest frame rate. The default build needs no system library for it;
//! this one needs libclang to build the V4L2 bindings on Linux.

use std::time::Instant;

use nokhwa::Camera;
use nokhwa::pixel_format::RgbFormat;
use nokhwa::utils::{CameraIndex, RequestedFormat, RequestedFormatType};

use super::{FrameSource, VideoError, VideoFrame, VideoInfo};

pub struct Webcam {
    info: VideoInfo,
    camera: Camera,
    started: Option<Instant>,
    shown: usize,
}

impl Webcam {
    /// Opens camera `index` (0: the first) and starts its stream.
    pub fn open(index: u32) -> Result<Self, VideoError> {
        let name = format!("webcam {index}");
        let fail = |e: nokhwa::NokhwaError| VideoError::new(&name, e.to_string());
        let format =
            RequestedFormat::new::<RgbFormat>(RequestedFormatType::AbsoluteHighestFrameRate);
        let mut camera = Camera::new(CameraIndex::Index(index), format).map_err(fail)?;
        camera.open_stream().map_err(fail)?;
        let resolution = camera.resolution();
        let info = VideoInfo {
            name: format!("{name} ({})", camera.info().human_name()),
            width: resolution.width(),
            height: resolution.height(),
            fps: camera.frame_rate() as f32,
            frames: None,
        };
        Ok(Self {
            info,
            camera,
            started: None,
            shown: 0,
        })
    }
}

impl FrameSource for Webcam {
    fn info(&self) -> &VideoInfo {
        &self.info
    }

    /// The camera's next frame, timed by when it arrived; a camera never ends on its own.
    fn next_frame(&mut self) -> Option<Result<VideoFrame, VideoError>> {
        let fail = |e: nokhwa::NokhwaError| VideoError::new(&self.info.name, e.to_string());
        let frame = self
            .camera
            .frame()
            .and_then(|buffer| buffer.decode_image::<RgbFormat>())
            .map_err(fail);
        let started = *self.started.get_or_insert_with(Instant::now);
        let index = self.shown;
        self.shown += 1;
        Some(frame.map(|rgb| VideoFrame {
            index,
            time_s: started.elapsed().as_secs_f64(),
            pixels: image::DynamicImage::ImageRgb8(rgb).to_rgba8(),
        }))
    }
}
