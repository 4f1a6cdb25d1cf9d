//! Stiff and extreme inputs: the splatting pass must give finite output, count what it drops, and
//! neither panic nor lose the device (wgpu's default error handler panics on validation errors).

use crate::common::{assert_all_finite, renderer};
use glam::{Mat4, Vec3};
use guava::camera::{Camera, orbit};
use guava::gaussians::GaussianCloud;
use guava::gaussians::synthetic::BallCloud;
use guava::render::reference;
use std::f32::consts::FRAC_1_SQRT_2;

const ID: [f32; 4] = [1.0, 0.0, 0.0, 0.0];

fn front_camera(size: u32) -> Camera {
    Camera::from_fov_y(
        orbit(Vec3::ZERO, 3.0, 0.0, 0.0),
        size,
        size,
        50f32.to_radians(),
    )
}

#[test]
fn extreme_scales_and_needles_match_the_reference() {
    let mut cloud = GaussianCloud::new(3);
    let c = [0.9, 0.4, 0.1];
    cloud.push([0.0, 0.0, 0.0], ID, [1e-8; 3], 1.0, &c);
    cloud.push([0.3, 0.0, 0.0], ID, [1e4; 3], 0.5, &c);
    cloud.push([-0.3, 0.1, 0.0], ID, [0.5, 5e-7, 5e-7], 0.9, &c); // 1e6 anisotropy
    cloud.push(
        [0.0, -0.3, 0.2],
        [FRAC_1_SQRT_2, FRAC_1_SQRT_2, 0.0, 0.0],
        [1e-6, 1.0, 1e-6],
        0.9,
        &c,
    );
    cloud.push(
        [0.1, 0.2, 0.0],
        [0.5, 0.5, 0.5, 0.5],
        [1e-3, 0.2, 0.2],
        1.0,
        &c,
    ); // edge-on disc
    let camera = front_camera(96);
    let mut r = renderer();
    let (gpu, stats) = r.render(&cloud, &camera, &[0.0; 3]).expect("fits");
    assert_all_finite(&gpu, "extreme scales");
    let (cpu, cpu_stats) = reference::render(&cloud, &camera, &[0.0; 3]);
    crate::common::assert_stats_match("extreme scales", &stats, &cpu_stats);
    let d = crate::common::diff(&gpu, &cpu);
    println!("extreme scales: {d:?} {stats:?}");
    // Needles make the 2D covariance nearly singular; f32 loses digits there, so only a loose bound.
    assert!(d.max_abs <= 2e-2, "{d:?}");
}

#[test]
fn gaussians_behind_on_and_at_the_camera_are_culled() {
    // Camera at the origin looking along +z, near plane at z = 0.2 (the reference's cull).
    let camera = Camera::from_fov_y(Mat4::IDENTITY, 64, 64, 1.0);
    let mut cloud = GaussianCloud::new(3);
    let c = [1.0; 3];
    cloud.push([0.0, 0.0, 0.0], ID, [0.1; 3], 1.0, &c); // at the camera centre
    cloud.push([0.0, 0.0, -1.0], ID, [0.1; 3], 1.0, &c); // behind
    cloud.push([0.0, 0.0, camera.near], ID, [0.1; 3], 1.0, &c); // exactly on the near plane
    cloud.push([0.05, 0.0, 0.1], ID, [0.1; 3], 1.0, &c); // between camera and near plane
    let mut r = renderer();
    let (image, stats) = r.render(&cloud, &camera, &[0.0; 3]).expect("fits");
    assert_eq!(stats.near, 4, "{stats:?}");
    assert_eq!(stats.visible, 0);
    assert!(
        image.features.iter().all(|v| *v == 0.0),
        "culled Gaussians must leave every pixel at the background"
    );
}

#[test]
fn zero_and_full_opacity() {
    let camera = front_camera(64);
    let mut cloud = GaussianCloud::new(3);
    cloud.push([0.0, 0.0, 0.0], ID, [0.3; 3], 0.0, &[1.0; 3]);
    cloud.push([0.0, 0.0, 0.5], ID, [0.3; 3], 1.0, &[0.5; 3]);
    let mut r = renderer();
    let (image, stats) = r.render(&cloud, &camera, &[0.0; 3]).expect("fits");
    assert_eq!((stats.transparent, stats.visible), (1, 1), "{stats:?}");
    // Opacity 1 is clamped to α = 0.99 at the centre.
    let centre = (32 * 64 + 32) as usize;
    assert!(
        (image.alpha[centre] - 0.99).abs() < 1e-5,
        "{}",
        image.alpha[centre]
    );
    assert_all_finite(&image, "opacity extremes");
}

