//! Posing by hand in people's terms: *Face* (jaw, eyes, brows, mouth and cheeks), *Hands* (each
//! finger's curl and spread, the wrist; per hand) and *Body* (head, neck, spine, shoulders,
//! elbows), each group with presets. A group the user touches overrides the motion for the joints
//! and parameters it drives until it is reset; the others keep following the motion.
//!
//! Built from the body itself: the ARKit units where the body has them (the default body), else
//! EHM's jaw and eye joints, eyelids and FLAME expression components; joint axes from the body's
//! rest joints (a finger curls towards its palm, an arm raises towards up), so both rigs' names
//! and rest poses work through one code path.

use glam::Vec3;
use guava::body::{BodyPose, Posable, PosedBody};

use guava::body::AnyBody;

/// What one slider moves: a parameter by the slider's value, or a joint about an axis (in its
/// world-aligned rest frame) by the value in degrees times the axis's length.
#[derive(Clone, Debug, PartialEq)]
enum Target {
    Coefficient(usize),
    Joint(usize, Vec3),
}

/// A named slider. Positive values drive `up`; negative ones drive `down` by the magnitude (two
/// ARKit units as one signed control, e.g. jaw left/right), or `up` by the signed value where
/// `down` is empty (joints).
#[derive(Clone, Debug)]
pub struct Control {
    pub name: String,
    pub range: [f32; 2],
    pub value: f32,
    up: Vec<Target>,
    down: Vec<Target>,
}

impl Control {
    fn units(name: &str, range: [f32; 2], up: Vec<usize>, down: Vec<usize>) -> Self {
        Self {
            name: name.into(),
            range,
            value: 0.0,
            up: up.into_iter().map(Target::Coefficient).collect(),
            down: down.into_iter().map(Target::Coefficient).collect(),
        }
    }

    /// Degrees about `axis` shared among `joints` (a spine bends over its vertebrae).
    fn degrees(name: &str, range: [f32; 2], joints: &[usize], axis: Vec3) -> Self {
        let share = axis.normalize_or_zero() / joints.len().max(1) as f32;
        Self::turns(name, range, joints.iter().map(|&j| (j, share)))
    }

    /// Degrees about each joint's own axis, the full angle at every joint (a finger curls at
    /// each knuckle, both eyes turn).
    fn turns(name: &str, range: [f32; 2], joints: impl Iterator<Item = (usize, Vec3)>) -> Self {
        Self {
            name: name.into(),
            range,
            value: 0.0,
            up: joints.map(|(j, axis)| Target::Joint(j, axis)).collect(),
            down: Vec::new(),
        }
    }

    fn is_empty(&self) -> bool {
        self.up.is_empty() && self.down.is_empty()
    }

    fn targets(&self) -> impl Iterator<Item = &Target> {
        self.up.iter().chain(&self.down)
    }

    fn apply(&self, pose: &mut BodyPose) {
        let (targets, amount) = if self.value < 0.0 && !self.down.is_empty() {
            (&self.down, -self.value)
        } else {
            (&self.up, self.value)
        };
        for t in targets {
            match *t {
                Target::Coefficient(i) => pose.coefficients[i] += amount,
                Target::Joint(j, axis) => pose.rotations[j] += axis * amount.to_radians(),
            }
        }
    }
}

/// Slider values by name; controls not named are 0.
#[derive(Clone)]
pub struct Preset {
    pub name: &'static str,
    values: Vec<(String, f32)>,
}

#[derive(Clone)]
pub struct Group {
    pub name: String,
    pub controls: Vec<Control>,
    pub presets: Vec<Preset>,
    /// Whether the group's values replace the motion's for what it drives.
    pub overridden: bool,
}

impl Group {
    fn new(name: &str, controls: Vec<Control>) -> Self {
        Self {
            name: name.into(),
            controls: controls.into_iter().filter(|c| !c.is_empty()).collect(),
            presets: Vec::new(),
            overridden: false,
        }
    }

    fn preset(mut self, name: &'static str, values: &[(&str, f32)]) -> Self {
        self.presets.push(Preset {
            name,
            values: values.iter().map(|(n, v)| (n.to_string(), *v)).collect(),
        });
        self
    }

