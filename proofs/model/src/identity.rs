//! How a kernel state is identified: the behavioural hash of `Kernel<Fx>`,
//! the `Debug` text of `Kernel<f32>` without its tick counters.

use kernel::{Fx, Kernel, Scalar};
use std::fmt::Debug;
use std::hash::{Hash, Hasher};

/// The number types the model runs on: how a kernel state is identified.
pub(crate) trait ModelScalar: Scalar + Debug + Send + Sync + 'static {
    const NAME: &'static str;
    fn hash_kernel<H: Hasher>(k: &Kernel<Self>, h: &mut H);
}

impl ModelScalar for Fx {
    const NAME: &'static str = "Kernel<Fx>";
    fn hash_kernel<H: Hasher>(k: &Kernel<Self>, h: &mut H) {
        k.hash(h);
    }
}

impl ModelScalar for f32 {
    const NAME: &'static str = "Kernel<f32>";
    fn hash_kernel<H: Hasher>(k: &Kernel<Self>, h: &mut H) {
        // The Debug text from the per-axis state on, minus `tick: N` (the
        // tick counter and the fault timestamp; `boot_ticks`/`ticks` are
        // other fields and are kept).
        let text = format!("{k:?}");
        // The identity and the parameters (constants, most of the text)
        // come before the per-axis state `axes: [Axis {`.
        let mut rest = text.find("axes: [Axis {").map_or(text.as_str(), |i| &text[i..]);
        while let Some(i) = rest.find("tick: ") {
            let before = &rest[..i];
            let whole_word = !before.ends_with(|c: char| c.is_alphanumeric() || c == '_');
            before.hash(h);
            rest = &rest[i + "tick: ".len()..];
            if whole_word {
                rest = rest.trim_start_matches(|c: char| c.is_ascii_digit());
            } else {
                "tick: ".hash(h);
            }
        }
        rest.hash(h);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::MODEL_CONFIG;
    use kernel::config::AXES;
    use kernel::{EncoderSample, Sense};
    use proofs::setup::new_kernel;
    use std::hash::DefaultHasher;

    #[test]
    fn f32_state_identity_ignores_only_the_tick_counters() {
        let (mut a, _) = new_kernel::<f32>(&kernel::config::Validated::relaxed(MODEL_CONFIG));
        let mut b = a.clone();
        let h = |k: &Kernel<f32>| {
            let mut h = DefaultHasher::new();
            f32::hash_kernel(k, &mut h);
            h.finish()
        };
        let s = |c: u16| Sense {
            encoders: [EncoderSample::Count(c); AXES],
            limits: 0,
            hardware_fault: None,
            link_lost: false,
        };
        a.tick(&s(100), None);
        b.tick(&s(100), None);
        b.tick(&s(100), None); // one more tick, same state otherwise
        assert_eq!(h(&a), h(&b));
        let mut c = a.clone();
        c.tick(&s(101), None); // a different estimate
        assert_ne!(h(&a), h(&c));
    }
}
