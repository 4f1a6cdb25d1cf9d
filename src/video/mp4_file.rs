//! An MP4 or MOV file's H.264 video track, decoded by OpenH264 (built from the `openh264`
//! crate's bundled source, as the MP4 export is). MP4 stores each picture's NAL units prefixed by
//! their length and the parameter sets once in the track header (`avcC`); the decoder wants
//! Annex B (start codes), the parameter sets in the stream: each key frame gets them in front.
//! Pictures come out of the decoder in the order shown (it reorders B-frames), so each takes the
//! earliest presentation time among the samples fed and not yet shown.

use std::cmp::Reverse;
use std::collections::{BinaryHeap, VecDeque};
use std::fs::File;
use std::io::BufReader;
use std::path::Path;

use image::RgbaImage;
use openh264::decoder::{Decoder, DecoderConfig, Flush};
use openh264::formats::YUVSource;

use super::{FrameSource, VideoError, VideoFrame, VideoInfo};

/// What to tell someone whose video is in another codec.
const CONVERT: &str = "guava reads H.264 video in MP4 or MOV files: convert it, for example \
                       `ffmpeg -i IN -c:v libx264 -pix_fmt yuv420p OUT.mp4`, or give a folder \
                       of its frames as images";

pub struct Mp4Video {
    info: VideoInfo,
    reader: mp4::Mp4Reader<BufReader<File>>,
    track: u32,
    timescale: f64,
    /// The next sample to read (1-based, as MP4 counts), and how many there are.
    next_sample: u32,
    samples: u32,
    /// Bytes of each NAL unit's length prefix (`avcC`).
    length_size: usize,
    /// SPS and PPS as Annex B, put before every key frame.
    parameter_sets: Vec<u8>,
    decoder: Decoder,
    /// Presentation times of the samples fed whose picture has not come out yet.
    pending: BinaryHeap<Reverse<i64>>,
    /// Pictures decoded and not yet handed out, with their presentation times.
    ready: VecDeque<(i64, RgbaImage)>,
    first_time: Option<i64>,
    shown: usize,
    flushed: bool,
    /// Scratch: the sample as Annex B.
    stream: Vec<u8>,
}

impl Mp4Video {
    pub fn open(path: &Path) -> Result<Self, VideoError> {
        let file = path.display().to_string();
        let fail = |problem: String| VideoError::new(&file, problem);
        let handle = File::open(path).map_err(|e| fail(e.to_string()))?;
        let size = handle.metadata().map_err(|e| fail(e.to_string()))?.len();
        let reader = mp4::Mp4Reader::read_header(BufReader::new(handle), size).map_err(|e| {
            fail(match sniff_video_codec(path) {
                Some(codec) if codec != "avc1" => {
                    format!("its video is {} ({codec}); {CONVERT}", codec_name(codec))
                }
                Some(_) => format!(
                    "an H.264 video whose header this reader cannot parse ({e}); \
                         rewrite the container without re-encoding: \
                         `ffmpeg -i IN -c copy OUT.mp4`"
                ),
                None => format!("not an MP4 or MOV file this reader understands ({e})"),
            })
        })?;
        let video = reader
            .tracks()
            .values()
            .filter(|t| matches!(t.track_type(), Ok(mp4::TrackType::Video)))
            .min_by_key(|t| t.track_id())
            .ok_or_else(|| fail("has no video track".into()))?;
        let stsd = &video.trak.mdia.minf.stbl.stsd;
        let Some(avc1) = &stsd.avc1 else {
            let codec = match sniff_video_codec(path) {
                Some(codec) => format!("{} ({codec})", codec_name(codec)),
                None => "in a codec other than H.264".into(),
            };
            return Err(fail(format!("its video is {codec}; {CONVERT}")));
        };
        let avcc = &avc1.avcc;
        if avcc.sequence_parameter_sets.is_empty() || avcc.picture_parameter_sets.is_empty() {
            return Err(fail("its H.264 track has no parameter sets (avcC)".into()));
        }
        let mut parameter_sets = Vec::new();
        for unit in avcc
            .sequence_parameter_sets
            .iter()
            .chain(&avcc.picture_parameter_sets)
        {
            parameter_sets.extend_from_slice(&[0, 0, 0, 1]);
            parameter_sets.extend_from_slice(&unit.bytes);
        }
        let samples = video.sample_count();
        if samples == 0 {
            return Err(fail(
                "its video track has no samples (a fragmented MP4, as streams write, is not read)"
                    .into(),
            ));
        }
        let seconds = video.duration().as_secs_f64();
        let info = VideoInfo {
            name: file.clone(),
            width: u32::from(video.width()),
            height: u32::from(video.height()),
            fps: if seconds > 0.0 {
                (samples as f64 / seconds) as f32
            } else {
                30.0
            },
            frames: Some(samples as usize),
        };
        let (track, timescale) = (video.track_id(), f64::from(video.timescale().max(1)));
        let length_size = usize::from(avcc.length_size_minus_one & 3) + 1;
        // The decoder reorders B-frames only when not flushed after every sample.
        let config = DecoderConfig::new().flush_after_decode(Flush::NoFlush);
        let decoder = Decoder::with_api_config(openh264::OpenH264API::from_source(), config)
            .map_err(|e| fail(format!("the H.264 decoder did not start: {e}")))?;
        Ok(Self {
            info,
            reader,
            track,
            timescale,
            next_sample: 1,
            samples,
            length_size,
            parameter_sets,
            decoder,
            pending: BinaryHeap::new(),
            ready: VecDeque::new(),
            first_time: None,
            shown: 0,
            flushed: false,
            stream: Vec::new(),
        })
    }

