//! Smooth scalar curves for procedural motion. Every helper is C1 (continuous first derivative),
//! so clips built from sums and products of them have no velocity jumps.

use std::f32::consts::PI;

/// 3u^2 - 2u^3 on [0, 1], clamped outside: C1 with zero slope at both ends.
pub fn smoothstep(u: f32) -> f32 {
    let u = u.clamp(0.0, 1.0);
    u * u * (3.0 - 2.0 * u)
}

/// Smooth ramp from 0 (t <= t0) to 1 (t >= t1).
pub fn ramp(t: f32, t0: f32, t1: f32) -> f32 {
    smoothstep((t - t0) / (t1 - t0))
}

/// Smooth bump: 0 outside [t0, t1], sin^2 rising to 1 at the middle and back (C1 at the ends).
pub fn bump(t: f32, t0: f32, t1: f32) -> f32 {
    if t <= t0 || t >= t1 {
        return 0.0;
    }
    let s = (PI * (t - t0) / (t1 - t0)).sin();
    s * s
}

/// Smooth plateau: ramps up over [t0, t1], holds 1, ramps down over [t2, t3].
pub fn plateau(t: f32, t0: f32, t1: f32, t2: f32, t3: f32) -> f32 {
    ramp(t, t0, t1) * (1.0 - ramp(t, t2, t3))
}

/// Periodic oscillation sin(2 pi t / period + phase).
pub fn osc(t: f32, period: f32, phase: f32) -> f32 {
    (2.0 * PI * t / period + phase).sin()
}

/// Fade-in/fade-out envelope over a clip of `duration` seconds: reaches 1 after `edge` seconds,
/// back to 0 at the end. Used so periodic clips start and end near their base pose.
pub fn envelope(t: f32, duration: f32, edge: f32) -> f32 {
    plateau(t, 0.0, edge, duration - edge, duration)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn derivative(f: impl Fn(f32) -> f32, t: f32) -> f32 {
        let h = 1e-3;
        (f(t + h) - f(t - h)) / (2.0 * h)
    }

    #[test]
    fn helpers_hit_their_end_values_with_zero_slope() {
        assert_eq!(smoothstep(0.0), 0.0);
        assert_eq!(smoothstep(1.0), 1.0);
        assert!((bump(0.5, 0.0, 1.0) - 1.0).abs() < 1e-6);
        for t in [0.0f32, 1.0] {
            assert!(derivative(|x| ramp(x, 0.0, 1.0), t).abs() < 5e-3);
            assert!(derivative(|x| bump(x, 0.0, 1.0), t).abs() < 2e-2);
        }
        assert!((plateau(1.5, 0.0, 1.0, 2.0, 3.0) - 1.0).abs() < 1e-6);
        assert_eq!(envelope(0.0, 3.0, 0.5), 0.0);
        assert!(envelope(3.0, 3.0, 0.5).abs() < 1e-6);
    }
}
