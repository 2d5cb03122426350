//! The drivers' enable decision (`firmware::driver_enable::drivers_enabled`)
//! over the simulator's scenarios, tick by tick: every tick that commands a
//! speed has the drivers enabled, and the tick a fault or a soft stop is
//! latched already has them off.

use kernel::config::PAROL6_VALIDATED;
use kernel::State;
use sim::runner::{run, RunOptions};
use sim::scenario::builtin;

#[test]
fn the_driver_enable_decision_never_cuts_a_commanded_motion_and_drops_in_the_latching_tick() {
    let mut latched_seen = 0;
    for name in ["inverted-dir", "limit-hit", "encoder-loss", "runaway", "cable-pull", "startup-homing"] {
        let sc =
            builtin().unwrap().into_iter().find(|s| s.name == name).unwrap_or_else(|| panic!("no scenario {name}"));
        let r = run(&PAROL6_VALIDATED, &sc, &RunOptions::default(), &mut |_| {});
        assert!(r.trace.iter().any(|s| firmware::driver_enable::drivers_enabled(s.state)), "{name}: never enabled");
        for w in r.trace.windows(2) {
            let (before, s) = (w[0], w[1]);
            let on = firmware::driver_enable::drivers_enabled(s.state);
            assert!(
                on || s.v.iter().all(|&v| v == 0.0),
                "{name} t={} {:?}: a speed with the drivers off",
                s.t,
                s.state
            );
            let latches = matches!(s.state, State::Fault | State::SoftEstop) && before.state != s.state;
            if latches {
                assert!(!on, "{name} t={}: enabled in the latching tick", s.t);
                latched_seen += 1;
            }
        }
    }
    assert!(latched_seen >= 4, "only {latched_seen} latching ticks in the scenarios");
}
