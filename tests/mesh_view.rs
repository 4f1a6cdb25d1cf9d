//! The mesh view of the posed default body, rendered headless on the test adapter: the image must
//! agree with the camera model (silhouette bounds = projected vertex bounds), be left–right
//! symmetric for the symmetric rest body, and follow the pose.

use glam::{Vec3, Vec4Swizzles};
use guava::body::{BodyModel, BodyPose, PosedBody, vertex_normals};
use guava::camera::Camera;
use guava::gpu::GpuContext;
use guava::render::mesh::{MeshPass, MeshStyle, clip_from_view};

const SIZE: u32 = 256;
const BACKGROUND: [f32; 3] = [0.0, 0.0, 0.0];

struct View {
    gpu: GpuContext,
    pass: MeshPass,
    camera: Camera,
    model: BodyModel,
}

impl View {
    fn new() -> Self {
        let gpu = GpuContext::headless().expect("a Vulkan adapter (lavapipe in CI)");
        let model = BodyModel::default_body().expect("default body");
        let mut pass = MeshPass::new(&gpu.device, None);
        pass.set_topology(&gpu.device, model.vertices.len(), &model.triangles);
        // In front of the body (it faces +z), looking at its centre.
        let camera = Camera::from_fov_y(
            Camera::look_at(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y),
            SIZE,
            SIZE,
            30f32.to_radians(),
        );
        Self {
            gpu,
            pass,
            camera,
            model,
        }
    }

    /// Renders the body in `pose`; returns a coverage mask (pixel differs from the background).
    fn render(&mut self, pose: &BodyPose, style: MeshStyle) -> (Vec<bool>, PosedBody) {
        let mut posed = PosedBody::default();
        self.model.pose(pose, &mut posed).expect("pose");
        let (mut scratch, mut normals) = (Vec::new(), Vec::new());
        vertex_normals(
            &posed.vertices,
            &self.model.triangles,
            Some(&self.model.weld),
            &mut scratch,
            &mut normals,
        );
        self.pass
            .set_vertices(&self.gpu.queue, &posed.vertices, &normals);
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        self.pass.encode(
            &self.gpu.device,
            &self.gpu.queue,
            &mut encoder,
            &self.camera,
            &style,
        );
        self.gpu.queue.submit([encoder.finish()]);
        let bytes = self
            .pass
            .read_color(&self.gpu.device, &self.gpu.queue)
            .expect("image");
        assert_eq!(bytes.len(), (SIZE * SIZE * 4) as usize);
        (
            bytes.chunks_exact(4).map(|p| p[..3] != [0, 0, 0]).collect(),
            posed,
        )
    }
}

fn shaded() -> MeshStyle {
    MeshStyle {
        shaded: true,
        wireframe: false,
        background: BACKGROUND,
        overlay: None,
    }
}

fn bounds(mask: &[bool]) -> [u32; 4] {
    let mut b = [u32::MAX, u32::MAX, 0, 0];
    for (i, _) in mask.iter().enumerate().filter(|(_, m)| **m) {
        let (x, y) = (i as u32 % SIZE, i as u32 / SIZE);
        b = [b[0].min(x), b[1].min(y), b[2].max(x), b[3].max(y)];
    }
    b
}

/// Pixel-edge bounds of the vertices projected with the camera model on the CPU.
fn projected_bounds(camera: &Camera, vertices: &[Vec3]) -> [f32; 4] {
    let clip = clip_from_view(camera) * camera.view_from_world;
    vertices
        .iter()
        .fold([f32::MAX, f32::MAX, f32::MIN, f32::MIN], |b, v| {
            let c = clip * v.extend(1.0);
            let ndc = c.xy() / c.w;
            let (x, y) = (
                (ndc.x + 1.0) * 0.5 * SIZE as f32,
                (1.0 - ndc.y) * 0.5 * SIZE as f32,
            );
            [b[0].min(x), b[1].min(y), b[2].max(x), b[3].max(y)]
        })
}

#[test]
fn silhouette_matches_the_camera_model_and_is_symmetric() {
    let mut view = View::new();
    let rest = BodyPose::rest(&view.model);
    let (mask, posed) = view.render(&rest, shaded());
    let coverage = mask.iter().filter(|m| **m).count() as f32 / mask.len() as f32;
    assert!((0.03..0.5).contains(&coverage), "coverage {coverage}");
    // Rasterised bounds (pixel indices) vs projected bounds (pixel edges): within a pixel.
    let got = bounds(&mask);
    let want = projected_bounds(&view.camera, &posed.vertices);
    for k in 0..4 {
        let edge = if k < 2 {
            want[k].floor()
        } else {
            want[k].ceil() - 1.0
        };
        assert!(
            (got[k] as f32 - edge).abs() <= 1.0,
            "bound {k}: image {got:?}, camera {want:?}"
        );
    }
    // The rest body is left-right symmetric and the camera looks at its centre line.
    let mut agree = 0;
    for y in 0..SIZE {
        for x in 0..SIZE {
            let i = (y * SIZE + x) as usize;
            let j = (y * SIZE + (SIZE - 1 - x)) as usize;
            agree += (mask[i] == mask[j]) as usize;
        }
    }
    assert!(
        agree as f32 / mask.len() as f32 > 0.99,
        "symmetry {}",
        agree as f32 / mask.len() as f32
    );
}

#[test]
fn the_image_follows_the_pose_and_the_wireframe_switch() {
    let mut view = View::new();
    let mut pose = BodyPose::rest(&view.model);
    let (rest, _) = view.render(&pose, shaded());
    // Raise the left arm: the silhouette grows upwards on the image's right (the body's left).
    pose.set_rotation(&view.model, "upperarm01.L", Vec3::new(0.0, 0.0, 2.2))
        .expect("joint");
    let (raised, posed) = view.render(&pose, shaded());
    let want = projected_bounds(&view.camera, &posed.vertices);
    assert_ne!(rest, raised);
    assert!((bounds(&raised)[1] as f32 - want[1].floor()).abs() <= 1.0);
    assert!(
        bounds(&raised)[1] + 10 < bounds(&rest)[1],
        "the raised hand is the highest point"
    );
    // Wireframe-only lies within the shaded silhouette's bounds (lines are up to a pixel wider).
    let wire = MeshStyle {
        shaded: false,
        wireframe: true,
        background: BACKGROUND,
        overlay: None,
    };
    let (lines, _) = view.render(&BodyPose::rest(&view.model), wire);
    let count = |m: &[bool]| m.iter().filter(|v| **v).count();
    assert!(
        count(&lines) > count(&rest) / 2,
        "the dense mesh fills most of its silhouette"
    );
    let (b, r) = (bounds(&lines), bounds(&rest));
    for k in 0..4 {
        assert!(b[k].abs_diff(r[k]) <= 1, "wire {b:?} vs shaded {r:?}");
    }
}