#[test]
fn nan_and_inf_in_any_attribute_are_dropped_and_counted() {
    let base = BallCloud::new(50, 4, 9).generate();
    let mut cloud = base.clone();
    let bad = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY];
    let mut poisoned = 0;
    for (k, v) in bad.iter().enumerate() {
        let i = k * 12;
        cloud.positions[i][k] = *v;
        cloud.rotations[i + 1][k + 1] = *v;
        cloud.scales[i + 2][k] = *v;
        cloud.opacities[i + 3] = *v;
        cloud.features[(i + 4) * 4 + k] = *v;
        poisoned += 5;
    }
    let camera = front_camera(80);
    let mut r = renderer();
    let (image, stats) = r.render(&cloud, &camera, &[0.0; 4]).expect("fits");
    assert_all_finite(&image, "NaN/Inf input");
    assert_eq!(stats.nonfinite, poisoned, "{stats:?}");
    let (_, cpu_stats) = reference::render(&cloud, &camera, &[0.0; 4]);
    crate::common::assert_stats_match("NaN/Inf input", &stats, &cpu_stats);
}

#[test]
fn empty_cloud_renders_the_background() {
    let cloud = GaussianCloud::new(3);
    let mut r = renderer();
    let (image, stats) = r
        .render(&cloud, &front_camera(40), &[0.25, 0.5, 0.75])
        .expect("fits");
    assert_eq!(stats.visible, 0);
    assert!(image.plane(2).iter().all(|v| *v == 0.75));
    assert!(image.alpha.iter().all(|v| *v == 0.0));
}

#[test]
fn one_by_one_and_4096_square_outputs() {
    let cloud = BallCloud::new(2000, 3, 5).generate();
    let mut r = renderer();
    let (tiny, _) = r.render(&cloud, &front_camera(1), &[0.0; 3]).expect("fits");
    assert_all_finite(&tiny, "1×1");
    let (cpu, _) = reference::render(&cloud, &front_camera(1), &[0.0; 3]);
    assert!(crate::common::diff(&tiny, &cpu).max_abs < 1e-4);
    let (big, stats) = r
        .render(&cloud, &front_camera(4096), &[0.0; 3])
        .expect("fits");
    assert_eq!((big.width, big.height), (4096, 4096));
    assert_all_finite(&big, "4096²");
    assert!(stats.visible > 1900, "{stats:?}");
    assert!(big.alpha.iter().any(|a| *a > 0.5));
}

#[test]
fn one_million_gaussians() {
    let cloud = BallCloud::new(1_000_000, 3, 6).generate();
    let mut r = renderer();
    let (image, stats) = r
        .render(&cloud, &front_camera(256), &[0.0; 3])
        .expect("fits");
    assert_all_finite(&image, "1M Gaussians");
    assert_eq!(stats.visible + stats.culled(), 1_000_000);
    assert!(stats.visible > 900_000, "{stats:?}");
    assert_eq!(
        stats.tile_pairs, stats.tile_pairs_needed,
        "pair buffers must have grown to fit"
    );
    // A dense ball seen face-on is opaque in the middle.
    assert!(image.alpha[(128 * 256 + 128) as usize] > 0.99);
}

/// On a device whose storage bindings hold 8 MiB (any adapter's can be lowered to that), 64
/// channels of f32 make 32,768 Gaussians the most that fit: one more is refused by name, and the
/// renderer goes on working.
#[test]
fn a_cloud_too_big_for_the_adapter_is_an_error() {
    const BINDING: u64 = 8 << 20;
    let gpu = guava::gpu::GpuContext::headless_with(|limits| {
        limits.max_storage_buffer_binding_size = BINDING;
    })
    .expect("a Vulkan adapter");
    let mut r = guava::render::HeadlessRenderer::new(gpu);
    let limits = r.gpu.device.limits();
    assert_eq!(limits.max_storage_buffer_binding_size, BINDING);
    let max =
        guava::render::splatter::max_gaussians(&limits, 64, guava::render::FeatureStorage::F32);
    assert_eq!(max, BINDING / (64 * 4));
    let n = (max + 1) as usize;
    let mut cloud = GaussianCloud::new(64);
    cloud.positions = vec![[0.0; 3]; n];
    cloud.rotations = vec![ID; n];
    cloud.scales = vec![[0.01; 3]; n];
    cloud.opacities = vec![0.5; n];
    cloud.features = vec![0.5; n * 64];
    let err = r
        .render(&cloud, &front_camera(8), &[0.0; 64])
        .expect_err("must not fit");
    assert!(err.to_string().contains("do not fit"), "{err}");
    // One fewer fits, and the renderer still works afterwards.
    cloud.positions.pop();
    cloud.rotations.pop();
    cloud.scales.pop();
    cloud.opacities.pop();
    cloud.features.truncate((n - 1) * 64);
    assert!(r.render(&cloud, &front_camera(8), &[0.0; 64]).is_ok());
    let small = BallCloud::new(100, 3, 1).generate();
    assert!(r.render(&small, &front_camera(8), &[0.0; 3]).is_ok());
}

