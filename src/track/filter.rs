//! The One Euro filter (Casiez, Roussel and Vogel, CHI 2012) as MediaPipe's landmark smoothing
//! applies it: a low-pass filter whose cutoff rises with the signal's speed, so that a still
//! subject does not jitter and a moving one does not lag. Speeds are measured in the object's
//! own size per second (MediaPipe scales landmark values by the inverse of the person's size),
//! so one setting serves a face close up and a body far away. Rotations are filtered as unit
//! quaternions (speed: the angle turned per second; the step: a slerp), never as Euler angles
//! or axis-angle components, which jump where they wrap.

use glam::{Quat, Vec3};

/// A One Euro filter's settings: the cutoff at rest (Hz), how much speed raises it (Hz per
/// unit of speed) and the cutoff of the speed's own low-pass (Hz).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OneEuroSettings {
    pub min_cutoff: f64,
    pub beta: f64,
    pub d_cutoff: f64,
}

impl OneEuroSettings {
    /// Landmarks in pixels, with speeds in the object's sizes per second: MediaPipe's settings
    /// for its pose landmarks (`pose_landmark_filtering`). Beside 0.1 and 40 (its graphs'
    /// other setting) they tracked `guava bench track`'s synthetic wave 0.2 px closer.
    pub const LANDMARKS: Self = Self {
        min_cutoff: 0.05,
        beta: 80.0,
        d_cutoff: 1.0,
    };
    /// Joint rotations, speed in radians per second: at rest 1 Hz, 21 Hz at a waving
    /// forearm's 4 rad/s. On `guava bench track`'s synthetic wave the arms' joints were (mean px
    /// off, Σ° change a frame; truth 8.9°) unfiltered 4.3 px, 67°; at rest 0.5 Hz 6.0 px, 30°;
    /// 1 Hz 5.8 px, 33°; 2 Hz 5.5 px, 36°; 1 Hz with β 0.3 (the first try) lagged the wave by
    /// 18 px. The shipped clip's self-reenactment (`guava eval --video`) gained from less lag
    /// too: 0.5 Hz 16.99 dB, 1 Hz 17.07, 2 Hz 17.11, its joints changing 3.85°, 4.11° and 4.43°
    /// a frame; 1 Hz is the middle of that trade.
    pub const ROTATIONS: Self = Self {
        min_cutoff: 1.0,
        beta: 5.0,
        d_cutoff: 1.0,
    };
    /// Face units (0…1 a unit), speed in units per second: a blink (1 unit in 0.1 s) passes.
    pub const EXPRESSIONS: Self = Self {
        min_cutoff: 1.5,
        beta: 2.0,
        d_cutoff: 1.0,
    };

    /// The smoothing factor of a low-pass at `cutoff` Hz for samples `dt` seconds apart.
    fn alpha(cutoff: f64, dt: f64) -> f64 {
        let tau = 1.0 / (2.0 * std::f64::consts::PI * cutoff);
        1.0 / (1.0 + tau / dt)
    }
}

/// One Euro filters over a fixed number of scalar channels (each its own filter, as MediaPipe
/// filters each coordinate).
#[derive(Clone, Debug)]
pub struct OneEuro {
    settings: OneEuroSettings,
    /// Per channel: the last raw value, the filtered value and the filtered speed.
    state: Vec<(f64, f64, f64)>,
    last_time: Option<f64>,
}

impl OneEuro {
    pub fn new(settings: OneEuroSettings) -> Self {
        Self {
            settings,
            state: Vec::new(),
            last_time: None,
        }
    }

    /// Forgets the past: the next values pass as they are (a subject lost and found again).
    pub fn reset(&mut self) {
        self.state.clear();
        self.last_time = None;
    }

    /// Filters `values` (in place) seen at `time` seconds; speeds are multiplied by
    /// `value_scale` (1 / the object's size) before they raise the cutoff. A change in the
    /// number of channels, or a time that does not advance, starts the filter afresh.
    pub fn apply(&mut self, time: f64, value_scale: f64, values: &mut [f64]) {
        let dt = self.last_time.map(|t| time - t);
        let fresh = self.state.len() != values.len() || !dt.is_some_and(|dt| dt > 0.0);
        self.last_time = Some(time);
        if fresh {
            self.state = values.iter().map(|&v| (v, v, 0.0)).collect();
            return;
        }
        let dt = dt.expect("checked above");
        let s = self.settings;
        let alpha_d = OneEuroSettings::alpha(s.d_cutoff, dt);
        for (v, (raw, filtered, speed)) in values.iter_mut().zip(&mut self.state) {
            let ds = (*v - *raw) * value_scale / dt;
            *speed += alpha_d * (ds - *speed);
            let cutoff = s.min_cutoff + s.beta * speed.abs();
            *raw = *v;
            *filtered += OneEuroSettings::alpha(cutoff, dt) * (*v - *filtered);
            *v = *filtered;
        }
    }
}

/// One Euro filters over joint rotations given as axis-angle vectors, each filtered as a unit
/// quaternion: its speed is the length of its low-passed angular velocity (a vector, so that
/// jitter back and forth averages out as a signed derivative does, where the angle turned
/// would add up), its step a slerp from the last filtered rotation towards the new one (on the
/// same hemisphere).
#[derive(Clone, Debug)]
pub struct RotationFilter {
    settings: OneEuroSettings,
    /// Per rotation: the last raw and filtered rotations and the filtered angular velocity
    /// (rad/s, in the rotation's own frame).
    state: Vec<(Quat, Quat, Vec3)>,
    last_time: Option<f64>,
}

