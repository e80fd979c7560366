//! Seeded random streams. Every draw in lasercal comes from a `ChaCha8Rng` whose seed is derived
//! from (scenario seed, purpose, trial index), so a trial's numbers never depend on thread count,
//! sharding or the order trials run in.

use rand::SeedableRng;
pub use rand_chacha::ChaCha8Rng as Rng;

/// A standard normal draw.
pub fn gauss(r: &mut Rng) -> f64 {
    use rand::RngExt;
    r.sample(rand_distr::StandardNormal)
}

/// SplitMix64 finaliser: a fast, well-mixed 64-bit hash.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Derive a child seed from a parent seed and a path of integers (purpose tag, trial index, ...).
pub fn derive(seed: u64, path: &[u64]) -> u64 {
    path.iter().fold(mix(seed), |acc, &p| mix(acc ^ mix(p)))
}

/// A generator for (seed, path).
pub fn stream(seed: u64, path: &[u64]) -> Rng {
    Rng::seed_from_u64(derive(seed, path))
}

/// Purpose tags, so that e.g. the noise of trial 7 and the pose jitter of trial 7 are independent.
pub mod tag {
    pub const TRIAL: u64 = 1;
    pub const SENSOR_NOISE: u64 = 2;
    pub const CHORD_NOISE: u64 = 3;
    pub const ROBOT_ERROR: u64 = 4;
    pub const VIBRATION: u64 = 5;
    pub const SPECIMEN: u64 = 6;
    pub const PLAN: u64 = 7;
    pub const GRID_POINT: u64 = 8;
    pub const PLACEMENT: u64 = 9;
}

/// A text's 64-bit FNV-1a hash: stable across platforms and versions, for seeds derived from
/// names or values (a grid point's).
pub fn text_hash(text: &str) -> u64 {
    text.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}