#[test]
fn stats_partition_the_input() {
    let mut spec = BallCloud::new(5000, 3, 8);
    spec.radius = 4.0; // many off-screen and some behind the camera
    spec.opacity_range = (0.0, 1.0);
    let cloud = spec.generate();
    let camera = Camera::from_fov_y(
        Mat4::from_translation(Vec3::new(0.0, 0.0, 2.0)),
        120,
        90,
        1.0,
    );
    let mut r = renderer();
    let (_, stats) = r.render(&cloud, &camera, &[0.0; 3]).expect("fits");
    assert_eq!(stats.visible + stats.culled(), stats.input);
    assert!(
        stats.near > 0 && stats.outside > 0 && stats.transparent > 0,
        "{stats:?}"
    );
    let (_, cpu) = reference::render(&cloud, &camera, &[0.0; 3]);
    crate::common::assert_stats_match("partition", &stats, &cpu);
}

#[test]
fn reused_buffers_give_identical_frames() {
    // Render a big cloud, then a smaller one into the same (larger) buffers, each several times:
    // nothing from an earlier frame or cloud may leak into a later one.
    let mut r = renderer();
    let camera = front_camera(128);
    let big = BallCloud::new(20_000, 3, 1).generate();
    let small = BallCloud::new(3_000, 3, 2).generate();
    let (first_big, stats_big) = r.render(&big, &camera, &[0.0; 3]).expect("fits");
    for cloud in [&small, &big, &small] {
        let (reference_image, reference_stats) = reference::render(cloud, &camera, &[0.0; 3]);
        for _ in 0..3 {
            let (image, stats) = r.render(cloud, &camera, &[0.0; 3]).expect("fits");
            crate::common::assert_stats_match("reused buffers", &stats, &reference_stats);
            assert!(crate::common::diff(&image, &reference_image).max_abs < 1e-3);
        }
    }
    let (again, stats_again) = r.render(&big, &camera, &[0.0; 3]).expect("fits");
    assert_eq!(
        (again, stats_again),
        (first_big, stats_big),
        "same input, same output, bit for bit"
    );
}

/// One splat filling a 4096² image (256² tiles) is listed in every tile and matches the
/// reference, in every tuning. Counting and listing its tiles one loop iteration per tile, the
/// 255th row reached llvmpipe's 65,535 iterations, where it leaves every loop of an invocation:
/// it got 65,025 tile pairs of 65,536 and its image was 31.9 dB from the reference, with nothing
/// said. Now a row is one iteration to count and eight tiles one to list (row_span, common.wgsl).
#[test]
fn a_splat_filling_the_image_is_in_every_tile() {
    let mut cloud = GaussianCloud::new(3);
    cloud.push([0.0; 3], ID, [3.0, 3.0, 0.01], 0.5, &[1.0, 0.5, 0.25]);
    let camera = front_camera(4096);
    let (cpu, _) = reference::render(&cloud, &camera, &[0.0; 3]);
    for mut r in crate::common::renderers() {
        let tuning = r.pipelines.tuning;
        let (gpu, stats) = r.render(&cloud, &camera, &[0.0; 3]).expect("fits");
        let d = crate::common::diff(&gpu, &cpu);
        println!("{tuning:?}: {} tile pairs, {d:?}", stats.tile_pairs);
        assert_eq!(stats.tile_pairs, 256 * 256, "{tuning:?}");
        assert!(
            d.max_abs <= 1e-3 && d.max_abs_alpha <= 1e-3,
            "{tuning:?}: {d:?}"
        );
    }
}
