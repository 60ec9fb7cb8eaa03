//! The benchmark's ray sets, as raybench's README defines them.
//!
//! - **Primary**: a `w × h` pinhole camera, 50° vertical field of view,
//!   at (0.35, 0.55, 2.45) looking at the origin with +y up; rays through
//!   pixel centres, in 4×4-pixel tiles (tiles row-major, pixels row-major
//!   inside a tile).
//! - **Incoherent**: origins uniform in `[-1.5, 1.5]³`, directions uniform
//!   on the unit sphere, from a SplitMix64 generator with a fixed seed
//!   (`0x5EED_0000 + n` for the cube-sphere of resolution `n`, as raybench).
//!
//! Every ray has `t_min = 0` and `t_max = ∞`. The f32 arithmetic follows
//! raybench's order, so for the cube-spheres the rays are bit-identical.
//!
//! Other meshes use the same rays in a [`Frame`]: the canonical setting
//! above (made for a mesh within about ±1.1) is scaled by the half of the
//! mesh's largest bounding-box side and moved to its bounding-box centre.
//! Directions are unchanged, so hit distances scale by the same factor.

/// A ray as every backend receives it: t from 0 to ∞.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BenchRay {
    /// Origin.
    pub o: [f32; 3],
    /// Unit direction.
    pub d: [f32; 3],
}

/// SplitMix64 (Steele, Lea and Flood 2014).
#[derive(Clone, Debug)]
pub struct SplitMix64(u64);

impl SplitMix64 {
    /// A generator with the given state.
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1) with 24 random bits.
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
    }
}

/// Where the canonical ray setting is placed: `world = center + scale * canonical`.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    /// Centre of the canonical origin.
    pub center: [f32; 3],
    /// Canonical-to-world scale.
    pub scale: f32,
}

impl Frame {
    /// The identity (the cube-spheres).
    pub const CANONICAL: Self = Self {
        center: [0.0; 3],
        scale: 1.0,
    };

    /// Centre of the bounds, and half of their largest side as the scale.
    pub fn fit(lo: [f32; 3], hi: [f32; 3]) -> Self {
        let half = (0..3).map(|k| 0.5 * (hi[k] - lo[k])).fold(0.0f32, f32::max);
        Self {
            center: [0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k])),
            scale: half,
        }
    }

    /// A canonical point in this frame.
    pub fn apply(&self, p: [f32; 3]) -> [f32; 3] {
        [0, 1, 2].map(|k| self.center[k] + self.scale * p[k])
    }

    fn place(&self, rays: &mut [BenchRay]) {
        if self.scale == 1.0 && self.center == [0.0; 3] {
            return;
        }
        for r in rays {
            r.o = self.apply(r.o);
        }
    }
}

fn normalize(v: [f32; 3]) -> [f32; 3] {
    let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    v.map(|c| c / len)
}

fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Primary rays of a `w × h` image (`w`, `h` multiples of 4).
pub fn primary(w: usize, h: usize, frame: Frame) -> Vec<BenchRay> {
    assert!(
        w.is_multiple_of(4) && h.is_multiple_of(4),
        "image size must be a multiple of 4"
    );
    let eye = [0.35f32, 0.55, 2.45];
    let forward = normalize(eye.map(|c| -c));
    let right = normalize(cross(forward, [0.0, 1.0, 0.0]));
    let up = cross(right, forward);
    let tan_y = (50.0f32.to_radians() * 0.5).tan();
    let tan_x = tan_y * (w as f32 / h as f32);
    let mut rays = Vec::with_capacity(w * h);
    for tile_y in (0..h).step_by(4) {
        for tile_x in (0..w).step_by(4) {
            for y in tile_y..tile_y + 4 {
                for x in tile_x..tile_x + 4 {
                    let sx = ((x as f32 + 0.5) / w as f32 * 2.0 - 1.0) * tan_x;
                    let sy = (1.0 - (y as f32 + 0.5) / h as f32 * 2.0) * tan_y;
                    let d = normalize([0, 1, 2].map(|k| forward[k] + sx * right[k] + sy * up[k]));
                    rays.push(BenchRay { o: eye, d });
                }
            }
        }
    }
    frame.place(&mut rays);
    rays
}

/// `count` incoherent rays (see the module docs).
pub fn incoherent(count: usize, seed: u64, frame: Frame) -> Vec<BenchRay> {
    let (lo, hi) = (-1.5f32, 1.5f32);
    let mut rng = SplitMix64::new(seed);
    let mut rays = Vec::with_capacity(count);
    for _ in 0..count {
        let o = [(); 3].map(|_| lo + (hi - lo) * rng.next_f32());
        let z = 1.0 - 2.0 * rng.next_f32();
        let phi = 2.0 * std::f32::consts::PI * rng.next_f32();
        let r = (1.0 - z * z).max(0.0).sqrt();
        let d = normalize([r * phi.cos(), r * phi.sin(), z]);
        rays.push(BenchRay { o, d });
    }
    frame.place(&mut rays);
    rays
}