impl RotationFilter {
    pub fn new(settings: OneEuroSettings) -> Self {
        Self {
            settings,
            state: Vec::new(),
            last_time: None,
        }
    }

    pub fn reset(&mut self) {
        self.state.clear();
        self.last_time = None;
    }

    /// Filters the axis-angle `rotations` (in place) seen at `time` seconds.
    pub fn apply(&mut self, time: f64, rotations: &mut [Vec3]) {
        let dt = self.last_time.map(|t| time - t);
        let fresh = self.state.len() != rotations.len() || !dt.is_some_and(|dt| dt > 0.0);
        self.last_time = Some(time);
        if fresh {
            self.state = rotations
                .iter()
                .map(|&r| {
                    let q = Quat::from_scaled_axis(r);
                    (q, q, Vec3::ZERO)
                })
                .collect();
            return;
        }
        let dt = dt.expect("checked above");
        let s = self.settings;
        let alpha_d = OneEuroSettings::alpha(s.d_cutoff, dt);
        for (r, (raw, filtered, velocity)) in rotations.iter_mut().zip(&mut self.state) {
            let q = Quat::from_scaled_axis(*r);
            let mut turn = raw.inverse() * q;
            if turn.w < 0.0 {
                turn = -turn;
            }
            let omega = turn.to_scaled_axis() / dt as f32;
            *velocity += alpha_d as f32 * (omega - *velocity);
            let cutoff = s.min_cutoff + s.beta * f64::from(velocity.length());
            let alpha = OneEuroSettings::alpha(cutoff, dt) as f32;
            // The shorter way round: q and −q are the same rotation.
            let q_near = if filtered.dot(q) < 0.0 { -q } else { q };
            *raw = q;
            *filtered = filtered.slerp(q_near, alpha).normalize();
            *r = filtered.to_scaled_axis();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic noise in [−1, 1].
    fn noise(i: usize) -> f64 {
        let x = (i as f64 * 12.9898).sin() * 43758.5453;
        2.0 * (x - x.floor()) - 1.0
    }

    #[test]
    fn a_still_signal_loses_its_jitter_and_a_moving_one_follows() {
        let mut filter = OneEuro::new(OneEuroSettings::LANDMARKS);
        // A landmark at 100 px with ±2 px of noise, 30 fps, on a 200 px person.
        let (mut raw_change, mut filtered_change) = (0.0, 0.0);
        let mut last = (100.0, 100.0);
        for i in 0..90 {
            let raw = 100.0 + 2.0 * noise(i);
            let mut v = [raw];
            filter.apply(i as f64 / 30.0, 1.0 / 200.0, &mut v);
            if i > 0 {
                raw_change += (raw - last.0).abs();
                filtered_change += (v[0] - last.1).abs();
            }
            last = (raw, v[0]);
        }
        // MediaPipe's setting keeps about a quarter of this jitter (0.28 measured): it favours
        // following motion, and the fit's temporal prior and the output's filter do the rest.
        assert!(
            filtered_change < 0.35 * raw_change,
            "jitter {filtered_change} against {raw_change}"
        );
        // Then it moves 300 px a second (1.5 bodies a second): it lags by under 10 px.
        for i in 90..120 {
            let raw = 100.0 + 10.0 * (i - 89) as f64;
            let mut v = [raw];
            filter.apply(i as f64 / 30.0, 1.0 / 200.0, &mut v);
            last = (raw, v[0]);
        }
        assert!((last.0 - last.1).abs() < 10.0, "lag {:?}", last);
    }

    #[test]
    fn rotations_are_filtered_across_the_half_turn_where_axis_angle_jumps() {
        // A joint turning steadily about y through π, where its axis-angle flips from (0, π, 0)
        // to (0, −π, 0): a per-component filter would swing back through zero.
        let mut filter = RotationFilter::new(OneEuroSettings::ROTATIONS);
        let mut previous: Option<Quat> = None;
        for i in 0..60 {
            let angle = 2.5 + 0.05 * i as f32;
            let mut r = [Quat::from_rotation_y(angle).to_scaled_axis()];
            filter.apply(i as f64 / 30.0, &mut r);
            let q = Quat::from_scaled_axis(r[0]);
            if let Some(p) = previous {
                assert!(
                    p.angle_between(q) < 0.06,
                    "frame {i}: jumped {}",
                    p.angle_between(q)
                );
            }
            previous = Some(q);
        }
        // It ends near the true rotation (lagging a little behind).
        let truth = Quat::from_rotation_y(2.5 + 0.05 * 59.0);
        let lag = previous.expect("ran").angle_between(truth);
        assert!(lag < 0.05, "{lag}");
    }

    #[test]
    fn a_change_of_channels_or_a_time_that_stands_still_restarts() {
        let mut filter = OneEuro::new(OneEuroSettings::EXPRESSIONS);
        let mut v = [0.0, 1.0];
        filter.apply(0.0, 1.0, &mut v);
        let mut w = [1.0, 0.0];
        filter.apply(0.0, 1.0, &mut w);
        assert_eq!(w, [1.0, 0.0]);
        let mut three = [0.5, 0.5, 0.5];
        filter.apply(1.0, 1.0, &mut three);
        assert_eq!(three, [0.5, 0.5, 0.5]);
    }
}
