//! Hands the photo did not show, drawn only where the photo looked. A close-up leaves the hands
//! far below its edge, so the default reconstruction left them out with the rest of what it did
//! not see; but a hand raised to the face comes into the very view the avatar was made from,
//! and without it the face it covers was drawn bare (the shipped clip's hand over her mouth).
//! So hands stay in the avatar, in the skin their unseen part is given, and each frame a hand is
//! drawn only while its wrist, middle knuckle or middle fingertip, carried back to the photo's
//! pose by the body's root, lies where the photo's camera saw (within [`SEEN_MARGIN`] of the
//! square, as what is kept of the body); hanging below the bust it is hidden. (The wrist alone
//! was not enough: the shipped clip's hand over her mouth has its wrist below the frame.) A hand
//! the photo showed is drawn as the avatar has it. The lower arm (elbow and forearm) of a hand
//! the photo did not show, where the photo did not show it either, is drawn while that hand
//! lies inside the photo itself (raised into it, not hanging just below it): left out, a waving
//! avatar cut at the chest (Grace Hopper) held up a hand floating beyond its sleeve.

use glam::{Affine3A, Vec3};

use super::Avatar;
use crate::body::{Posable, PosedBody};
use crate::camera::Camera;

/// The body just past the photo's edge is kept (turned views see a little of it, coloured from
/// what the photo shows next to it): this share of the photo's side beyond each edge.
pub const SEEN_MARGIN: f32 = 0.25;

/// The arm's joints from the upper arm's middle down to the wrist (their names' beginnings): a
/// vertex moved most by one is the lower arm's. (The forearm's alone left a gap at the elbow.)
const LOWER_ARM: [&str; 2] = ["upperarm02", "lowerarm"];

/// Whether `camera` sees `point` within `bounds` (left, top, right, bottom, in its pixels) or
/// within `margin` (a share of the camera's side, [`SEEN_MARGIN`] for what is kept of the body)
/// of them.
pub fn seen_within(camera: &Camera, bounds: [f32; 4], margin: f32, point: Vec3) -> bool {
    let [left, top, right, bottom] = bounds;
    let (mx, my) = (margin * camera.width as f32, margin * camera.height as f32);
    let p = camera.project(point);
    p.z > 0.0 && (left - mx..right + mx).contains(&p.x) && (top - my..bottom + my).contains(&p.y)
}

/// An avatar's hands the photo did not show, with what deciding their visibility needs.
#[derive(Clone, Debug)]
pub struct HandsInView {
    /// Per body vertex: 0 off those hands, 1 the left hand's, 2 the right's, 3 the left lower
    /// arm's and 4 the right's where the photo did not show them.
    sides: Vec<u8>,
    /// Each hand's wrist, middle knuckle and middle fingertip joints.
    joints: [[usize; 3]; 2],
    /// The root joint's world transform at the photo's pose, and the photo's camera.
    root: Affine3A,
    camera: Camera,
}

impl HandsInView {
    /// `None` for an avatar without its photo's view, a body without hand parts and wrists
    /// (EHM's), or when the photo showed both hands: those are drawn as the avatar has them.
    pub fn new(avatar: &Avatar, body: &impl Posable) -> Option<Self> {
        let view = avatar.source_view.as_ref()?;
        let joint = |name: &str| body.joint_names().position(|n| n == name);
        let hand = |side: &str| -> Option<[usize; 3]> {
            Some([
                joint(&format!("wrist.{side}"))?,
                joint(&format!("finger3-1.{side}"))?,
                joint(&format!("finger3-3.{side}"))?,
            ])
        };
        let joints = [hand("L")?, hand("R")?];
        let mut posed = PosedBody::default();
        body.pose(&avatar.base_pose(body), &mut posed).ok()?;
        let mut hands = Self {
            sides: Vec::new(),
            joints,
            root: *posed.joints.first()?,
            camera: view.camera,
        };
        let unseen = hands.in_view(&posed, SEEN_MARGIN).map(|seen| !seen);
        let names: Vec<&str> = body.joint_names().collect();
        let lower_arm_side = |v: usize| -> u8 {
            let Some(name) = body.dominant_joint(v).and_then(|j| names.get(j)) else {
                return 0;
            };
            let side = match name.rsplit('.').next() {
                Some("L") => 0,
                Some("R") => 1,
                _ => return 0,
            };
            let shown = hands.sees(SEEN_MARGIN, posed.vertices[v]);
            let lower_arm = LOWER_ARM.iter().any(|j| name.starts_with(j));
            match lower_arm && unseen[side] && !shown {
                true => 3 + side as u8,
                false => 0,
            }
        };
        let sides: Vec<u8> = (0..body.vertex_count())
            .map(|v| match body.part_of(v) {
                Some("hand.L") if unseen[0] => 1,
                Some("hand.R") if unseen[1] => 2,
                _ => lower_arm_side(v),
            })
            .collect();
        hands.sides = sides;
        hands.sides.iter().any(|&s| s != 0).then_some(hands)
    }

    /// Whether vertex `v` is drawn only while its hand is in the photo's view.
    pub fn hides(&self, v: usize) -> bool {
        self.sides.get(v).is_some_and(|&s| s != 0)
    }

    /// Whether each hand (left, right) of the body posed as `posed` is in the photo's view,
    /// or within `margin` (a share of its side) of it.
    fn in_view(&self, posed: &PosedBody, margin: f32) -> [bool; 2] {
        let Some(root) = posed.joints.first() else {
            return [true; 2];
        };
        let back = self.root * root.inverse();
        self.joints.map(|hand| {
            hand.iter().any(|&j| {
                posed.joints.get(j).is_none_or(|joint| {
                    self.sees(margin, back.transform_point3a(joint.translation).into())
                })
            })
        })
    }

    /// Whether the photo's camera sees `point` (at the photo's pose) within its square or within
    /// `margin` of it.
    fn sees(&self, margin: f32, point: Vec3) -> bool {
        let square = [
            0.0,
            0.0,
            self.camera.width as f32,
            self.camera.height as f32,
        ];
        seen_within(&self.camera, square, margin, point)
    }

    /// Per body vertex, 1 where it is drawn and 0 on a hand out of the photo's view (or a lower
    /// arm whose hand is out of the photo itself).
    pub fn visibility(&self, posed: &PosedBody, out: &mut Vec<f32>) {
        let near = self.in_view(posed, SEEN_MARGIN);
        let inside = self.in_view(posed, 0.0);
        out.clear();
        out.extend(self.sides.iter().map(|&s| match s {
            1 | 2 => f32::from(u8::from(near[usize::from(s - 1)])),
            3 | 4 => f32::from(u8::from(inside[usize::from(s - 3)])),
            _ => 1.0,
        }));
    }
}
