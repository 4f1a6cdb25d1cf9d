//! A camera path set by hand: orbit cameras keyed at timeline times, passed through smoothly
//! (Catmull–Rom through every orbit parameter, held before the first key and after the last).
//! The viewport follows it while the timeline moves (camera mode *keys*) and sequence exports
//! fly it.

use glam::Vec3;

use crate::orbit::OrbitCamera;

#[derive(Clone, Debug, Default)]
pub struct CameraKeys {
    /// Keys sorted by time (seconds on the timeline); one camera per time.
    keys: Vec<(f64, OrbitCamera)>,
}

impl CameraKeys {
    pub fn keys(&self) -> &[(f64, OrbitCamera)] {
        &self.keys
    }

    pub fn is_empty(&self) -> bool {
        self.keys.is_empty()
    }

    /// Keys `camera` at `time`, replacing a key at the same time.
    pub fn set(&mut self, time: f64, camera: OrbitCamera) {
        match self.keys.binary_search_by(|(t, _)| t.total_cmp(&time)) {
            Ok(i) => self.keys[i].1 = camera,
            Err(i) => self.keys.insert(i, (time, camera)),
        }
    }

    pub fn remove(&mut self, index: usize) {
        if index < self.keys.len() {
            self.keys.remove(index);
        }
    }

    pub fn clear(&mut self) {
        self.keys.clear();
    }

    /// The camera at `time`: `None` without keys.
    pub fn at(&self, time: f64) -> Option<OrbitCamera> {
        let keys = &self.keys;
        let last = keys.len().checked_sub(1)?;
        let i = keys.partition_point(|(t, _)| *t <= time);
        if i == 0 {
            return Some(keys[0].1);
        }
        if i > last {
            return Some(keys[last].1);
        }
        // Between keys i-1 and i; the neighbours beyond them shape the curve (repeated at ends).
        let (t0, t1) = (keys[i - 1].0, keys[i].0);
        let s = ((time - t0) / (t1 - t0).max(1e-9)) as f32;
        let [a, b, c, d] = [i.saturating_sub(2), i - 1, i, (i + 1).min(last)].map(|k| keys[k].1);
        let curve = |f: fn(&OrbitCamera) -> f32| catmull_rom(f(&a), f(&b), f(&c), f(&d), s);
        let target = Vec3::new(
            curve(|o| o.target.x),
            curve(|o| o.target.y),
            curve(|o| o.target.z),
        );
        Some(OrbitCamera {
            target,
            // Zooming is even in log distance; never through zero.
            distance: curve(|o| o.distance.max(1e-6).ln()).exp(),
            yaw_rad: curve(|o| o.yaw_rad),
            pitch_rad: curve(|o| o.pitch_rad).clamp(-1.55, 1.55),
            fov_y_rad: curve(|o| o.fov_y_rad).clamp(1f32.to_radians(), 170f32.to_radians()),
            y_up: c.y_up,
        })
    }

    /// The keys panel: add the current view at the current time, go to or remove a key.
    /// Returns a key's camera when the user asks to look through it.
    pub fn ui(
        &mut self,
        ui: &mut egui::Ui,
        time: f64,
        current: OrbitCamera,
    ) -> Option<OrbitCamera> {
        ui.horizontal(|ui| {
            if ui
                .button(format!("Key this view at {time:.2} s"))
                .on_hover_text(
                    "the orbit camera as it is, at the timeline's time: the path passes \
                     through every key (camera mode *keys* and sequence exports follow it)",
                )
                .clicked()
            {
                self.set(time, current);
            }
            if !self.is_empty() && ui.button("Clear").clicked() {
                self.clear();
            }
        });
        let mut look = None;
        let mut removed = None;
        for (i, (t, o)) in self.keys.iter().enumerate() {
            ui.horizontal(|ui| {
                ui.monospace(format!(
                    "{t:6.2} s  yaw {:4.0}°  pitch {:3.0}°  {:.2} m",
                    o.yaw_rad.to_degrees(),
                    o.pitch_rad.to_degrees(),
                    o.distance
                ));
                if ui.small_button("look").clicked() {
                    look = Some(*o);
                }
                if ui.small_button("✕").clicked() {
                    removed = Some(i);
                }
            });
        }
        if let Some(i) = removed {
            self.remove(i);
        }
        look
    }
}

/// Uniform Catmull–Rom between `b` (s = 0) and `c` (s = 1).
fn catmull_rom(a: f32, b: f32, c: f32, d: f32, s: f32) -> f32 {
    let (s2, s3) = (s * s, s * s * s);
    0.5 * (2.0 * b
        + (c - a) * s
        + (2.0 * a - 5.0 * b + 4.0 * c - d) * s2
        + (3.0 * b - 3.0 * c + d - a) * s3)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn yawed(deg: f32, distance: f32) -> OrbitCamera {
        OrbitCamera {
            yaw_rad: deg.to_radians(),
            distance,
            ..Default::default()
        }
    }

    #[test]
    fn the_path_passes_through_its_keys_and_holds_beyond_them() {
        let mut keys = CameraKeys::default();
        assert!(keys.at(1.0).is_none());
        keys.set(4.0, yawed(90.0, 2.0));
        keys.set(0.0, yawed(0.0, 2.0));
        keys.set(8.0, yawed(90.0, 8.0));
        for (t, want) in [
            (0.0, 0.0),
            (4.0, 90.0),
            (8.0, 90.0),
            (-1.0, 0.0),
            (9.0, 90.0),
        ] {
            let got = keys.at(t).expect("keyed").yaw_rad.to_degrees();
            assert!((got - want).abs() < 1e-3, "{t} s: {got}°");
        }
        // Between keys the yaw moves monotonically from 0° to 90° (linear keys stay linear).
        let mid = keys.at(2.0).expect("keyed").yaw_rad.to_degrees();
        assert!((30.0..60.0).contains(&mid), "{mid}°");
        // Distance is interpolated in log space: halfway from 2 to 8 m is near 4 m, not 5.
        let d = keys.at(6.0).expect("keyed").distance;
        assert!((3.5..4.6).contains(&d), "{d}");
        // A key at an existing time replaces it.
        keys.set(4.0, yawed(45.0, 2.0));
        assert_eq!(keys.keys().len(), 3);
        assert!((keys.at(4.0).expect("keyed").yaw_rad.to_degrees() - 45.0).abs() < 1e-3);
    }
}
