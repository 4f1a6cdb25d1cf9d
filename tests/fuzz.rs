//! Every parser a user can feed, fed mangled files: valid seeds of each format (made here or
//! shipped) with bytes flipped, cut, repeated, spliced in and numbers in headers swapped for
//! hostile ones. Each must return (an error or a value), never panic, and allocate nothing in
//! proportion to a size a file merely claims. `PROPTEST_CASES` sets the cases per parser (64 in
//! the normal run; e.g. `PROPTEST_CASES=20000 cargo test --test integration fuzz::` for a longer
//! search); failures proptest finds are saved under `proptest-regressions/` and replayed first.

use std::io::Cursor;
use std::path::Path;
use std::sync::OnceLock;

use proptest::prelude::*;

use crate::npz_writer::{npy_f32, npz};

/// The seed files: one or more valid files per format.
struct Seeds {
    ply: Vec<Vec<u8>>,
    splat: Vec<u8>,
    tracking: Vec<u8>,
    arkit: Vec<u8>,
    npz: Vec<u8>,
    npy: Vec<u8>,
    avatar: Vec<u8>,
    glb: Vec<u8>,
    ehm: Vec<u8>,
    photos: Vec<Vec<u8>>,
    onnx: Vec<Vec<u8>>,
}

fn seeds() -> &'static Seeds {
    static SEEDS: OnceLock<Seeds> = OnceLock::new();
    SEEDS.get_or_init(|| {
        let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/splat_transform");
        let read = |p: &Path| std::fs::read(p).expect("seed file");
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let dir = std::env::temp_dir().join(format!("guava-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let knot = dir.join("knot.ply");
        guava::gaussians::ply::write(&knot, &guava::gaussians::synthetic::torus_knot(20, 1))
            .expect("write");
        let ascii = b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n\
            property float z\nproperty float f_dc_0\nproperty float f_dc_1\nproperty float f_dc_2\n\
            property float opacity\nproperty float scale_0\nproperty float scale_1\n\
            property float scale_2\nproperty float rot_0\nproperty float rot_1\nproperty float rot_2\n\
            property float rot_3\nend_header\n0 0 0 1 0 0 0 -2 -2 -2 1 0 0 0\n1 2 3 0 1 0 2 -1 -1 -1 0 1 0 0\n"
            .to_vec();
        let avatar_path = dir.join("tiny.guava");
        tiny_avatar().save(&avatar_path).expect("save avatar");
        let seeds = Seeds {
            ply: vec![read(&knot), ascii, read(&data.join("cloud.compressed.ply"))],
            splat: read(&data.join("cloud.splat"))[..32 * 20].to_vec(),
            tracking: read(&Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/demo_portrait.json")),
            arkit: b"Timecode,BlendShapeCount,JawOpen,EyeBlinkLeft\n00:00:00:00,2,0.5,0.1\n00:00:00:01,2,0.6,0.0\n"
                .to_vec(),
            npz: npz(&[
                ("global_orient", npy_f32(&[2, 3], &[0.1; 6])),
                ("body_pose", npy_f32(&[2, 63], &[0.0; 126])),
                ("transl", npy_f32(&[2, 3], &[0.0; 6])),
                ("betas", npy_f32(&[10], &[0.0; 10])),
                ("expression", npy_f32(&[2, 10], &[0.2; 20])),
            ]),
            npy: npy_f32(&[2, 3], &[0.5; 6]),
            avatar: read(&avatar_path),
            glb: read(&Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/anny_body.glb")),
            ehm: read(&root.join("tests/data/ehm_synthetic.npz")),
            // A photo without alpha, and one whose alpha is a person mask.
            photos: vec![read(&root.join("tests/data/demo_portrait_128.png")), masked_png()],
            // The default refiner, and GUAVA's reduced refiner (each checked as it loads).
            onnx: vec![
                read(&root.join("assets/refiner/default_refiner.onnx")),
                read(&root.join("tests/data/guava_onnx/guava_refiner.onnx")),
            ],
        };
        std::fs::remove_dir_all(&dir).ok();
        seeds
    })
}

/// A 24² RGBA PNG whose alpha marks a disc (a person mask).
fn masked_png() -> Vec<u8> {
    let image = image::RgbaImage::from_fn(24, 24, |x, y| {
        let inside = (x as f32 - 12.0).hypot(y as f32 - 12.0) < 8.0;
        image::Rgba([200, 120, 90, if inside { 255 } else { 0 }])
    });
    let mut png = Vec::new();
    image
        .write_to(&mut Cursor::new(&mut png), image::ImageFormat::Png)
        .expect("png");
    png
}

/// `bytes` written to a file of its own (the parsers under test read paths), removed after.
fn with_file<T>(bytes: &[u8], name: &str, read: impl FnOnce(&Path) -> T) -> T {
    use std::sync::atomic::{AtomicUsize, Ordering};
    static NEXT: AtomicUsize = AtomicUsize::new(0);
    let path = std::env::temp_dir().join(format!(
        "guava-fuzz-{}-{}-{name}",
        std::process::id(),
        NEXT.fetch_add(1, Ordering::Relaxed)
    ));
    std::fs::write(&path, bytes).expect("temp file");
    let out = read(&path);
    std::fs::remove_file(&path).ok();
    out
}

/// A two-Gaussian avatar of a three-vertex body: enough structure for every field of the file.
fn tiny_avatar() -> guava::avatar::Avatar {
    use guava::avatar::{Avatar, AvatarKind, LocalGaussians, UvGaussians};
    let local = |n: usize| LocalGaussians {
        rotations: vec![[1.0, 0.0, 0.0, 0.0]; n],
        scales: vec![[0.01; 3]; n],
        opacities: vec![0.9; n],
        features: vec![0.5; 4 * n],
    };
    Avatar {
        kind: AvatarKind::DefaultReconstruction,
        body: "tiny".into(),
        body_vertices: 3,
        body_triangles: 1,
        channels: 4,
        identity: Default::default(),
        ehm_identity: None,
        source: "fuzz seed".into(),
        source_view: None,
        displacements: vec![0.01, 0.0, 0.02],
        template: local(3),
        uv: UvGaussians {
            triangles: vec![0, 0],
            barycentrics: vec![[0.3, 0.3, 0.4]; 2],
            offsets: vec![[0.0; 3]; 2],
            local: local(2),
        },
        skinned: Default::default(),
        outside: 0,
    }
}

/// One way to damage a file.
#[derive(Clone, Debug)]
enum Damage {
    Flip {
        at: usize,
        byte: u8,
    },
    Cut {
        at: usize,
    },
    Insert {
        at: usize,
        bytes: Vec<u8>,
    },
    Repeat {
        at: usize,
        len: usize,
    },
    /// The first run of decimal digits at or after `at` becomes `number` (a count in a header).
    Number {
        at: usize,
        number: u64,
    },
}

fn damage() -> impl Strategy<Value = Damage> {
    let hostile = prop_oneof![
        Just(0u64),
        Just(1u64 << 31),
        Just(u32::MAX as u64),
        Just(u64::MAX),
        any::<u64>()
    ];
    prop_oneof![
        (any::<usize>(), any::<u8>()).prop_map(|(at, byte)| Damage::Flip { at, byte }),
        any::<usize>().prop_map(|at| Damage::Cut { at }),
        (any::<usize>(), prop::collection::vec(any::<u8>(), 1..16))
            .prop_map(|(at, bytes)| Damage::Insert { at, bytes }),
        (any::<usize>(), 1usize..64).prop_map(|(at, len)| Damage::Repeat { at, len }),
        (any::<usize>(), hostile).prop_map(|(at, number)| Damage::Number { at, number }),
    ]
}

fn apply(seed: &[u8], damages: &[Damage]) -> Vec<u8> {
    let mut b = seed.to_vec();
    for d in damages {
        let n = b.len().max(1);
        match d {
            Damage::Flip { at, byte } => {
                if !b.is_empty() {
                    b[at % n] ^= byte;
                }
            }
            Damage::Cut { at } => b.truncate(at % n),
            Damage::Insert { at, bytes } => {
                let at = (at % n).min(b.len());
                b.splice(at..at, bytes.iter().copied());
            }
            Damage::Repeat { at, len } => {
                let at = (at % n).min(b.len());
                let end = (at + len).min(b.len());
                let copy = b[at..end].to_vec();
                b.splice(end..end, copy);
            }
            Damage::Number { at, number } => {
                let start = at % n;
                if let Some(i) = (start..b.len()).find(|&i| b[i].is_ascii_digit()) {
                    let j = (i..b.len())
                        .find(|&j| !b[j].is_ascii_digit())
                        .unwrap_or(b.len());
                    b.splice(i..j, number.to_string().bytes());
                }
            }
        }
    }
    b
}

fn damaged(seed: &'static [u8]) -> impl Strategy<Value = Vec<u8>> {
    prop::collection::vec(damage(), 1..4).prop_map(move |d| apply(seed, &d))
}

fn config() -> ProptestConfig {
    // 64 cases per parser unless PROPTEST_CASES says otherwise; regressions are replayed.
    ProptestConfig {
        cases: std::env::var("PROPTEST_CASES")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(64),
        ..ProptestConfig::default()
    }
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn ply_files(bytes in (0usize..3).prop_flat_map(|k| damaged(&seeds().ply[k]))) {
        let _ = guava::gaussians::ply::read_from(Cursor::new(bytes), Path::new("fuzz.ply"));
    }

    #[test]
    fn splat_files(bytes in damaged(&seeds().splat)) {
        let _ = guava::gaussians::splat::decode(&bytes);
    }

    #[test]
    fn tracking_files(bytes in damaged(&seeds().tracking)) {
        let _ = guava::tracking::Tracking::from_json(&bytes, "fuzz.json");
    }

    #[test]
    fn arkit_csv_files(bytes in damaged(&seeds().arkit)) {
        let _ = guava::tracking::import::parse_arkit_csv(&String::from_utf8_lossy(&bytes), "fuzz.csv");
    }

    #[test]
    fn npz_archives(bytes in damaged(&seeds().npz)) {
        if let Ok(npz) = guava::npz::Npz::read(Cursor::new(&bytes), "fuzz.npz") {
            for name in ["global_orient", "body_pose", "transl", "betas", "expression"] {
                let _ = npz.f32s(name, &[None, None]);
                let _ = npz.shape(name);
            }
        }
    }

    #[test]
    fn npy_arrays(bytes in damaged(&seeds().npy)) {
        let _ = guava::npz::parse_npy(&bytes);
    }

    #[test]
    fn avatar_files(bytes in damaged(&seeds().avatar)) {
        let _ = guava::avatar::Avatar::from_bytes(&bytes, "fuzz.guava");
    }

    #[test]
    fn glb_body_templates(bytes in damaged(&seeds().glb)) {
        let _ = guava::body::BodyModel::from_glb(&bytes, "fuzz.glb");
    }

    #[test]
    fn ehm_bodies(bytes in damaged(&seeds().ehm)) {
        if let Ok(npz) = guava::npz::Npz::read(Cursor::new(&bytes), "fuzz_ehm.npz") {
            let _ = guava::body::EhmModel::from_opened(&npz, Path::new("fuzz_ehm.npz"));
        }
    }

    /// Decoding is the image crate's; orientation, the alpha-as-mask rule, the square crop
    /// (any crop a tracking file may claim) and the person mask are ours.
    #[test]
    fn photos_crops_and_masks(
        bytes in (0usize..2).prop_flat_map(|k| damaged(&seeds().photos[k])),
        left in any::<i32>(), top in any::<i32>(), side in prop_oneof![0u32..300, any::<u32>()],
    ) {
        use guava::photo::{Crop, SourceImage};
        if let Ok((image, alpha)) = with_file(&bytes, "photo.png", SourceImage::decode) {
            let _ = SourceImage::from_rgba_at(&image, None, alpha, "fuzz.png", 64);
            let crop = Crop { left, top, side: side.min(4096) };
            if let Ok(photo) = SourceImage::from_rgba_at(&image, Some(crop), alpha, "fuzz.png", 32)
                && let Some(mut mask) = photo.mask
            {
                guava::photo::keep_person(&mut mask, 32);
            }
        }
    }

    /// Model files go through ONNX Runtime's own parser first, then our checks.
    #[test]
    fn refiner_models(bytes in (0usize..2).prop_flat_map(|k| damaged(&seeds().onnx[k]))) {
        let runtime = guava::onnx::OnnxRuntime::load().expect("ONNX Runtime");
        let _ = with_file(&bytes, "model.onnx", |p| guava::refine::Refiner::load(runtime, p));
    }

    /// Our own reader and WGSL compiler take the same damaged files: an error, never a panic
    /// or an invalid GPU call (wgpu's handler panics on those); what compiles also runs.
    #[test]
    fn refiner_models_for_the_wgsl_passes(
        bytes in (0usize..2).prop_flat_map(|k| damaged(&seeds().onnx[k]))
    ) {
        let gpu = crate::common::shared_gpu();
        if let Ok(mut refiner) =
            with_file(&bytes, "model.onnx", |p| guava::refine::Refiner::load_wgsl(gpu, p))
        {
            let _ = refiner.refine(&guava::render::SplatImage::new(9, 7, 4));
        }
    }
}

/// Sizes a file claims but does not hold are refused before anything that size is allocated:
/// each of these would ask for terabytes (or overflow) if believed.
#[test]
fn hostile_sizes_allocate_nothing_large() {
    // A PLY header claiming 2³¹ vertices, with none.
    let ply =
        b"ply\nformat binary_little_endian 1.0\nelement vertex 2147483648\nproperty float x\n\
        property float y\nproperty float z\nend_header\n";
    let err = guava::gaussians::ply::read_from(Cursor::new(ply.to_vec()), Path::new("big.ply"));
    assert!(err.is_err());
    // An .npy array whose shape overflows, and one whose dtype is cut short.
    for header in [
        "{'descr': '<f4', 'fortran_order': False, 'shape': (4611686018427387904, 4611686018427387904), }",
        "{'descr': '<f4', 'fortran_order': False, 'shape': (18446744073709551615,), }",
        "{'descr': 'f', 'fortran_order': False, 'shape': (1,), }",
        "{'descr': '', 'fortran_order': False, 'shape': (1,), }",
    ] {
        let mut npy = b"\x93NUMPY\x01\x00".to_vec();
        npy.extend_from_slice(&(header.len() as u16).to_le_bytes());
        npy.extend_from_slice(header.as_bytes());
        npy.extend_from_slice(&[0u8; 16]);
        assert!(guava::npz::parse_npy(&npy).is_err(), "{header}");
    }
    // An .npz entry whose directory claims 2⁴⁰ bytes uncompressed.
    let mut archive = npz(&[("a", npy_f32(&[1], &[1.0]))]);
    let directory = archive
        .windows(4)
        .rposition(|w| w == b"PK\x01\x02")
        .expect("central directory");
    // Uncompressed size: offset 24 in a central directory header (a u32; with a ZIP64 extra
    // it would be 64-bit: here the largest u32 a header can claim).
    archive[directory + 24..directory + 28].copy_from_slice(&u32::MAX.to_le_bytes());
    let _ = guava::npz::Npz::read(Cursor::new(&archive), "big.npz");
}
