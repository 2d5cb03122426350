//! The boot's length forgotten: an exact merge of states that differ only
//! in how many ticks the kernel spent in Boot.
//!
//! The kernel counts its Boot ticks (`boot_ticks`, toward the boot timeout)
//! and keeps the count after Boot, and its `Hash` includes it. Nothing reads
//! the count outside Boot: the boot step reads it only while the mode is
//! Boot, and no transition enters Boot again. So two kernels that differ
//! only in it (and in the tick counter, which only labels reports) have the
//! same future: the same outputs, events and status on every input
//! sequence (`kernel/tests/boot_count.rs` tests it). Without the merge each
//! boot length (J1's encoder lost in zero, one or two Boot ticks) gave a
//! copy of every state reached after it.
//!
//! On the transition that leaves Boot the model replaces the kernel by the
//! one a boot of a single tick reaches (a clone of the initial kernel,
//! ticked once with the same tick's readings and request, or `<HOME>` for a
//! home queued earlier), when, and only when, its `Debug` text (every
//! field) equals the kernel's but for those two counters. Otherwise the
//! kernel is kept as it is: no merge. A boot that ends by its timeout
//! (the fault `EncoderNotReady`) is never matched, and keeps its count.

use crate::identity::ModelScalar;
use std::sync::atomic::AtomicBool;

/// `--no-merges`: the model without its two own merges (this one and the
/// enable flag marking only the state an accepted enable reached: it is
/// kept from the first enable on instead), so the figures measured without
/// them can be regenerated; a run with it checks the same properties on
/// more states.
pub(crate) static OFF: AtomicBool = AtomicBool::new(false);
use crate::model::Supervisor;
use kernel::{Kernel, Request, Sense};

/// `text` without the values of the fields `tick` (the counter and the
/// fault's timestamp) and `boot_ticks`.
pub(crate) fn without_counters(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(i) = rest.find("tick") {
        let before = &rest[..i];
        out.push_str(before);
        let after = &rest[i..];
        let whole_word = !before.ends_with(|c: char| c.is_alphanumeric() || c == '_');
        let key = ["tick: ", "ticks: "].into_iter().find(|k| after.starts_with(k));
        let boot = out.ends_with("boot_");
        match key {
            Some(k) if (whole_word && k == "tick: ") || (boot && k == "ticks: ") => {
                out.push_str(k);
                rest = after[k.len()..].trim_start_matches(|c: char| c.is_ascii_digit());
            }
            _ => {
                out.push_str("tick");
                rest = &after["tick".len()..];
            }
        }
    }
    out.push_str(rest);
    out
}

impl<S: ModelScalar> Supervisor<S> {
    /// The kernel a boot of one tick reaches with `sense` and `req` (or
    /// `<HOME>`), if it equals `k` but for the two counters; `None` if no
    /// such boot matches (then `k` is kept).
    pub(crate) fn short_boot(&self, k: &Kernel<S>, sense: &Sense, req: Option<Request<S>>) -> Option<Kernel<S>> {
        let want = without_counters(&format!("{k:?}"));
        [req, Some(Request::Home)].into_iter().find_map(|r| {
            let mut c = self.init.clone();
            c.tick(sense, r);
            (without_counters(&format!("{c:?}")) == want).then_some(c)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::environment::Perturb;
    use crate::model::supervisor;
    use kernel::{Fx, State};

    /// A boot lengthened by J1's lost encoder is matched by the one-tick
    /// boot (the merge happens), with or without a queued `<HOME>`; a boot
    /// ended by its timeout is not.
    #[test]
    fn a_longer_boot_is_merged_and_a_timed_out_one_is_not() {
        let m = supervisor::<Fx>("full");
        let still = m.sense(Perturb::None, 0);
        let lost = m.sense(Perturb::LostJ1, 0);
        for (queued, ticks) in [(None, 1), (None, 2), (Some(Request::Home), 2)] {
            let mut k = m.init.clone();
            k.tick(&lost, queued);
            for _ in 1..ticks {
                k.tick(&lost, None);
            }
            assert_eq!(k.state(), State::Boot);
            k.tick(&still, None);
            assert_ne!(k.state(), State::Boot);
            let c = m.short_boot(&k, &still, None).expect("a one-tick boot matches");
            assert_eq!(without_counters(&format!("{c:?}")), without_counters(&format!("{k:?}")));
            assert_ne!(format!("{c:?}"), format!("{k:?}"), "the boot count differs");
        }
        let mut k = m.init.clone();
        while k.state() == State::Boot {
            k.tick(&lost, None);
        }
        assert_eq!(k.state(), State::Fault);
        assert!(m.short_boot(&k, &lost, None).is_none());
    }

    #[test]
    fn only_the_two_counters_are_dropped() {
        let t = "Kernel { tick: 12, axes: [Axis { homing: AxisHoming { ticks: 3, rest: 1 } }], boot_ticks: 2, since_cmd: 1, fault: Some(Fault { reason: X, tick: 9 }) }";
        assert_eq!(
            without_counters(t),
            "Kernel { tick: , axes: [Axis { homing: AxisHoming { ticks: 3, rest: 1 } }], boot_ticks: , since_cmd: 1, fault: Some(Fault { reason: X, tick:  }) }"
        );
        // A field whose name only contains the word keeps its value.
        assert_eq!(
            without_counters("since_tick: 4, ticks: 5, tick_hz: 1000"),
            "since_tick: 4, ticks: 5, tick_hz: 1000"
        );
    }
}
