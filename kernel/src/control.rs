//! The control law `v = v_ff + Kp * (p_cmd - p_est)`, saturated.

use crate::scalar::Scalar;

/// Computes the velocity command and whether every input and the raw result
/// were finite. A non-finite anything gives exactly zero (and `false`, which
/// the supervisor turns into a fault); otherwise the result is saturated to
/// `[-vmax, vmax]` and speeds below `deadband` become zero.
#[inline]
pub fn control_law<S: Scalar>(setpoint: S, ff: S, estimate: S, kp: S, vmax: S, deadband: S) -> (S, bool) {
    let e = setpoint.minus(estimate);
    let raw = ff.plus(kp.times(e));
    let ok = setpoint.is_finite() && ff.is_finite() && estimate.is_finite() && raw.is_finite();
    let v = raw.saturate(vmax);
    let v = S::select(v.abs() < deadband, S::ZERO, v);
    (S::select(ok, v, S::ZERO), ok)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scalar::Fx;

    #[test]
    fn law_and_saturation() {
        let (v, ok) = control_law(1.0f32, 0.5, 0.9, 5.0, 3.0, 0.0);
        assert!(ok && (v - 1.0).abs() < 1e-6, "{v}");
        assert_eq!(control_law(10.0f32, 0.0, 0.0, 5.0, 3.0, 0.0), (3.0, true));
        assert_eq!(control_law(-10.0f32, 0.0, 0.0, 5.0, 3.0, 0.0), (-3.0, true));
        assert_eq!(control_law(0.0f32, 0.01, 0.0, 5.0, 3.0, 0.02), (0.0, true));
        // Exactly at the deadband the output passes (only below is zeroed).
        assert_eq!(control_law(0.0f32, 0.25, 0.0, 5.0, 3.0, 0.25), (0.25, true));
        assert_eq!(control_law(0.0f32, -0.25, 0.0, 5.0, 3.0, 0.25), (-0.25, true));
    }

    #[test]
    fn nan_and_infinity_give_zero_and_not_ok() {
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            assert_eq!(control_law(bad, 0.0, 0.0, 5.0, 3.0, 0.0), (0.0, false));
            assert_eq!(control_law(0.0, bad, 0.0, 5.0, 3.0, 0.0), (0.0, false));
            assert_eq!(control_law(0.0, 0.0, bad, 5.0, 3.0, 0.0), (0.0, false));
        }
        // inf - inf inside the law
        assert_eq!(control_law(f32::MAX, f32::MAX, -f32::MAX, 5.0, 3.0, 0.0), (0.0, false));
    }

    #[test]
    fn fixed_point_extremes_saturate() {
        let (v, ok) = control_law(Fx::MAX, Fx::MAX, Fx::MIN, Fx::from_num(5), Fx::from_num(3), Fx::ZERO);
        assert!(ok);
        assert_eq!(v, Fx::from_num(3));
    }
}
