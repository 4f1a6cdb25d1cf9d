//! Splat files in and out: 3DGS PLY round trips, files written the way the original 3DGS code
//! writes them, PlayCanvas's compressed PLY and antimatter15's `.splat` against PlayCanvas's own
//! decoder (splat-transform), and malformed files.

use guava::gaussians::ply::{self, SH_C0};
use guava::gaussians::synthetic::BallCloud;
use std::io::Cursor;
use std::path::{Path, PathBuf};

fn temp(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("guava-ply-{}-{name}", std::process::id()))
}

#[test]
fn round_trip_keeps_every_attribute() {
    for channels in [3, 32] {
        let mut cloud = BallCloud::new(500, channels, 11).generate();
        for q in &mut cloud.rotations {
            // Reading normalises quaternions (as 3DGS does); the generator already makes unit ones.
            let n = q.iter().map(|c| c * c).sum::<f32>().sqrt();
            q.iter_mut().for_each(|c| *c /= n);
        }
        let path = temp(&format!("rt{channels}.ply"));
        ply::write(&path, &cloud).expect("write");
        let back = ply::read(&path).expect("read");
        std::fs::remove_file(&path).ok();
        assert_eq!((back.len(), back.channels), (cloud.len(), channels));
        let close = |a: f32, b: f32, tol: f32| (a - b).abs() <= tol * b.abs().max(1.0);
        for i in 0..cloud.len() {
            assert_eq!(back.positions[i], cloud.positions[i]);
            for k in 0..3 {
                assert!(close(back.scales[i][k], cloud.scales[i][k], 1e-5));
            }
            for k in 0..4 {
                assert!(close(back.rotations[i][k], cloud.rotations[i][k], 1e-6));
            }
            assert!(close(back.opacities[i], cloud.opacities[i], 1e-5));
            for (a, b) in back.features_of(i).iter().zip(cloud.features_of(i)) {
                assert!(close(*a, *b, 1e-5), "{a} vs {b}");
            }
        }
    }
}

/// A file laid out like the original 3DGS `save_ply`: normals, 45 f_rest, logit opacity.
#[test]
fn reads_a_3dgs_style_file() {
    let mut header = String::from("ply\nformat binary_little_endian 1.0\nelement vertex 2\n");
    let mut names = vec![
        "x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2",
    ]
    .into_iter()
    .map(String::from)
    .collect::<Vec<_>>();
    names.extend((0..45).map(|i| format!("f_rest_{i}")));
    names.extend(
        [
            "opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3",
        ]
        .map(String::from),
    );
    for n in &names {
        header.push_str(&format!("property float {n}\n"));
    }
    header.push_str("end_header\n");
    let mut bytes = header.into_bytes();
    for v in 0..2 {
        let mut row = vec![0f32; names.len()];
        row[0] = v as f32;
        row[6] = 1.0; // f_dc_0
        row[54] = 0.0; // opacity logit → 0.5
        row[55] = (0.1f32).ln();
        row[56] = (0.2f32).ln();
        row[57] = (0.3f32).ln();
        row[58] = 2.0; // unnormalised quaternion (2, 0, 0, 0) → identity
        bytes.extend(row.iter().flat_map(|f| f.to_le_bytes()));
    }
    let cloud = ply::read_from(Cursor::new(bytes), Path::new("scene.ply")).expect("valid file");
    assert_eq!((cloud.len(), cloud.channels), (2, 3));
    assert_eq!(cloud.positions[1], [1.0, 0.0, 0.0]);
    assert!((cloud.features_of(0)[0] - (0.5 + SH_C0)).abs() < 1e-6);
    assert!((cloud.opacities[0] - 0.5).abs() < 1e-6);
    assert!((cloud.scales[0][2] - 0.3).abs() < 1e-6);
    assert_eq!(cloud.rotations[0], [1.0, 0.0, 0.0, 0.0]);
}

