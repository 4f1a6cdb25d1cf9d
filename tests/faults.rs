//! Faults while saving: the disk filling up part-way, the folder vanishing mid-write, a target
//! that cannot be written. Each is one error, no temporary file is left, and what was there
//! before is intact (`atomic_file::write_atomic`, which every save and export goes through).

use std::io::{self, Write};

use guava::atomic_file::write_atomic;

fn dir(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("guava-faults-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).expect("dir");
    d
}

#[test]
fn a_full_disk_leaves_the_previous_file_intact() {
    let d = dir("full");
    let path = d.join("avatar.guava");
    std::fs::write(&path, b"the previous avatar").expect("write");
    // The disk fills after 64 KiB of a 1 MiB file.
    let err = write_atomic(&path, |out| {
        for chunk in 0..16 {
            if chunk == 1 {
                return Err(io::Error::new(
                    io::ErrorKind::StorageFull,
                    "no space left on device",
                ));
            }
            out.write_all(&[7u8; 65536])?;
        }
        Ok(())
    })
    .expect_err("fails");
    assert_eq!(err.kind(), io::ErrorKind::StorageFull);
    assert_eq!(std::fs::read(&path).expect("read"), b"the previous avatar");
    assert_eq!(
        std::fs::read_dir(&d).expect("list").count(),
        1,
        "no temporary file left"
    );
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn a_folder_that_vanishes_mid_write_is_one_error() {
    let d = dir("vanish");
    let path = d.join("frame.png");
    let err = write_atomic(&path, |out| {
        out.write_all(b"half a frame")?;
        out.flush()?;
        std::fs::remove_dir_all(&d)?;
        out.write_all(b"the other half")
    });
    assert!(err.is_err());
    assert!(!d.exists() && !path.exists());
}

#[test]
fn a_target_that_cannot_be_written_keeps_what_is_there() {
    let d = dir("blocked");
    // A directory where the file should go: the rename over it fails (root included).
    let path = d.join("export.ply");
    std::fs::create_dir(&path).expect("a directory in the way");
    let err = write_atomic(&path, |out| out.write_all(b"splats"));
    assert!(err.is_err());
    assert!(path.is_dir(), "what was there is intact");
    assert_eq!(
        std::fs::read_dir(&d).expect("list").count(),
        1,
        "no temporary file left"
    );
    std::fs::remove_dir_all(&d).ok();
}
