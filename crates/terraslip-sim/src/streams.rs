//! One random stream per subsystem, derived from the seed.

use rand::rngs::StdRng;
use rand::SeedableRng;

/// One RNG stream per subsystem, so that e.g. switching the camera off does
/// not change the GNSS noise of a seed.
pub(crate) fn stream(seed: u64, name: &str) -> StdRng {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in name.bytes() {
        h = (h ^ b as u64).wrapping_mul(0x0100_0000_01b3);
    }
    StdRng::seed_from_u64(seed ^ h)
}