    /// Sets the named preset's values (and overrides the motion); `false` if the group has no
    /// such preset.
    pub fn choose(&mut self, name: &str) -> bool {
        let Some(preset) = self.presets.iter().find(|p| p.name == name) else {
            return false;
        };
        for c in &mut self.controls {
            c.value = preset
                .values
                .iter()
                .find(|(n, _)| *n == c.name)
                .map_or(0.0, |(_, v)| *v);
        }
        self.overridden = true;
        true
    }

    /// Back to following the motion, the sliders at 0.
    pub fn reset(&mut self) {
        for c in &mut self.controls {
            c.value = 0.0;
        }
        self.overridden = false;
    }

    /// Replaces what the group drives with its sliders' pose (rest plus the sliders).
    fn apply(&self, pose: &mut BodyPose) {
        for t in self.controls.iter().flat_map(Control::targets) {
            match *t {
                Target::Coefficient(i) => pose.coefficients[i] = 0.0,
                Target::Joint(j, _) => pose.rotations[j] = Vec3::ZERO,
            }
        }
        for c in &self.controls {
            c.apply(pose);
        }
    }
}

/// The groups for one body.
#[derive(Clone)]
pub struct PoseControls {
    pub groups: Vec<Group>,
}

impl PoseControls {
    /// The controls `model` supports, named for people; `rest` is the model posed at rest.
    pub fn for_body(model: &AnyBody, rest: &PosedBody) -> Self {
        let rig = Rig { model, rest };
        let mut groups = vec![rig.face()];
        groups.extend([Side::Left, Side::Right].map(|s| rig.hand(s)));
        groups.push(rig.body());
        groups.retain(|g| !g.controls.is_empty());
        Self { groups }
    }

    /// The motion's (or the hand-set) pose with the overridden groups' values in place.
    pub fn apply(&self, pose: &mut BodyPose) {
        for g in self.groups.iter().filter(|g| g.overridden) {
            g.apply(pose);
        }
    }

    pub fn overridden(&self) -> impl Iterator<Item = &str> {
        self.groups
            .iter()
            .filter(|g| g.overridden)
            .map(|g| g.name.as_str())
    }

    pub fn group_mut(&mut self, name: &str) -> Option<&mut Group> {
        self.groups.iter_mut().find(|g| g.name == name)
    }

    pub fn ui(&mut self, ui: &mut egui::Ui) {
        let overridden: Vec<&str> = self.overridden().collect();
        ui.label(if overridden.is_empty() {
            "Every group follows the motion; a group you touch overrides it until reset.".into()
        } else {
            format!(
                "Set by hand (overriding the motion): {}",
                overridden.join(", ")
            )
        });
        for group in &mut self.groups {
            let title = if group.overridden {
                format!("{} (set by hand)", group.name)
            } else {
                group.name.clone()
            };
            egui::CollapsingHeader::new(title)
                .id_salt(&group.name)
                .default_open(group.name == "Face")
                .show(ui, |ui| group_ui(group, ui));
        }
    }
}

fn group_ui(group: &mut Group, ui: &mut egui::Ui) {
    ui.horizontal_wrapped(|ui| {
        let mut chosen = None;
        for p in &group.presets {
            if ui.button(p.name).clicked() {
                chosen = Some(p.name);
            }
        }
        if let Some(name) = chosen {
            group.choose(name);
        }
        if ui
            .add_enabled(group.overridden, egui::Button::new("Reset"))
            .on_hover_text("back to following the motion")
            .clicked()
        {
            group.reset();
        }
    });
    for c in &mut group.controls {
        let [lo, hi] = c.range;
        if ui
            .add(egui::Slider::new(&mut c.value, lo..=hi).text(&c.name))
            .changed()
        {
            group.overridden = true;
        }
    }
}

#[derive(Clone, Copy, PartialEq)]
enum Side {
    Left,
    Right,
}

/// World axes of the bodies' rest frames: y up, the body facing +z, its left at +x.
const UP: Vec3 = Vec3::Y;
const FORWARD: Vec3 = Vec3::Z;
const THEIR_LEFT: Vec3 = Vec3::X;

/// The axis that turns `direction` towards `towards` for positive angles.
fn turning(direction: Vec3, towards: Vec3) -> Vec3 {
    direction.cross(towards).normalize_or_zero()
}

/// Finger names, thumb first: the default body's (MakeHuman's finger1…5) and EHM's (SMPL-X's).
const FINGERS: [(&str, &str, &str); 5] = [
    ("thumb", "finger1", "thumb"),
    ("index", "finger2", "index"),
    ("middle", "finger3", "middle"),
    ("ring", "finger4", "ring"),
    ("pinky", "finger5", "pinky"),
];

