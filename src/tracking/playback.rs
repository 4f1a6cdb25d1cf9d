//! The playback clock (play, pause, loop, speed, scrub, step) and the tracked camera at a time.

use glam::{Mat3, Mat4, Quat, Vec3};

use super::format::Tracking;
use super::retarget::bracket;

/// Where playback is and how it moves. Time runs from 0 to the last frame's time.
#[derive(Clone, Debug, PartialEq)]
pub struct Player {
    time: f64,
    duration: f64,
    fps: f64,
    frames: usize,
    pub playing: bool,
    pub looping: bool,
    /// Playback rate; negative plays backwards.
    pub speed: f32,
}

impl Player {
    pub fn new(tracking: &Tracking) -> Self {
        Self {
            time: 0.0,
            duration: tracking.duration(),
            fps: tracking.fps as f64,
            frames: tracking.frames.len(),
            playing: true,
            looping: true,
            speed: 1.0,
        }
    }

    pub fn time(&self) -> f64 {
        self.time
    }

    pub fn duration(&self) -> f64 {
        self.duration
    }

    pub fn frame_count(&self) -> usize {
        self.frames
    }

    /// The frame at or just before the current time.
    pub fn frame(&self) -> usize {
        ((self.time * self.fps + 1e-6).floor() as usize).min(self.frames - 1)
    }

    /// Moves the clock by `dt` wall-clock seconds when playing; returns whether the time changed.
    /// Without looping, playback stops at either end.
    pub fn advance(&mut self, dt: f64) -> bool {
        if !self.playing || !dt.is_finite() {
            return false;
        }
        let before = self.time;
        let t = self.time + dt * self.speed as f64;
        if self.looping && self.duration > 0.0 {
            self.time = t.rem_euclid(self.duration);
        } else {
            self.time = t.clamp(0.0, self.duration);
            if self.time != t {
                self.playing = false;
            }
        }
        self.time != before
    }

    /// Jumps to `time` (clamped); non-finite times are ignored.
    pub fn seek(&mut self, time: f64) {
        if time.is_finite() {
            self.time = time.clamp(0.0, self.duration);
        }
    }

    /// Pauses and moves by whole frames (negative steps back), stopping at the ends.
    pub fn step(&mut self, frames: i64) {
        self.playing = false;
        let target = (self.frame() as i64 + frames).clamp(0, self.frames as i64 - 1);
        self.time = (target as f64 / self.fps).min(self.duration);
    }
}

/// The tracked camera at `time`: world→camera in OpenCV axes and `invtanfov`, rotation slerped
/// and translation blended between the nearest frames. `None` when the file has no cameras.
pub fn camera_at(tracking: &Tracking, time: f64) -> Option<(Mat4, f32)> {
    let (a, b, t) = bracket(tracking, time);
    let ca = tracking.frames[a].camera?;
    let cb = tracking.frames[b].camera?;
    let split = |m: [[f32; 4]; 3]| {
        let r = Mat3::from_cols_array_2d(&[
            [m[0][0], m[1][0], m[2][0]],
            [m[0][1], m[1][1], m[2][1]],
            [m[0][2], m[1][2], m[2][2]],
        ]);
        (
            Quat::from_mat3(&r).normalize(),
            Vec3::new(m[0][3], m[1][3], m[2][3]),
        )
    };
    let (ra, ta) = split(ca.w2c);
    let (rb, tb) = split(cb.w2c);
    let w2c = Mat4::from_rotation_translation(ra.slerp(rb, t), ta.lerp(tb, t));
    Some((w2c, ca.invtanfov + (cb.invtanfov - ca.invtanfov) * t))
}
