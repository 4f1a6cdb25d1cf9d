//! Exact Euclidean distance transforms on a square pixel grid (Felzenszwalb & Huttenlocher 2012,
//! the lower envelope of parabolas, one pass over columns and one over rows), with the nearest
//! seed of every pixel; and the connected parts of a mask. Silhouette fitting and the Gaussians
//! made for what the body does not cover measure with them.

/// For every pixel of a `size`² grid, the squared distance to the nearest seed and that seed's
/// index (row-major); `None` where there is no seed at all.
pub fn nearest_seeds(seeds: &[bool], size: usize) -> Vec<Option<(f32, u32)>> {
    const FAR: f32 = f32::INFINITY;
    // Columns: the nearest seed in each column, by row.
    let mut column: Vec<(f32, u32)> = vec![(FAR, u32::MAX); size * size];
    let mut f = vec![FAR; size];
    let mut at = vec![u32::MAX; size];
    let (mut d, mut idx) = (vec![0.0; size], vec![u32::MAX; size]);
    for x in 0..size {
        for y in 0..size {
            let i = y * size + x;
            (f[y], at[y]) = if seeds[i] {
                (0.0, i as u32)
            } else {
                (FAR, u32::MAX)
            };
        }
        envelope(&f, &at, &mut d, &mut idx);
        for y in 0..size {
            column[y * size + x] = (d[y], idx[y]);
        }
    }
    // Rows: each pixel's nearest over its row of column results.
    let mut out = vec![None; size * size];
    for y in 0..size {
        for x in 0..size {
            (f[x], at[x]) = column[y * size + x];
        }
        envelope(&f, &at, &mut d, &mut idx);
        for x in 0..size {
            if d[x].is_finite() {
                out[y * size + x] = Some((d[x], idx[x]));
            }
        }
    }
    out
}

/// The 1D transform: `d[q] = min_p (q − p)² + f[p]`, with the minimising `p`'s label in `idx`.
fn envelope(f: &[f32], label: &[u32], d: &mut [f32], idx: &mut [u32]) {
    let n = f.len();
    let mut v = vec![0usize; n];
    let mut z = vec![0.0f32; n + 1];
    let mut k = 0usize;
    let first = (0..n).find(|&q| f[q].is_finite());
    let Some(first) = first else {
        d.fill(f32::INFINITY);
        idx.fill(u32::MAX);
        return;
    };
    v[0] = first;
    z[0] = f32::NEG_INFINITY;
    z[1] = f32::INFINITY;
    // Where parabola q overtakes parabola p.
    let cross = |q: usize, p: usize| {
        ((f[q] + (q * q) as f32) - (f[p] + (p * p) as f32)) / (2.0 * (q - p) as f32)
    };
    for (q, fq) in f.iter().enumerate().skip(first + 1) {
        if !fq.is_finite() {
            continue;
        }
        let mut s = cross(q, v[k]);
        // z[0] is −∞, so this stops at k = 0 at the latest.
        while s <= z[k] {
            k -= 1;
            s = cross(q, v[k]);
        }
        k += 1;
        v[k] = q;
        z[k] = s;
        z[k + 1] = f32::INFINITY;
    }
    let mut k = 0;
    for q in 0..n {
        while z[k + 1] < q as f32 {
            k += 1;
        }
        let p = v[k];
        d[q] = (q as f32 - p as f32).powi(2) + f[p];
        idx[q] = label[p];
    }
}

/// The connected parts (4-neighbours) of the pixels where `inside` is set, as a label per pixel
/// (`u32::MAX` outside) and each part's pixel count.
pub fn connected_parts(inside: &[bool], size: usize) -> (Vec<u32>, Vec<usize>) {
    connected_regions(size, size, |i| inside[i], |_, _| true)
}

/// The 4-neighbours of cell `i` of a `width × height` grid (row-major): left, right, up, down,
/// `None` past the grid's edge.
pub fn neighbours(i: usize, width: usize, height: usize) -> [Option<usize>; 4] {
    let (x, y) = (i % width, i / width);
    [
        (x > 0).then(|| i - 1),
        (x + 1 < width).then(|| i + 1),
        (y > 0).then(|| i - width),
        (y + 1 < height).then(|| i + width),
    ]
}

/// The connected parts of a `width × height` grid (row-major): cells where `inside` holds, two
/// 4-neighbours in one part where `joined` links them. A label per cell (`u32::MAX` outside) and
/// each part's cell count.
pub fn connected_regions(
    width: usize,
    height: usize,
    inside: impl Fn(usize) -> bool,
    joined: impl Fn(usize, usize) -> bool,
) -> (Vec<u32>, Vec<usize>) {
    let mut label = vec![u32::MAX; width * height];
    let mut sizes = Vec::new();
    let mut stack = Vec::new();
    for start in 0..width * height {
        if !inside(start) || label[start] != u32::MAX {
            continue;
        }
        let part = sizes.len() as u32;
        let mut count = 0;
        label[start] = part;
        stack.push(start);
        while let Some(i) = stack.pop() {
            count += 1;
            for j in neighbours(i, width, height).into_iter().flatten() {
                if inside(j) && label[j] == u32::MAX && joined(i, j) {
                    label[j] = part;
                    stack.push(j);
                }
            }
        }
        sizes.push(count);
    }
    (label, sizes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distances_and_nearest_seeds_are_exact() {
        let size = 23;
        let seed_at = [(3usize, 4usize), (17, 9), (10, 20), (0, 22)];
        let mut seeds = vec![false; size * size];
        for (x, y) in seed_at {
            seeds[y * size + x] = true;
        }
        let out = nearest_seeds(&seeds, size);
        for y in 0..size {
            for x in 0..size {
                let best = seed_at
                    .iter()
                    .map(|&(sx, sy)| {
                        (x as f32 - sx as f32).powi(2) + (y as f32 - sy as f32).powi(2)
                    })
                    .fold(f32::INFINITY, f32::min);
                let (d, at) = out[y * size + x].expect("a seed");
                assert_eq!(d, best, "({x}, {y})");
                let (sx, sy) = (at as usize % size, at as usize / size);
                assert_eq!(
                    (x as f32 - sx as f32).powi(2) + (y as f32 - sy as f32).powi(2),
                    best
                );
            }
        }
        assert!(nearest_seeds(&[false; 16], 4).iter().all(Option::is_none));
    }

    #[test]
    fn parts_are_found_with_their_sizes() {
        // Two blobs: a 3×3 square and a 1×2 bar, apart.
        let size = 8;
        let mut inside = vec![false; size * size];
        for y in 1..4 {
            for x in 1..4 {
                inside[y * size + x] = true;
            }
        }
        inside[6 * size + 6] = true;
        inside[6 * size + 7] = true;
        let (label, sizes) = connected_parts(&inside, size);
        assert_eq!(sizes, vec![9, 2]);
        assert_eq!(label[6 * size + 7], 1);
        assert_eq!(label[0], u32::MAX);
    }
}
