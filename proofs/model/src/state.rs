//! A model state: the kernel and the little of the plant the properties need.

use crate::identity::ModelScalar;
use kernel::config::AXES;
use kernel::{Kernel, Scalar};
use std::hash::{DefaultHasher, Hash, Hasher};

/// The J1 encoder as seen by the plant: the count it was (re)initialised
/// from (every other count differs by more than the plausibility window),
/// and the current run of invalid samples (frozen one above the limit: the
/// count is lost until an enable re-initialises J1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) struct J1 {
    pub(crate) seen: bool,
    pub(crate) reference: u16,
    pub(crate) run: u8,
}

#[derive(Clone, Debug)]
pub(crate) struct St<S: Scalar> {
    pub(crate) k: Kernel<S>,
    /// The transition checks violated on the way into this state (a bit per
    /// `Check`; checked on every transition, so no history is needed).
    pub(crate) violated: u64,
    /// The transition into this state accepted an enable (for reachability
    /// only: the property "enable accepted" holds in some reachable state
    /// exactly when some explored transition accepted an enable, as a flag
    /// kept from then on would say, without doubling every state reached
    /// after the first enable).
    pub(crate) enabled: bool,
    pub(crate) j1: J1,
    /// The soft-stop ramp: its tick (1 on the timeout tick) and the outputs
    /// it started from.
    pub(crate) ramp: Option<(u32, [S; AXES])>,
    /// The transition into this state completed a homing group one of
    /// whose axes had finished (`Done`) before it and waited, at rest, for
    /// a sibling still moving (for reachability only: the kernel's future
    /// does not depend on it).
    pub(crate) group_waited: bool,
    /// The set-points move toward the 2 mrad target (`Req::MotionFar`): a
    /// motion toward it was the last accepted and they are not yet at
    /// rest. Decided by the kernel's state (its set-points' targets, which
    /// its `Hash` includes, and whether they rest), so hashing it adds no
    /// state; it decides which targets `Supervisor::choices` offers.
    pub(crate) far: bool,
    /// Ticks from power-on on the path that reached this state (for the
    /// census only: not part of the state's identity, so a state keeps the
    /// count of the path that reached it first, the shortest under
    /// `--depth`'s one-thread breadth-first search).
    pub(crate) ticks: u32,
}

impl<S: ModelScalar> St<S> {
    pub(crate) fn fingerprint(&self) -> u64 {
        let mut h = DefaultHasher::new();
        self.hash(&mut h);
        h.finish()
    }
}

impl<S: ModelScalar> Hash for St<S> {
    fn hash<H: Hasher>(&self, h: &mut H) {
        S::hash_kernel(&self.k, h);
        (self.violated, self.enabled, self.j1, self.group_waited, self.far).hash(h);
        // The ramp's start equals the kernel's Stopping v0 (hashed above);
        // its tick is the kernel's k + 1.
        self.ramp.map(|(k, _)| k).hash(h);
    }
}

impl<S: ModelScalar> PartialEq for St<S> {
    fn eq(&self, other: &Self) -> bool {
        self.fingerprint() == other.fingerprint()
    }
}
