//! Seeded-defect self-tests of the twin (`docs/safety/TOOLS.md`): a
//! peripheral that answers wrongly must show. A dead encoder line (the
//! QuadTimer sees no frame) is caught by the image's own boot self-test; an
//! encoder whose frames carry a wrong angle is caught by the twin's
//! comparison of the image's feedback with the plant (the criterion of
//! `image.rs`'s `feedback_reports_encoder_angles`), which passes unseeded.

use twin::plant::Plant;
use twin::{load_image, Twin, MS, START_Q};

fn run(t: &mut Twin, until_ms: u64) {
    if let Err(f) = t.run_until(until_ms * MS) {
        panic!("image stopped: {f}");
    }
}

fn lines(t: &Twin) -> Vec<String> {
    let text = t.board().serial_text();
    let done = text.rfind('\n').map_or("", |i| &text[..i]);
    done.lines().map(str::to_owned).collect()
}

fn twin_with(seed: impl FnOnce(&mut Plant)) -> Twin {
    let mut plant = Plant::new(&kernel::config::PAROL6, START_Q);
    seed(&mut plant);
    Twin::new(&load_image().expect("image"), plant).expect("twin")
}

/// Joints whose reported angle differs from the one the plant was set to by
/// more than 2 mrad (motor angle modulo a turn, over the gear ratio).
fn wrong_angles(t: &Twin) -> Vec<usize> {
    let l = lines(t);
    let last = l.iter().rev().find(|s| s.starts_with("<ACK,") && s.contains(",H")).expect("feedback line").clone();
    let f: Vec<f64> = last
        .trim_matches(['<', '>'])
        .split(',')
        .skip(2)
        .step_by(2)
        .take(6)
        .map(|x| x.parse().expect("angle"))
        .collect();
    let cfg = &kernel::config::PAROL6;
    (0..6)
        .filter(|&i| {
            let g = f64::from(cfg.joints[i].gear_ratio);
            let want = (START_Q[i] * g).rem_euclid(std::f64::consts::TAU) / g;
            (f[i] - want).abs() >= 0.002
        })
        .collect()
}

#[test]
fn an_encoder_reporting_a_wrong_angle_is_caught_and_a_right_one_is_not() {
    let mut clean = twin_with(|_| {});
    run(&mut clean, 80);
    assert_eq!(wrong_angles(&clean), Vec::<usize>::new());
    // J3's encoder answers with an angle 0.05 rad (joint) away from the pose
    // the comparison expects.
    let mut seeded = twin_with(|p| p.joints[2].steps += (0.05 * p.joints[2].steps_per_rad).round() as i64);
    run(&mut seeded, 80);
    assert_eq!(wrong_angles(&seeded), vec![2]);
}

/// The self-test waits for a silent encoder up to `SETTLE_MAX_MS` (1 s,
/// after the period calibration's 16 ms), then fails it.
#[test]
fn a_dead_encoder_line_fails_the_image_boot_self_test() {
    let mut t = twin_with(|p| p.joints[2].encoder_cut = true);
    run(&mut t, 1_100);
    let l = lines(&t);
    // code = ENCODER (0x40) | J3's bit (0x04) = 68
    assert!(l.iter().any(|s| s == "FAULT HARDWARE SELF_TEST code=68"), "{l:?}");
}
