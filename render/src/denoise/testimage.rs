//! A synthetic noisy render for the denoiser tests: a floor lit by an area light whose soft
//! shadow edge runs diagonally, under a wall, with an albedo edge down the floor. Each pixel's
//! lighting is a Monte Carlo estimate (light-sample visibility with `spp` samples), so the
//! noise has the statistics of a real render; the converged image is the exact expectation.

/// The noisy image, its guides and its expectation.
pub struct TestImage {
    pub width: u32,
    pub height: u32,
    pub noisy: Vec<[f32; 3]>,
    pub converged: Vec<[f32; 3]>,
    pub albedo: Vec<[f32; 3]>,
    pub normal: Vec<[f32; 3]>,
    /// The first column of the floor's brighter albedo.
    pub edge_x: usize,
}

/// Mean squared error over all channels.
pub fn mse(a: &[[f32; 3]], b: &[[f32; 3]]) -> f32 {
    let sum: f32 = a
        .iter()
        .zip(b)
        .map(|(p, q)| (0..3).map(|c| (p[c] - q[c]).powi(2)).sum::<f32>())
        .sum();
    sum / (3 * a.len()) as f32
}

impl TestImage {
    /// A `width × height` image estimated with `spp` samples per pixel.
    pub fn new(width: u32, height: u32, spp: u32) -> TestImage {
        let (w, h) = (width as usize, height as usize);
        let wall_rows = h / 3;
        let edge_x = w / 2;
        let mut state = 0x1234_5678u32;
        let mut random = move || {
            // xorshift32: enough for test noise.
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state as f32 / u32::MAX as f32
        };
        let mut img = TestImage {
            width,
            height,
            noisy: Vec::new(),
            converged: Vec::new(),
            albedo: Vec::new(),
            normal: Vec::new(),
            edge_x,
        };
        for y in 0..h {
            for x in 0..w {
                let (albedo, normal, visible) = if y < wall_rows {
                    ([0.5, 0.5, 0.5], [0.0, 0.0, 1.0], 0.6)
                } else {
                    let a = if x < edge_x {
                        [0.2, 0.25, 0.2]
                    } else {
                        [0.8, 0.7, 0.6]
                    };
                    // The fraction of the light seen from here: a soft ramp along a diagonal.
                    let s = (x as f32 - 0.4 * y as f32) / 12.0;
                    (a, [0.0, 1.0, 0.0], s.clamp(0.0, 1.0))
                };
                let hits = (0..spp).filter(|_| random() < visible).count() as f32;
                let estimate = 0.1 + 0.9 * hits / spp as f32;
                let expected = 0.1 + 0.9 * visible;
                img.noisy.push(albedo.map(|a| a * estimate));
                img.converged.push(albedo.map(|a| a * expected));
                img.albedo.push(albedo);
                img.normal.push(normal);
            }
        }
        img
    }
}
