//! The scalar operations the kernel's clamps rest on, at their edges.

/// `Scalar::min`/`max` on `f32` return the number when either operand is
/// NaN (IEEE minNum/maxNum), whichever side the NaN is on.
#[test]
fn f32_min_and_max_return_the_number_beside_a_nan_on_either_side() {
    use kernel::Scalar;
    assert_eq!(Scalar::max(f32::NAN, 1.0f32), 1.0);
    assert_eq!(Scalar::max(1.0f32, f32::NAN), 1.0);
    assert_eq!(Scalar::min(f32::NAN, 1.0f32), 1.0);
    assert_eq!(Scalar::min(1.0f32, f32::NAN), 1.0);
}