#[test]
fn ascii_files_read_too() {
    let text = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n\
        property float f_dc_0\nproperty float f_dc_1\nproperty float f_dc_2\nproperty float opacity\n\
        property float scale_0\nproperty float scale_1\nproperty float scale_2\nproperty float rot_0\n\
        property float rot_1\nproperty float rot_2\nproperty float rot_3\nend_header\n\
        1 2 3 0 0 0 0 0 0 0 1 0 0 0\n";
    let cloud = ply::read_from(Cursor::new(text), Path::new("a.ply")).expect("ascii");
    assert_eq!(cloud.positions[0], [1.0, 2.0, 3.0]);
    assert_eq!(cloud.features_of(0), [0.5, 0.5, 0.5]);
}

#[test]
fn malformed_files_name_the_file_and_the_problem() {
    let cases: &[(&str, &[u8], &str)] = &[
        ("empty.ply", b"", "header ends"),
        ("notply.ply", b"hello\n", "not a PLY file"),
        ("noformat.ply", b"ply\nelement vertex 1\nproperty float x\nend_header\n", "format"),
        (
            "missing.ply",
            b"ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\nend_header\n",
            "`y` is missing",
        ),
        ("badcount.ply", b"ply\nformat ascii 1.0\nelement vertex lots\nend_header\n", "not a number"),
    ];
    for (name, bytes, expect) in cases {
        let err = ply::read_from(Cursor::new(bytes.to_vec()), Path::new(name))
            .expect_err(name)
            .to_string();
        assert!(err.contains(name) && err.contains(expect), "{name}: {err}");
    }
    // Truncated binary data.
    let path = temp("trunc.ply");
    let cloud = BallCloud::new(10, 3, 1).generate();
    ply::write(&path, &cloud).expect("write");
    let bytes = std::fs::read(&path).expect("read back");
    std::fs::write(&path, &bytes[..bytes.len() - 7]).expect("truncate");
    let err = ply::read(&path).expect_err("truncated").to_string();
    std::fs::remove_file(&path).ok();
    assert!(
        err.contains("truncated") && err.contains("vertex 9"),
        "{err}"
    );
    // A missing file.
    let err = ply::read(Path::new("/nonexistent/x.ply"))
        .expect_err("missing")
        .to_string();
    assert!(err.contains("/nonexistent/x.ply"), "{err}");
}

#[test]
fn writing_never_leaves_a_partial_file() {
    let path = temp("atomic.ply");
    let cloud = BallCloud::new(100, 3, 2).generate();
    ply::write(&path, &cloud).expect("write");
    assert!(
        !path.with_extension("ply.tmp").exists(),
        "the temporary file is renamed away"
    );
    let first = std::fs::read(&path).expect("read");
    // A failing write (into a directory that does not exist) leaves nothing behind.
    assert!(ply::write(Path::new("/nonexistent/dir/x.ply"), &cloud).is_err());
    ply::write(&path, &cloud).expect("overwrite");
    assert_eq!(std::fs::read(&path).expect("read"), first);
    std::fs::remove_file(&path).ok();
}

fn splat_transform_fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/splat_transform")
        .join(name)
}

/// tools/make_splat_file_fixtures.py compressed 1,000 random Gaussians with degree-1 SH into
/// four chunks (the last partial) with PlayCanvas's splat-transform, and had it decode the file
/// back to the standard layout. Our reading of the compressed file must match that decoding.
/// Both decode in f64 and round once to f32; what differs is where the standard file's logit,
/// log-scale and SH DC are activated in f32, so 2e-6 relative (a few f32 ulps) bounds it.
#[test]
fn compressed_files_read_as_playcanvas_decodes_them() {
    let ours = ply::read(&splat_transform_fixture("cloud.compressed.ply")).expect("compressed");
    let theirs = ply::read(&splat_transform_fixture("decoded.ply")).expect("decoded");
    assert_eq!((ours.len(), ours.channels), (1000, 3));
    assert_eq!((theirs.len(), theirs.channels), (1000, 3));
    let close = |a: f32, b: f32| (a - b).abs() <= 2e-6 * b.abs().max(1.0);
    let mut distinct_opacities = std::collections::BTreeSet::new();
    for i in 0..ours.len() {
        let pairs = [
            (&ours.positions[i][..], &theirs.positions[i][..]),
            (&ours.rotations[i][..], &theirs.rotations[i][..]),
            (&ours.scales[i][..], &theirs.scales[i][..]),
            (&ours.opacities[i..=i], &theirs.opacities[i..=i]),
            (ours.features_of(i), theirs.features_of(i)),
        ];
        for (a, b) in pairs {
            assert!(
                a.iter().zip(b).all(|(x, y)| close(*x, *y)),
                "splat {i}: {a:?} vs {b:?}"
            );
        }
        distinct_opacities.insert(ours.opacities[i].to_bits());
    }
    // The fixture is not degenerate: opacities span the 8-bit range.
    assert!(
        distinct_opacities.len() > 100,
        "{}",
        distinct_opacities.len()
    );
}

