//! Model check of the supervisor and homing state machine, with stateright,
//! over the real `kernel::Kernel` (`cargo run -p model --release`).
//!
//! ```text
//! model [--variant fx|f32] [--config full|stream|small|tiny|homing] [--expect-violation NAME] [--timeout S] [--bounded S] [--depth D] [--census] [--coupling] [--no-merges] [--no-far] [--homing-restricted]
//! ```
//!
//! With no arguments: the full configuration over `Kernel<Fx>` (to
//! completion: every reachable state), the stream configuration over
//! `Kernel<Fx>` (bounded by `--bounded S` seconds or `--depth D`, which
//! apply to the stream configuration only), the small
//! and the homing configurations over `Kernel<Fx>` (to completion), then
//! the tiny configuration over `Kernel<f32>` (to
//! completion) (its states are identified by formatting them, about 25
//! times slower per state than the fixed-point hash; the small
//! configuration takes over 10 minutes in f32). `--expect-violation NAME`
//! is for the mutation tests (`mutants.sh`): it stops at, and succeeds only
//! on, a violation of a property whose name contains NAME.
//! `--census` prints how many unique states each kernel state, homed mask
//! and tuple of homing phases holds, and how many states, by kernel state,
//! were first reached after each number of ticks from power-on (`census`).
//! `--coupling` checks the homing group's coupling lemma on every explored
//! transition without a request or perturbation and fails unless it held
//! on every one and the run finished (`coupling`).
//! `--no-merges` turns off the model's own two merges (`boot`: the Boot
//! tick count, and the enable flag kept from the first enable on), to
//! regenerate the figures measured without them.
//! `--no-far` runs the full configuration without its 2 mrad target, to
//! show the `sometimes` properties that need it fail there;
//! `--homing-restricted` gives it the stream configuration's alphabet
//! during homing (with both, it is the full configuration with only its
//! 20 urad targets and that alphabet, whose figures `README.md` gives).
//!
//! Properties: each transition check (`checks!`) and each state property is
//! a property of its own, named by the requirements it checks (`SR-5: a
//! latch left without an accepted enable`); SAFETY.md's rows name them. A
//! transition check applies where its antecedent holds; a run lists as
//! backing evidence (`model.tsv`) only the state properties and the checks
//! whose antecedent held on some explored transition, and prints the
//! others as not exercised.
//!
//! Abstraction (stated so a reviewer can judge it):
//! - The arm is stationary: every encoder reads a constant count, so the
//!   observer's numeric state is constant and each reachable kernel state is
//!   one of finitely many. What the model varies, independently at every
//!   tick, is everything discrete: which of the seeking homing axes reach
//!   their switches (each axis independently, so every order of arrivals
//!   within a group is explored; a switch releases as soon as its axis
//!   backs off); one sensor perturbation (none,
//!   J1 encoder lost, J1 encoder glitch, a hardware fault of each kind, a
//!   stray pressed switch on J1 or J6); and one request (none, home,
//!   per-joint home of J1 / J6 / a bad index, enable, two valid motion
//!   targets, a target 10 mrad beyond J1's limit). The valid targets are
//!   the homed arm's positions and, on every joint, a point below them:
//!   20 urad below in the full configuration (`model::NEAR_LANDING`: a
//!   motion toward it lands in one tick, so the set-points take finitely
//!   many values), 2 mrad in the others (`model::NEAR_STREAM`: a motion
//!   accelerates, cruises and brakes over several ticks; the full
//!   configuration offers it too, as a third target, under the restriction
//!   below). Only J1's encoder and
//!   the J1 and J6 switches are perturbed: every joint is checked by the
//!   same per-axis code, which `evidence_tests::every_joint_is_checked_like_j1_and_j6`
//!   shows joint by joint. A cause that persists is the same choice on consecutive
//!   ticks. The plant keeps only what the SR-7 and SR-11 properties need
//!   (the ramp's start, the J1 run of invalid samples).
//! - Configuration (`MODEL_CONFIG`): `PAROL6` with the timers shortened
//!   within `kernel::config::check` (command timeout 3 ms, segments 1 ms,
//!   boot timeout 2 ms: the kernel keeps its boot tick count in its state
//!   after boot, so each boot length multiplied the state space) and three
//!   documented relaxations, tested by
//!   `config::tests::model_config_relaxes_exactly_the_named_rules`: zero homing
//!   back-off (a stationary arm never travels one), 8 ms homing timeouts
//!   (the shortest with which a run homes,
//!   `config::tests::the_homing_timeout_is_the_shortest_that_homes`; J4's
//!   is 9 ms in the homing configuration) and a
//!   4 ms soft-stop ramp (faster than `max_acceleration`, PAROL6's).
//! - Full configuration (`--config full`, the default): `MODEL_CONFIG`,
//!   the whole alphabet above, to completion, and a third valid target
//!   2 mrad below the homed arm (`Req::MotionFar`: a motion toward it
//!   accelerates, cruises and brakes over 20 ticks, longer than the 3 ms
//!   command timeout). Its restriction beyond the others' is the
//!   re-targeting of a moving set-point: the 2 mrad target is offered only
//!   while the set-points are at rest or already move toward it, and the
//!   20 urad ones (which land within two ticks) not while they do, so no
//!   moving set-point is re-targeted by 2 mrad (what keeps the stream
//!   configuration from finishing); `proofs/model/README.md`, "The full
//!   configuration: finite by its targets". It requires the command
//!   timeout's soft stop of a moving arm, SoftEstop, and a cruising and a
//!   braking set-point (`sometimes` properties); `--no-far
//!   --homing-restricted` (the full configuration with the 20 urad targets
//!   only and the stream configuration's alphabet during homing) fails
//!   those four.
//! - Stream configuration (`--config stream`): the full one with the
//!   2 mrad target. The set-points' positions and velocities toward the
//!   two targets, re-targeted on any tick, and the soft-stop ramps from
//!   each, keep it from finishing: the test command runs it bounded
//!   (`--depth 44`: every path of up to 42 ticks from power-on; sampled
//!   evidence). `--census` shows where its states lie (SAFETY.md gives
//!   the figures).
//! - During homing, where every request is refused and changes nothing
//!   but the tick's events
//!   (`model::tests::a_request_during_homing_changes_nothing_but_the_events`),
//!   the full and stream configurations offer only no request and one
//!   motion request. The stream configuration, to fit its time budget,
//!   draws only four perturbations there (none, J1 lost, a tick overrun,
//!   J6 stray switch); the full one every perturbation but the J1 glitch
//!   and the J1 stray switch (so every hardware fault kind): a restriction,
//!   those two multiply the homing states past the run's budget.
//! - Reduced configuration (`--config small`, used for the f32 variant and
//!   the mutation tests): requests none / home / enable / near target /
//!   beyond J1's limit only,
//!   the switches of the seeking axes arriving all together or not at all,
//!   every perturbation in every state. The two configurations together
//!   cover every arrival order and every perturbation during homing, not
//!   every combination of the two.
//! - Tiny configuration (`--config tiny`, the f32 variant): the small one
//!   with six perturbations (none, J1 lost, each of the three hardware
//!   fault kinds, J6 stray switch; not the J1 glitch and the J1 stray
//!   switch). The small configuration draws only the tick overrun; the full
//!   one every kind in every state, the stream one every kind outside
//!   homing.
//! - Homing configuration (`--config homing`): requests none / home /
//!   per-joint home of J1, J4, J5, J6 / enable, every subset of the seeking
//!   axes' switches on every tick (every arrival order), perturbations none
//!   and a tick overrun (to leave a run by a fault and an enable). With the
//!   small one it gives complete runs for every arrival order and
//!   `<HOMEn>` (SR-13, SR-14, SR-16). Its arm (`HOMING_MODEL_CONFIG`) gives
//!   J4 a 9 ms homing timeout, one tick more than J5's (on the arm the
//!   timeouts of a group's joints differ with their ranges): with equal
//!   shortest timeouts an axis that finishes after its sibling has run out
//!   of time, so a finished axis waits only toward a homing timeout; here
//!   J5 also waits, `Done` and stepped at rest, for a J4 whose switch came
//!   a tick late, and the group then completes (the `sometimes` property
//!   "a finished homing axis waited for its group, which then completed";
//!   `config::tests::a_late_j4_completes_its_group_while_j5_waits`). The
//!   property "SR-14/16: a finished homing axis moved, left Done or faulted
//!   while its group was still moving" checks every such wait.
//! - States are identified by `Kernel`'s behavioural hash (everything but the
//!   tick counter and the fault timestamp, which no decision reads, and the
//!   run record of a homing axis in `Idle` or `Done`, which nothing reads
//!   there before a new run overwrites it: an exact merge, argued and
//!   tested as `README.md` describes) plus the plant. Two more exact
//!   merges are the model's own: the kernel that leaves Boot is replaced by
//!   the one a boot of one tick reaches when they differ only in the Boot
//!   tick count, which nothing reads after Boot ([`boot`],
//!   `kernel/tests/boot_count.rs`), and the flag of an accepted enable is
//!   kept only on the state the enable reached (the `sometimes` property
//!   "enable accepted" needs no more). `Kernel<f32>` has
//!   no `Hash` (f32 has none): its states are identified by its `Debug`
//!   text without the two tick counters (it keeps the run record; Rust prints
//!   every non-NaN f32 in a form that round-trips, so distinct values give
//!   distinct text; a stationary arm never makes a NaN, and if it did the
//!   "no NaN" property would fail).
//!
//! Recoverability (SR-6, SR-31; property "SR-6/31: recoverability: ..."):
//! wherever a latch is entered (or a stop toward one starts), and in every
//! homing state with the host link lost there, the kernel is cloned and
//! driven, with the switches pressed in that tick held pressed and nothing
//! else perturbed, through the end of the ramp, `<ENABLE>` and, where
//! homing was lost, `<HOME>`: both must be accepted unless a homed joint's
//! switch is pressed (a cause only the operator removes). The lost link is
//! judged on the clone only, not explored as a perturbation (as one it more
//! than doubled the small configuration's state space). A kernel that takes
//! an unhomed joint's switch for a cause (`mutants.sh`,
//! `lock-up-on-homing-switch`) fails it.
//!
//! Every reachable state is explored (breadth first) and every property is
//! checked on every transition or state; the run fails if a property is
//! violated or a `sometimes` property is never reached (the bounded run
//! too: an exploration that never reached one did not reach what it
//! shows).
//!
//! Modules, one job each: [`boot`] (the boot's length forgotten),
//! [`census`] (where the explored states lie),
//! [`config`] (the arm configuration and its
//! relaxations), [`identity`] (how a kernel state is identified),
//! [`state`] (a model state), [`environment`] (the choices offered on a
//! tick), [`transition`] (one tick and its transition checks), [`checks`]
//! (the transition checks as properties), [`recovery`] (the
//! recoverability judgement), [`properties`] (the state properties),
//! [`model`] (the configurations and the stateright model), [`mod@run`] (one
//! exploration and its evidence).