/// Axis-aligned rays whose other two direction components are +0.0 or
/// −0.0 in every combination (24 directions), from `origins` points
/// uniform in the canonical box [-0.5, 0.5]³: a correctness probe for
/// traversal code that derives slab order from direction signs.
pub fn axis_aligned(origins: usize, frame: Frame) -> Vec<BenchRay> {
    let mut rng = SplitMix64::new(0xA715_0000);
    let mut rays = Vec::with_capacity(origins * 24);
    for _ in 0..origins {
        let o = frame.apply([(); 3].map(|_| rng.next_f32() - 0.5));
        for axis in 0..3 {
            for sign in [1.0f32, -1.0] {
                for zeros in [[0.0f32, 0.0], [-0.0, 0.0], [0.0, -0.0], [-0.0, -0.0]] {
                    let mut d = [0.0f32; 3];
                    d[axis] = sign;
                    d[(axis + 1) % 3] = zeros[0];
                    d[(axis + 2) % 3] = zeros[1];
                    rays.push(BenchRay { o, d });
                }
            }
        }
    }
    rays
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splitmix64_reference_values() {
        // First outputs for seed 0 (Vigna's reference implementation).
        let mut g = SplitMix64::new(0);
        assert_eq!(g.next_u64(), 0xE220_A839_7B1D_CDAF);
        assert_eq!(g.next_u64(), 0x6E78_9E6A_A1B9_65F4);
    }

    #[test]
    fn primary_rays_are_tiled_and_centred() {
        let rays = primary(8, 8, Frame::CANONICAL);
        assert_eq!(rays.len(), 64);
        // Ray 0 is pixel (0,0), ray 4 pixel (0,1), ray 16 pixel (4,0).
        let eye = [0.35f32, 0.55, 2.45];
        assert!(rays.iter().all(|r| r.o == eye));
        assert!(rays[0].d[0] < rays[16].d[0]);
        assert!(rays[0].d[1] > rays[4].d[1]);
        // The four central pixels surround the view axis symmetrically.
        let axis = normalize(eye.map(|c| -c));
        let centre: [f32; 3] = [27, 30, 33, 36]
            .iter()
            .fold([0.0; 3], |s, &i| [0, 1, 2].map(|k| s[k] + rays[i].d[k]));
        let c = normalize(centre);
        let dot: f32 = (0..3).map(|k| c[k] * axis[k]).sum();
        assert!(dot > 0.999_999, "{dot}");
    }

    #[test]
    fn incoherent_rays_fill_the_box_and_sphere() {
        let rays = incoherent(20_000, 7, Frame::CANONICAL);
        let mut mean = [0.0f64; 3];
        for r in &rays {
            assert!(r.o.iter().all(|&c| (-1.5..1.5).contains(&c)));
            let len: f32 = r.d.iter().map(|c| c * c).sum();
            assert!((len - 1.0).abs() < 1e-5);
            for (m, d) in mean.iter_mut().zip(r.d) {
                *m += f64::from(d) / rays.len() as f64;
            }
        }
        assert!(mean.iter().all(|m| m.abs() < 0.03), "{mean:?}");
    }

    #[test]
    fn axis_aligned_rays_cover_every_signed_zero() {
        let rays = axis_aligned(2, Frame::CANONICAL);
        assert_eq!(rays.len(), 48);
        let bits: std::collections::HashSet<[u32; 3]> =
            rays.iter().map(|r| r.d.map(f32::to_bits)).collect();
        assert_eq!(bits.len(), 24);
        assert!(rays
            .iter()
            .all(|r| r.d.iter().filter(|c| c.abs() == 1.0).count() == 1));
        assert!(rays[..24].iter().all(|r| r.o == rays[0].o));
    }

    #[test]
    fn frame_scales_origins_only() {
        let f = Frame::fit([0.0, 0.0, 0.0], [2.0, 1.0, 1.0]);
        assert_eq!(f.center, [1.0, 0.5, 0.5]);
        assert_eq!(f.scale, 1.0);
        let a = incoherent(4, 3, Frame::CANONICAL);
        let b = incoherent(4, 3, f);
        for (a, b) in a.iter().zip(&b) {
            assert_eq!(a.d, b.d);
            assert_eq!(b.o[0], a.o[0] + 1.0);
        }
    }
}
