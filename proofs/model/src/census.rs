//! A census of the explored states (`--census`): how many unique states
//! each kernel state, homed mask and tuple of homing phases holds, and how
//! many were first reached after each number of ticks (where an
//! exploration still grows when it is stopped), to show
//! where a configuration's state space lies (the stream configuration's in
//! homing runs and, once homed, in the set-points' trajectories and
//! soft-stop ramps). Off unless asked for: it takes a lock per transition.

use crate::identity::ModelScalar;
use crate::state::St;
use std::collections::{BTreeMap, HashMap, HashSet};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;

/// Whether this run takes the census.
pub(crate) static ON: AtomicBool = AtomicBool::new(false);

/// The state fingerprints seen, by class (state, homed mask, phases), and
/// how many states were first reached after each number of ticks from
/// power-on, by kernel state. Sharded by fingerprint so the two exploring
/// threads rarely wait.
type Classes = HashMap<String, HashSet<u64>>;
type Levels = BTreeMap<(u32, String), usize>;
static SEEN: [Mutex<Option<(Classes, Levels)>>; 16] = [const { Mutex::new(None) }; 16];

/// A state's class: its kernel state, homed mask and each axis's homing
/// phase (two letters: `Wa`iting, `Fa`stSeek, `Ba`ckOff, `Sl`owSeek,
/// `Re`lease, `Se`ttle, `Do`ne, `Id`le).
fn class<S: ModelScalar>(n: &St<S>) -> String {
    let phases: Vec<String> = n.k.homing_phases().iter().map(|p| format!("{p:?}").chars().take(2).collect()).collect();
    format!("{:?} homed {:06b} phases {}", n.k.state(), n.k.homed(), phases.join(" "))
}

/// Counts the state `n` reached by a transition.
pub(crate) fn note<S: ModelScalar>(n: &St<S>) {
    if !ON.load(Ordering::Relaxed) {
        return;
    }
    let f = n.fingerprint();
    let Some(shard) = SEEN.get((f % 16) as usize) else { return };
    if let Ok(mut s) = shard.lock() {
        let (classes, levels) = s.get_or_insert_with(Default::default);
        if classes.entry(class(n)).or_default().insert(f) {
            *levels.entry((n.ticks, format!("{:?}", n.k.state()))).or_default() += 1;
        }
    }
}

/// Prints the census (the states first reached after each number of ticks,
/// unique states per kernel state, then the `top` largest classes) and
/// forgets it.
pub(crate) fn report(name: &str, cfg: &str, top: usize) {
    let mut classes: BTreeMap<String, usize> = BTreeMap::new();
    let mut levels: BTreeMap<u32, BTreeMap<String, usize>> = BTreeMap::new();
    for shard in &SEEN {
        if let Ok(mut s) = shard.lock() {
            let (shard_classes, shard_levels) = s.take().unwrap_or_default();
            for (c, set) in shard_classes {
                *classes.entry(c).or_default() += set.len();
            }
            for ((t, state), n) in shard_levels {
                *levels.entry(t).or_default().entry(state).or_default() += n;
            }
        }
    }
    // Where the exploration still grows: the states first reached after
    // each number of ticks, by kernel state.
    for (t, by) in &levels {
        println!("census {name} {cfg}: first reached after {t:>3} ticks: {by:?}");
    }
    let mut by_state: BTreeMap<&str, usize> = BTreeMap::new();
    for (c, n) in &classes {
        *by_state.entry(c.split(' ').next().unwrap_or("")).or_default() += n;
    }
    let total: usize = by_state.values().sum();
    println!("census {name} {cfg}: {total} unique states reached by a transition, by kernel state: {by_state:?}");
    let mut largest: Vec<(&String, &usize)> = classes.iter().collect();
    largest.sort_by(|a, b| b.1.cmp(a.1).then(a.0.cmp(b.0)));
    for (c, n) in largest.into_iter().take(top) {
        println!("census {name} {cfg}: {n:>9} {c}");
    }
}