mod boot;
mod census;
mod checks;
mod config;
mod coupling;
#[cfg(test)]
mod coupling_tests;
mod environment;
#[cfg(test)]
mod evidence_tests;
mod identity;
mod model;
mod properties;
mod recovery;
mod run;
mod state;
mod transition;

use config::MODEL_RELAXATIONS;
use kernel::Fx;
use run::run;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |k: &str| args.iter().position(|a| a == k).and_then(|i| args.get(i + 1)).map(String::as_str);
    let expect = arg("--expect-violation");
    // `--census`: print where the explored states lie (`census`).
    census::ON.store(args.iter().any(|a| a == "--census"), std::sync::atomic::Ordering::Relaxed);
    // `--coupling`: check the homing group's coupling lemma on every
    // transition without a request or perturbation (`coupling`).
    coupling::ON.store(args.iter().any(|a| a == "--coupling"), std::sync::atomic::Ordering::Relaxed);
    // `--no-merges`: the model without its own two merges (`boot`).
    boot::OFF.store(args.iter().any(|a| a == "--no-merges"), std::sync::atomic::Ordering::Relaxed);
    // `--homing-restricted`: the full configuration with the stream
    // configuration's alphabet during homing.
    model::HOMING_RESTRICTED
        .store(args.iter().any(|a| a == "--homing-restricted"), std::sync::atomic::Ordering::Relaxed);
    // `--no-far`: the full configuration without its 2 mrad target.
    model::NO_FAR.store(args.iter().any(|a| a == "--no-far"), std::sync::atomic::Ordering::Relaxed);
    // `--bounded S`: explore breadth first for at most S seconds and report
    // a bounded exploration (sampled evidence) if it does not finish.
    // Only the stream configuration is bounded: the others (full, small,
    // homing, tiny) must finish, so that their runs are model checks.
    let bounded = arg("--bounded").and_then(|t| t.parse::<u64>().ok());
    // `--depth D`: explore the stream configuration breadth first on one
    // thread, every path of up to D - 2 ticks from power-on (the initial
    // state is at depth 1), and report a bounded exploration (sampled
    // evidence) if it does not finish within that depth: what it covers
    // does not depend on the machine's speed or load. (`--timeout` does not
    // apply: stateright enforces it only where its threads share work,
    // which one thread never does.)
    let depth = arg("--depth").and_then(|t| t.parse::<usize>().ok());
    let plain_timeout: Option<u64> = arg("--timeout").and_then(|t| t.parse().ok());
    let runs: Vec<(&str, &str)> = match (arg("--variant"), arg("--config")) {
        (None, None) => vec![("fx", "full"), ("fx", "stream"), ("fx", "small"), ("fx", "homing"), ("f32", "tiny")],
        (v, c) => vec![(v.unwrap_or("fx"), c.unwrap_or("full"))],
    };
    for (field, rule) in MODEL_RELAXATIONS {
        println!("model: configuration relaxes {field} (breaks '{rule}'; see the doc comment)");
    }
    let mut tsv = String::new();
    for (variant, cfg) in runs {
        if !matches!(cfg, "full" | "stream" | "small" | "tiny" | "homing") {
            eprintln!("model: unknown configuration {cfg}");
            std::process::exit(2);
        }
        let (timeout, bounded, depth) = match (cfg, bounded, depth) {
            ("stream", _, Some(d)) => (None, true, Some(d)),
            ("stream", Some(b), None) => (Some(b), true, None),
            _ => (plain_timeout, false, None),
        };
        let r = match variant {
            "fx" => run::<Fx>(cfg, expect, timeout, bounded, depth),
            "f32" => run::<f32>(cfg, expect, timeout, bounded, depth),
            other => {
                eprintln!("model: unknown variant {other}");
                std::process::exit(2);
            }
        };
        let name = if variant == "fx" { "Kernel<Fx>" } else { "Kernel<f32>" };
        if coupling::ON.load(std::sync::atomic::Ordering::Relaxed) && !r.exhaustive {
            println!("model: the coupling lemma was not checked on every reachable state (the run did not finish)");
            std::process::exit(1);
        }
        println!(
            "{} {name}, {cfg} configuration: {} states ({} unique), max depth {}, {:.1} s",
            if r.exhaustive { "model-checked" } else { "explored (bounded, sampled evidence)" },
            r.generated,
            r.unique,
            r.depth,
            r.secs
        );
        if let Some(want) = expect {
            let hit: Vec<&String> = r.violated.iter().filter(|v| v.contains(want)).collect();
            if hit.is_empty() {
                println!("model: expected a violation of '{want}', found {:?}", r.violated);
                std::process::exit(1);
            }
            println!("model: violated as expected: {hit:?}");
            continue;
        }
        if r.exhaustive {
            println!(
                "model-checked {name}: every property holds in every reachable state; every 'sometimes' property reached"
            );
            tsv.push_str(&format!(
                "model\tmodel-checked\t{}\tholds\tsupervisor + homing, {name}, {cfg} configuration\t{}\n",
                r.unique,
                r.backing.join("|")
            ));
        } else {
            tsv.push_str(&format!(
                "model\tsampled\t{}\tholds\tbounded BFS exploration (not exhaustive) to depth {}, {name}, {cfg} configuration\t{}\n",
                r.unique,
                r.depth,
                r.backing.join("|")
            ));
        }
    }
    if expect.is_none() {
        if let Ok(dir) = std::env::var("EVIDENCE_DIR") {
            if let Err(e) = std::fs::write(std::path::Path::new(&dir).join("model.tsv"), tsv) {
                eprintln!("model: cannot write the evidence file in {dir}: {e}");
                std::process::exit(1);
            }
        }
    }
}