/// Joint lookups on either rig.
struct Rig<'a> {
    model: &'a AnyBody,
    rest: &'a PosedBody,
}

impl Rig<'_> {
    fn joint(&self, name: &str) -> Option<usize> {
        self.model.joint_names().position(|n| n == name)
    }

    /// A joint on one side: `template` on the default body (`name.L`), `ehm` on EHM (`left_name`).
    fn sided(&self, side: Side, template: &str, ehm: &str) -> Option<usize> {
        let name = match (self.model.is_ehm(), side) {
            (false, Side::Left) => format!("{template}.L"),
            (false, Side::Right) => format!("{template}.R"),
            (true, Side::Left) => format!("left_{ehm}"),
            (true, Side::Right) => format!("right_{ehm}"),
        };
        self.joint(&name)
    }

    fn at(&self, j: usize) -> Vec3 {
        self.rest.joints[j].translation.into()
    }

    fn parameter(&self, name: &str) -> Option<usize> {
        self.model.parameter_names().position(|n| n == name)
    }

    fn parameters(&self, names: &[&str]) -> Vec<usize> {
        names.iter().filter_map(|n| self.parameter(n)).collect()
    }

    fn face(&self) -> Group {
        let units = |name: &str, up: &[&str], down: &[&str]| {
            let range = if down.is_empty() {
                [0.0, 1.0]
            } else {
                [-1.0, 1.0]
            };
            Control::units(name, range, self.parameters(up), self.parameters(down))
        };
        let mut controls = vec![
            units("jaw open", &["jawOpen"], &[]),
            units("jaw sideways (their left)", &["jawLeft"], &["jawRight"]),
            units("jaw forward", &["jawForward"], &[]),
            units(
                "look sideways (their left)",
                &["eyeLookOutLeft", "eyeLookInRight"],
                &["eyeLookInLeft", "eyeLookOutRight"],
            ),
            units(
                "look up / down",
                &["eyeLookUpLeft", "eyeLookUpRight"],
                &["eyeLookDownLeft", "eyeLookDownRight"],
            ),
            units("blink", &["eyeBlinkLeft", "eyeBlinkRight"], &[]),
            units(
                "lids wide / squint",
                &["eyeWideLeft", "eyeWideRight"],
                &["eyeSquintLeft", "eyeSquintRight"],
            ),
            units(
                "brows raise / lower",
                &["browInnerUp", "browOuterUpLeft", "browOuterUpRight"],
                &["browDownLeft", "browDownRight"],
            ),
            units(
                "smile / frown",
                &["mouthSmileLeft", "mouthSmileRight"],
                &["mouthFrownLeft", "mouthFrownRight"],
            ),
            units("pucker", &["mouthPucker"], &[]),
            units("funnel", &["mouthFunnel"], &[]),
            units(
                "mouth sideways (their left)",
                &["mouthLeft"],
                &["mouthRight"],
            ),
            units(
                "lips apart",
                &[
                    "mouthUpperUpLeft",
                    "mouthUpperUpRight",
                    "mouthLowerDownLeft",
                    "mouthLowerDownRight",
                ],
                &[],
            ),
            units("lips pressed", &["mouthPressLeft", "mouthPressRight"], &[]),
            units("cheeks puff", &["cheekPuff"], &[]),
            units(
                "cheeks squint",
                &["cheekSquintLeft", "cheekSquintRight"],
                &[],
            ),
            units("nose sneer", &["noseSneerLeft", "noseSneerRight"], &[]),
            // EHM: FLAME's jaw and eyes are joints, its lids parameters.
            units("blink", &["eyelid_left", "eyelid_right"], &[]),
        ];
        if self.parameter("jawOpen").is_none()
            && let Some(jaw) = self.joint("jaw")
        {
            controls.push(Control::degrees(
                "jaw open °",
                [-5.0, 30.0],
                &[jaw],
                turning(FORWARD, -UP),
            ));
        }
        let eyes: Vec<usize> = [("eye.L", "left_eye_smplhf"), ("eye.R", "right_eye_smplhf")]
            .iter()
            .filter_map(|(t, e)| self.joint(if self.model.is_ehm() { e } else { t }))
            .collect();
        if self.parameter("eyeLookOutLeft").is_none() && !eyes.is_empty() {
            let both = |name: &str, axis: Vec3| {
                Control::turns(name, [-30.0, 30.0], eyes.iter().map(|&j| (j, axis)))
            };
            controls.push(both(
                "look sideways ° (their left)",
                turning(FORWARD, THEIR_LEFT),
            ));
            controls.push(both("look up / down °", turning(FORWARD, UP)));
        }
        // FLAME's expression components have no names: the first ten, by number.
        for (i, name) in self.model.parameter_names().enumerate() {
            if let Some(k) = name
                .strip_prefix("flame_expression_")
                .and_then(|k| k.parse::<usize>().ok())
                .filter(|&k| k < 10)
            {
                controls.push(Control {
                    name: format!("expression component {k}"),
                    range: [-3.0, 3.0],
                    value: 0.0,
                    up: vec![Target::Coefficient(i)],
                    down: Vec::new(),
                });
            }
        }
        Group::new("Face", controls)
            .preset("Neutral", &[])
            .preset(
                "Smile",
                &[
                    ("smile / frown", 0.8),
                    ("cheeks squint", 0.3),
                    ("jaw open", 0.1),
                ],
            )
            .preset(
                "Surprise",
                &[
                    ("brows raise / lower", 0.9),
                    ("lids wide / squint", 0.8),
                    ("jaw open", 0.5),
                    ("jaw open °", 15.0),
                ],
            )
            .preset("Blink", &[("blink", 1.0)])
            .preset("Kiss", &[("pucker", 0.9), ("lips pressed", 0.2)])
    }

    fn hand(&self, side: Side) -> Group {
        let name = match side {
            Side::Left => "Left hand",
            Side::Right => "Right hand",
        };
        let wrist = self.sided(side, "wrist", "wrist");
        let chain = |(_, template, ehm): (&str, &str, &str)| -> Option<[usize; 3]> {
            let joint = |k: usize| match self.model.is_ehm() {
                false => self.sided(side, &format!("{template}-{k}"), ""),
                true => self.sided(side, "", &format!("{ehm}{k}")),
            };
            Some([joint(1)?, joint(2)?, joint(3)?])
        };
        let (Some(wrist), Some(index), Some(middle), Some(pinky)) = (
            wrist,
            chain(FINGERS[1]),
            chain(FINGERS[2]),
            chain(FINGERS[4]),
        ) else {
            return Group::new(name, Vec::new());
        };
        // The palm's normal, towards the palm: at rest both bodies hold their palms down.
        let w = self.at(wrist);
        let mut palm = (self.at(index[0]) - w)
            .cross(self.at(pinky[0]) - w)
            .normalize_or_zero();
        if palm.dot(-UP) < 0.0 {
            palm = -palm;
        }
        let direction = |f: [usize; 3]| (self.at(f[2]) - self.at(f[0])).normalize_or_zero();
        let middle_dir = direction(middle);
        let mut controls = Vec::new();
        for finger in FINGERS {
            let Some(f) = chain(finger) else { continue };
            let d = direction(f);
            let curl = turning(d, palm);
            controls.push(Control::turns(
                &format!("{} curl °", finger.0),
                [-20.0, 100.0],
                f.iter().map(|&j| (j, curl)),
            ));
            if finger.0 != "middle" {
                // Spread turns the base joint about the palm's normal, away from the middle finger.
                let away = (d - middle_dir).normalize_or_zero();
                let axis = turning(d, away.reject_from(palm).normalize_or_zero());
                controls.push(Control::degrees(
                    &format!("{} spread °", finger.0),
                    [-20.0, 30.0],
                    &f[..1],
                    axis,
                ));
            }
        }
        controls.push(Control::degrees(
            "wrist bend °",
            [-70.0, 70.0],
            &[wrist],
            turning(middle_dir, palm),
        ));
        controls.push(Control::degrees(
            "wrist sideways °",
            [-30.0, 30.0],
            &[wrist],
            turning(
                middle_dir,
                (self.at(index[0]) - self.at(pinky[0])).normalize_or_zero(),
            ),
        ));
        controls.push(Control::degrees(
            "wrist twist °",
            [-90.0, 90.0],
            &[wrist],
            middle_dir,
        ));
        let curls = |values: [f32; 5]| -> Vec<(String, f32)> {
            FINGERS
                .iter()
                .zip(values)
                .map(|((n, _, _), v)| (format!("{n} curl °"), v))
                .collect()
        };
        let preset = |g: Group, name: &'static str, values: Vec<(String, f32)>| {
            let refs: Vec<(&str, f32)> = values.iter().map(|(n, v)| (n.as_str(), *v)).collect();
            g.preset(name, &refs)
        };
        let mut open = curls([0.0; 5]);
        open.extend(["thumb", "index", "ring", "pinky"].map(|n| (format!("{n} spread °"), 12.0)));
        let mut group = Group::new(name, controls);
        group = preset(group, "Relaxed", curls([10.0, 15.0, 20.0, 25.0, 30.0]));
        group = preset(group, "Open", open);
        group = preset(group, "Fist", curls([45.0, 85.0, 85.0, 85.0, 85.0]));
        group = preset(group, "Point", curls([45.0, 0.0, 85.0, 85.0, 85.0]));
        group = preset(group, "Pinch", curls([30.0, 40.0, 15.0, 15.0, 15.0]));
        preset(group, "Thumbs up", curls([-10.0, 85.0, 85.0, 85.0, 85.0]))
    }

    fn body(&self) -> Group {
        let named =
            |names: &[&str]| -> Vec<usize> { names.iter().filter_map(|n| self.joint(n)).collect() };
        let spine = named(&[
            "spine05", "spine04", "spine03", "spine02", "spine01", "spine1", "spine2", "spine3",
        ]);
        let neck = named(&["neck01", "neck02", "neck03", "neck"]);
        let head = named(&["head"]);
        let mut controls = Vec::new();
        for (part, joints, range) in [
            ("head", &head, 60.0),
            ("neck", &neck, 40.0),
            ("spine", &spine, 45.0),
        ] {
            controls.push(Control::degrees(
                &format!("{part} nod °"),
                [-range, range],
                joints,
                turning(FORWARD, -UP),
            ));
            controls.push(Control::degrees(
                &format!("{part} turn ° (their left)"),
                [-range * 1.5, range * 1.5],
                joints,
                turning(FORWARD, THEIR_LEFT),
            ));
            controls.push(Control::degrees(
                &format!("{part} tilt ° (their left)"),
                [-range, range],
                joints,
                turning(UP, THEIR_LEFT),
            ));
        }
        for side in [Side::Left, Side::Right] {
            let label = match side {
                Side::Left => "left",
                Side::Right => "right",
            };
            let (Some(shoulder), Some(elbow), Some(wrist)) = (
                self.sided(side, "upperarm01", "shoulder"),
                self.sided(side, "lowerarm01", "elbow"),
                self.sided(side, "wrist", "wrist"),
            ) else {
                continue;
            };
            let arm = (self.at(elbow) - self.at(shoulder)).normalize_or_zero();
            let forearm = (self.at(wrist) - self.at(elbow)).normalize_or_zero();
            controls.push(Control::degrees(
                &format!("{label} arm raise °"),
                [-60.0, 120.0],
                &[shoulder],
                turning(arm, UP),
            ));
            controls.push(Control::degrees(
                &format!("{label} arm forward °"),
                [-60.0, 120.0],
                &[shoulder],
                turning(arm, FORWARD),
            ));
            controls.push(Control::degrees(
                &format!("{label} arm twist °"),
                [-90.0, 90.0],
                &[shoulder],
                arm,
            ));
            controls.push(Control::degrees(
                &format!("{label} elbow bend °"),
                [0.0, 150.0],
                &[elbow],
                turning(forearm, FORWARD),
            ));
        }
        Group::new("Body", controls)
            .preset("Rest", &[])
            .preset(
                "Wave",
                &[
                    ("right arm raise °", 75.0),
                    // The elbow bends forward from the arm's rest: a quarter twist makes it up.
                    ("right arm twist °", 90.0),
                    ("right elbow bend °", 100.0),
                    ("head tilt ° (their left)", -8.0),
                ],
            )
            .preset(
                "Hands to chest",
                &[
                    ("left arm forward °", 45.0),
                    ("right arm forward °", 45.0),
                    ("left elbow bend °", 120.0),
                    ("right elbow bend °", 120.0),
                ],
            )
            .preset(
                "Look around",
                &[
                    ("head turn ° (their left)", 35.0),
                    ("neck turn ° (their left)", 15.0),
                ],
            )
            .preset("Lean in", &[("spine nod °", 20.0), ("head nod °", -10.0)])
    }
}
