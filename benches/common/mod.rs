//! Inputs shared by the criterion benches: deterministic procedural textures (smooth value noise plus
//! grain) and an ω problem arranged like the real case (the intermediate tile is four quadrants of four
//! different crops, the candidate another crop).

use ndarray::{s, Array3};

/// An `h x w` RGB value-noise texture (cells of 12 pixels) with 20 % grain, from `seed`.
pub fn texture(h: usize, w: usize, seed: u64) -> Array3<f32> {
    let mut state = seed.wrapping_mul(0x9E3779B97F4A7C15) | 1;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    let cell = 12;
    let (gh, gw) = (h / cell + 2, w / cell + 2);
    let grid: Vec<[f32; 3]> = (0..gh * gw).map(|_| [next(), next(), next()]).collect();
    Array3::from_shape_fn((h, w, 3), |(y, x, c)| {
        let (fy, fx) = (y as f32 / cell as f32, x as f32 / cell as f32);
        let (iy, ix) = (fy as usize, fx as usize);
        let (ty, tx) = (fy - iy as f32, fx - ix as f32);
        let g = |a: usize, b: usize| grid[a * gw + b][c];
        let v = g(iy, ix) * (1.0 - ty) * (1.0 - tx)
            + g(iy + 1, ix) * ty * (1.0 - tx)
            + g(iy, ix + 1) * (1.0 - ty) * tx
            + g(iy + 1, ix + 1) * ty * tx;
        (0.8 * v + 0.2 * next()).clamp(0.0, 1.0)
    })
}

/// Intermediate tile I (four quadrants of four crops) and matching patch O (another crop), `n x n`.
pub fn omega_pair(n: usize) -> (Array3<f32>, Array3<f32>) {
    let ex = texture(2 * n + 8, 2 * n + 8, n as u64);
    let h = n / 2;
    let mut a = Array3::<f32>::zeros((n, n, 3));
    let corners = [(0, 0), (3, n + 5), (n + 2, 7), (n + 6, n + 1)];
    for (q, &(r, c)) in corners.iter().enumerate() {
        let (ty, tx) = ((q / 2) * h, (q % 2) * h);
        a.slice_mut(s![ty..ty + h, tx..tx + h, ..])
            .assign(&ex.slice(s![r..r + h, c..c + h, ..]));
    }
    let b = ex
        .slice(s![n / 3..n / 3 + n, n / 2..n / 2 + n, ..])
        .to_owned();
    (a, b)
}
