//! A 10,000-frame sequence plays through without growing memory: live heap bytes, counted by a
//! wrapping allocator, are the same after a full pass as before it. Its own test binary, because
//! the allocator counts every thread of the process.
#![allow(unsafe_code)] // a GlobalAlloc wrapper is the only way to count heap bytes exactly

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicIsize, Ordering};

use guava::body::{BodyModel, BodyPose, PosedBody, SMPLX_JOINTS};
use guava::tracking::{BodyKind, Frame, Player, Retarget, Tracking};

struct Counting;

static LIVE: AtomicIsize = AtomicIsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        LIVE.fetch_add(layout.size() as isize, Ordering::Relaxed);
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        LIVE.fetch_sub(layout.size() as isize, Ordering::Relaxed);
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        LIVE.fetch_add(
            new_size as isize - layout.size() as isize,
            Ordering::Relaxed,
        );
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

#[test]
fn ten_thousand_frames_play_without_growing_memory() {
    let model = BodyModel::default_body().expect("default body");
    let frames = 10_000;
    let mut tracking = Tracking::new(
        BodyKind::Smplx,
        30.0,
        SMPLX_JOINTS.iter().map(|s| s.to_string()).collect(),
        (0..50).map(|i| format!("expression_{i:03}")).collect(),
    );
    for f in 0..frames {
        let a = (f as f32 * 0.01).sin();
        tracking.frames.push(Frame {
            translation: [0.0, 0.1 * a, 0.0],
            rotations: (0..55)
                .map(|j| [0.3 * a, 0.01 * j as f32, -0.2 * a])
                .collect(),
            values: vec![a; 50],
            camera: None,
        });
    }
    tracking.validate("memory test").expect("valid");
    let retarget = Retarget::new(&tracking, &model);
    let mut player = Player::new(&tracking);
    let mut pose = BodyPose::rest(&model);
    let mut posed = PosedBody::default();
    let mut play = |steps: usize| {
        for _ in 0..steps {
            player.advance(1.0 / 30.0);
            retarget.sample(&tracking, player.time(), &mut pose);
            model.pose(&pose, &mut posed).expect("pose");
        }
    };
    play(2); // first use sizes the reused buffers
    let before = LIVE.load(Ordering::Relaxed);
    play(frames + 10); // a full pass and a wrap-around
    let after = LIVE.load(Ordering::Relaxed);
    assert_eq!(
        after - before,
        0,
        "live heap grew by {} bytes",
        after - before
    );
    assert!(posed.vertices.iter().all(|v| v.is_finite()));
}