    fn fail(&self, problem: String) -> VideoError {
        VideoError::new(&self.info.name, problem)
    }

    /// Feeds the next sample to the decoder; keeps the picture it gives back, if any.
    fn feed(&mut self) -> Result<(), VideoError> {
        let n = self.next_sample;
        self.next_sample += 1;
        let sample = self
            .reader
            .read_sample(self.track, n)
            .map_err(|e| self.fail(format!("sample {n}: {e}")))?;
        let Some(sample) = sample else {
            return Ok(());
        };
        self.stream.clear();
        if sample.is_sync {
            self.stream.extend_from_slice(&self.parameter_sets);
        }
        let mut rest = &sample.bytes[..];
        while rest.len() > self.length_size {
            let (prefix, tail) = rest.split_at(self.length_size);
            let len = prefix
                .iter()
                .fold(0usize, |a, &b| (a << 8) | usize::from(b));
            if len > tail.len() {
                return Err(self.fail(format!(
                    "sample {n}: a NAL unit of {len} bytes in {} left (a damaged file?)",
                    tail.len()
                )));
            }
            self.stream.extend_from_slice(&[0, 0, 0, 1]);
            self.stream.extend_from_slice(&tail[..len]);
            rest = &tail[len..];
        }
        self.pending.push(Reverse(
            sample.start_time as i64 + i64::from(sample.rendering_offset),
        ));
        let decoded = self
            .decoder
            .decode(&self.stream)
            .map_err(|e| VideoError::new(&self.info.name, format!("sample {n}: {e}")))?;
        if let Some(yuv) = decoded {
            let picture = to_rgba(&yuv);
            self.keep(picture);
        }
        Ok(())
    }

    fn keep(&mut self, picture: RgbaImage) {
        // A picture with no sample left to time it (a decoder that doubled one) is dropped.
        if let Some(Reverse(time)) = self.pending.pop() {
            self.ready.push_back((time, picture));
        }
    }

    fn flush(&mut self) -> Result<(), VideoError> {
        self.flushed = true;
        let pictures: Vec<RgbaImage> = self
            .decoder
            .flush_remaining()
            .map_err(|e| VideoError::new(&self.info.name, format!("at its end: {e}")))?
            .iter()
            .map(to_rgba)
            .collect();
        for picture in pictures {
            self.keep(picture);
        }
        Ok(())
    }
}

/// Video sample entries a file may declare, with their codecs' names.
const VIDEO_CODECS: [(&str, &str); 10] = [
    ("avc1", "H.264"),
    ("avc3", "H.264 with in-band parameter sets"),
    ("hvc1", "HEVC (H.265), as phones record"),
    ("hev1", "HEVC (H.265)"),
    ("av01", "AV1"),
    ("vp09", "VP9"),
    ("vp08", "VP8"),
    ("apcn", "Apple ProRes"),
    ("apch", "Apple ProRes"),
    ("mp4v", "MPEG-4 Part 2"),
];

fn codec_name(fourcc: &str) -> &'static str {
    VIDEO_CODECS
        .iter()
        .find(|(c, _)| *c == fourcc)
        .map_or("an unknown codec", |(_, name)| name)
}

/// The first video sample entry named in a file's sample descriptions (`stsd`), read from its
/// first and last 16 MiB (where the header sits), for a message that names the codec when the
/// header cannot be read or holds no H.264.
fn sniff_video_codec(path: &Path) -> Option<&'static str> {
    use std::io::{Read, Seek, SeekFrom};
    const SPAN: u64 = 16 << 20;
    let mut file = File::open(path).ok()?;
    let size = file.metadata().ok()?.len();
    let mut bytes = Vec::new();
    file.by_ref().take(SPAN).read_to_end(&mut bytes).ok()?;
    if size > SPAN {
        file.seek(SeekFrom::Start(size.saturating_sub(SPAN).max(SPAN)))
            .ok()?;
        file.read_to_end(&mut bytes).ok()?;
    }
    // After `stsd`: version and flags, the entry count, the first entry's size, then its type.
    bytes
        .windows(4)
        .enumerate()
        .filter(|(_, w)| w == b"stsd")
        .filter_map(|(at, _)| bytes.get(at + 16..at + 20))
        .find_map(|fourcc| VIDEO_CODECS.iter().find(|(c, _)| c.as_bytes() == fourcc))
        .map(|(c, _)| *c)
}

fn to_rgba(yuv: &openh264::decoder::DecodedYUV) -> RgbaImage {
    let (w, h) = yuv.dimensions();
    let mut rgba = vec![0; w * h * 4];
    yuv.write_rgba8(&mut rgba);
    RgbaImage::from_raw(w as u32, h as u32, rgba).expect("w × h × 4 bytes")
}

impl FrameSource for Mp4Video {
    fn info(&self) -> &VideoInfo {
        &self.info
    }

    fn next_frame(&mut self) -> Option<Result<VideoFrame, VideoError>> {
        while self.ready.is_empty() {
            let step = if self.next_sample <= self.samples {
                self.feed()
            } else if !self.flushed {
                self.flush()
            } else {
                return None;
            };
            if let Err(e) = step {
                // Nothing more comes after a broken sample.
                (self.next_sample, self.flushed) = (self.samples + 1, true);
                return Some(Err(e));
            }
        }
        let (time, pixels) = self.ready.pop_front()?;
        let first = *self.first_time.get_or_insert(time);
        let frame = VideoFrame {
            index: self.shown,
            time_s: (time - first) as f64 / self.timescale,
            pixels,
        };
        self.shown += 1;
        Some(Ok(frame))
    }
}
