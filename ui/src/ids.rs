//! Ids for what the viewport uploads or re-renders by id (a cloud, an avatar, a body's topology,
//! a pose). Their own module: the parts that make such things need no path through the app.

use std::sync::atomic::{AtomicU64, Ordering};

/// A new id, unique for the whole process.
pub(crate) fn next_id() -> u64 {
    static NEXT: AtomicU64 = AtomicU64::new(1);
    NEXT.fetch_add(1, Ordering::Relaxed)
}
