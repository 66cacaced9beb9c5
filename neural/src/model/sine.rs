//! The branch-free scalar sine and cosine of the SIRENs' evaluation and of the training
//! path's portable loops (`train::kernel` has the same on 16 lanes).

/// Sine and cosine without branches (so loops over it vectorise): x = k pi + r with
/// |r| <= pi/2 (Cody-Waite, pi in two parts), Taylor polynomials of r to degrees 11 and 12
/// (truncation below 6e-8), and the sign of (-1)^k. Accurate to a few ulps for |x| < 1e5; a
/// SIREN's pre-activations stay far inside that.
#[inline(always)]
pub fn sin_cos(x: f32) -> (f32, f32) {
    const ROUND: f32 = 12_582_912.0; // 1.5 * 2^23: adding it rounds to an integer
    const PI_HI: f32 = 3.140_625; // exact in 8 bits, so k * PI_HI is exact
    #[allow(clippy::excessive_precision)] // the digits of pi - PI_HI
    const PI_LO: f32 = 9.676_535_5e-4; // pi - PI_HI
    let shifted = x * std::f32::consts::FRAC_1_PI + ROUND;
    let k = shifted - ROUND;
    let odd = shifted.to_bits() << 31; // the parity of k, moved to the sign bit
    let r = (x - k * PI_HI) - k * PI_LO;
    let r2 = r * r;
    let sin_r = r + r
        * r2
        * (-1.0 / 6.0
            + r2 * (1.0 / 120.0
                + r2 * (-1.0 / 5040.0 + r2 * (1.0 / 362_880.0 + r2 * (-1.0 / 39_916_800.0)))));
    let cos_r = 1.0
        + r2 * (-0.5
            + r2 * (1.0 / 24.0
                + r2 * (-1.0 / 720.0
                    + r2 * (1.0 / 40_320.0
                        + r2 * (-1.0 / 3_628_800.0 + r2 * (1.0 / 479_001_600.0))))));
    (f32::from_bits(sin_r.to_bits() ^ odd), f32::from_bits(cos_r.to_bits() ^ odd))
}