#[test]
fn malformed_compressed_files_name_the_problem() {
    let bytes = std::fs::read(splat_transform_fixture("cloud.compressed.ply")).expect("fixture");
    let header_end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .expect("header")
        + 11;
    let header = std::str::from_utf8(&bytes[..header_end]).expect("ASCII header");
    let with_header = |h: String| [h.as_bytes(), &bytes[header_end..]].concat();
    let cases = [
        (
            "fewchunks.compressed.ply",
            with_header(header.replace("element chunk 4", "element chunk 3")),
            "element `chunk` has 3 rows",
        ),
        (
            "nobound.compressed.ply",
            with_header(header.replace("property float max_b\n", "property float max_q\n")),
            "chunk property `max_b` is missing",
        ),
        (
            "nocolour.compressed.ply",
            with_header(header.replace(
                "property uint packed_color\n",
                "property uint packed_rgba\n",
            )),
            "vertex property `packed_color` is missing",
        ),
        (
            "trunc.compressed.ply",
            // Cut inside the vertices: the SH element after them is 9 bytes a splat.
            bytes[..bytes.len() - 9 * 1000 - 5].to_vec(),
            "file ends at vertex 999 of 1000: truncated",
        ),
    ];
    for (name, file, expect) in cases {
        let err = ply::read_from(Cursor::new(file), Path::new(name))
            .expect_err(name)
            .to_string();
        assert!(err.contains(name) && err.contains(expect), "{name}: {err}");
    }
}

/// 256 random Gaussians packed into antimatter15's `.splat` by tools/make_splat_file_fixtures.py
/// (as his converter packs them), read by `gaussians::read_file`, against the source cloud and
/// against splat-transform's decoding of the same file.
#[test]
fn dot_splat_files_read_within_their_quantisation() {
    let ours =
        guava::gaussians::read_file(&splat_transform_fixture("cloud.splat")).expect(".splat");
    let source = ply::read(&splat_transform_fixture("splat_source.ply")).expect("source");
    let theirs = ply::read(&splat_transform_fixture("splat_decoded.ply")).expect("decoded");
    assert_eq!((ours.len(), ours.channels), (256, 3));
    assert_eq!((theirs.len(), source.len()), (256, 256));
    let near = |a: &[f32], b: &[f32], tol: f32| a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol);
    for i in 0..ours.len() {
        // Positions and scales are f32 in the file: exact (scales up to the source's exp in f32).
        assert_eq!(ours.positions[i], source.positions[i], "splat {i}");
        assert!(near(
            &ours.scales[i],
            &source.scales[i],
            1e-6 * source.scales[i][0].max(1.0)
        ));
        // Colour and opacity are truncated to 1/255 steps; colours beyond [0, 1] are clipped.
        let colour: Vec<f32> = source
            .features_of(i)
            .iter()
            .map(|c| c.clamp(0.0, 1.0))
            .collect();
        for (got, want) in ours.features_of(i).iter().zip(&colour) {
            assert!(
                (0.0..=1.0 / 255.0 + 1e-6).contains(&(want - got)),
                "splat {i}: {got} vs {want}"
            );
        }
        let opacity_lost = source.opacities[i] - ours.opacities[i];
        assert!(
            (0.0..=1.0 / 255.0 + 1e-6).contains(&opacity_lost),
            "splat {i}: {opacity_lost}"
        );
        // Each quaternion component is truncated to 1/128 before normalising: 2/128 bounds it.
        assert!(
            near(&ours.rotations[i], &source.rotations[i], 2.0 / 128.0),
            "splat {i}"
        );

        // splat-transform decodes the same bytes: identical but for f32 activation rounding and
        // its opacity clamp to [1e-6, 1 − 1e-6]; its rotations are b/127.5 − 1 where antimatter15's
        // viewer (and we) take (b − 128)/128, which differ by under 0.01 once normalised.
        assert!(
            near(ours.features_of(i), theirs.features_of(i), 2e-6),
            "splat {i}"
        );
        assert!(
            near(&ours.opacities[i..=i], &theirs.opacities[i..=i], 2e-6),
            "splat {i}"
        );
        assert!(near(
            &ours.scales[i],
            &theirs.scales[i],
            2e-6 * ours.scales[i][0].max(1.0)
        ));
        assert!(
            near(&ours.rotations[i], &theirs.rotations[i], 0.01),
            "splat {i}"
        );
    }
    // A file that is not whole records names the problem.
    let path = temp("cut.splat");
    let bytes = std::fs::read(splat_transform_fixture("cloud.splat")).expect("fixture");
    std::fs::write(&path, &bytes[..bytes.len() - 5]).expect("write");
    let err = guava::gaussians::read_file(&path)
        .expect_err("cut")
        .to_string();
    std::fs::remove_file(&path).ok();
    assert!(
        err.contains("cut.splat") && err.contains("not a whole number of 32-byte splats"),
        "{err}"
    );
}

/// Standard 3DGS files shade as 3DGS shades them: each Gaussian's colour is clamped at 0 before
/// blending (`computeColorFromSH`), on the GPU and in the f64 reference alike (dark regions of
/// published scenes were up to ~60/255 darker); GUAVA's feature clouds (files with `feat_*`
/// channels) keep what they store.
#[test]
fn standard_files_clamp_colour_at_zero_as_3dgs_does() {
    use glam::Mat4;
    use guava::camera::Camera;
    use guava::gaussians::GaussianCloud;
    use guava::render::reference;

    let path = temp("dark.ply");
    let mut dark = GaussianCloud::new(3);
    dark.push(
        [0.0, 0.0, 3.0],
        [1.0, 0.0, 0.0, 0.0],
        [0.3; 3],
        0.9,
        &[-0.3, 0.5, 1.2],
    );
    ply::write(&path, &dark).expect("write");
    let read = ply::read(&path).expect("read");
    let rgb = read.features_of(0);
    assert!(rgb[0] == 0.0 && (rgb[1] - 0.5).abs() < 1e-6 && (rgb[2] - 1.2).abs() < 1e-5);

    // Over white, the clamped red adds nothing: red = 1 − α wherever the Gaussian covers.
    let camera = Camera::from_fov_y(Mat4::IDENTITY, 32, 32, 0.8);
    let background = [1.0; 3];
    let (exact, _) = reference::render(&read, &camera, &background);
    let (gpu, _) = crate::common::renderer()
        .render(&read, &camera, &background)
        .expect("renders");
    let centre = 16 * 32 + 16;
    assert!(exact.alpha[centre] > 0.8);
    for (name, image) in [("reference", &exact), ("GPU", &gpu)] {
        let red = image.plane(0);
        let worst = (0..red.len())
            .map(|i| (red[i] - (1.0 - image.alpha[i])).abs())
            .fold(0.0f32, f32::max);
        assert!(worst < 1e-3, "{name}: red departs from 1 − α by {worst}");
    }

    // A feature cloud's channels are not colours to clamp.
    let mut features = GaussianCloud::new(4);
    features.push(
        [0.0; 3],
        [1.0, 0.0, 0.0, 0.0],
        [0.3; 3],
        0.9,
        &[-0.3, 0.5, 1.2, -2.0],
    );
    ply::write(&path, &features).expect("write");
    let read = ply::read(&path).expect("read");
    assert!((read.features_of(0)[0] + 0.3).abs() < 1e-6 && read.features_of(0)[3] == -2.0);
    std::fs::remove_file(&path).ok();
}
