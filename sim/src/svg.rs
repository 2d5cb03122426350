//! One SVG per scenario, written by hand (no plotting dependency: the
//! workspace's release profile uses fat LTO and one codegen unit, and every
//! extra crate costs build time in `cargo run -p sim --release`).
//!
//! Panels: a state strip; per joint, true angle and kernel set-point
//! (rad, in the arm's frame), with the commanded velocity (rad/s, right
//! axis, dashed); a time axis in seconds with a grid line at each tick.

use std::fmt::Write as _;

use kernel::config::AXES;
use kernel::State;

use crate::report::Report;
use crate::trace::Sample;

const W: f64 = 1100.0;
const LEFT: f64 = 70.0;
/// Room for the right axis's labels ("-10.00 rad/s").
const RIGHT: f64 = 85.0;
const PANEL_H: f64 = 120.0;
const GAP: f64 = 28.0;
const STRIP_H: f64 = 22.0;
/// Top of the state strip.
const Y0: f64 = 60.0;
/// Below the last panel: the time axis's ticks, labels and title.
const BOTTOM: f64 = 50.0;
const MAX_POINTS: usize = 1500;
const STATES: [State; 7] =
    [State::Boot, State::Unhomed, State::Homing, State::Operational, State::Stopping, State::SoftEstop, State::Fault];

fn state_color(s: State) -> &'static str {
    match s {
        State::Boot => "#bbbbbb",
        State::Unhomed => "#dddddd",
        State::Homing => "#f0c040",
        State::Operational => "#70c070",
        State::Stopping => "#f09040",
        State::SoftEstop => "#e06060",
        State::Fault => "#a02020",
    }
}

/// Appends `v` formatted as `format!("{v:.1}")` does, byte for byte
/// ([`crate::numfmt::push_fixed`]).
pub fn push_f1(s: &mut String, v: f64) {
    crate::numfmt::push_fixed(s, v, 1);
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

/// Where the kernel's set-points are drawn: until the first homing
/// completes (`homed_at`) the kernel counts in its power-on frame, offset
/// from the arm's by `offset` (the true angle minus the kernel's estimate
/// on the last tick before homing starts, when no axis has been zeroed
/// yet); from then on in the arm's.
#[derive(Clone, Copy)]
struct Frame {
    homed_at: Option<u64>,
    offset: [f32; AXES],
}

impl Frame {
    /// The power-on frame of trace `tr`, homed at `homed_at`.
    fn of(tr: &[Sample], homed_at: Option<u64>) -> Frame {
        let before = tr.iter().take_while(|s| s.state != State::Homing).last().or(tr.first());
        let offset = before.map(|s| core::array::from_fn(|j| s.q[j] - s.est[j])).unwrap_or([0.0; AXES]);
        Frame { homed_at, offset }
    }

    /// Joint `j`'s set-point in the arm's frame (rad): the set-point the
    /// kernel holds, where it is on the arm (homing moves the arm by
    /// commanded speeds and leaves it where homing started; at homing's end
    /// the kernel sets it to the homed position).
    fn setpoint(&self, smp: &Sample, j: usize) -> f32 {
        if self.homed_at.is_none_or(|h| smp.t < h) {
            smp.sp[j] + self.offset[j]
        } else {
            smp.sp[j]
        }
    }
}

/// What one pass over the trace finds: each panel's least and largest
/// angle (true or drawn set-point) and largest speed, and the state strip's runs
/// of one state (first, last index).
struct Extents {
    lo: [f32; AXES],
    hi: [f32; AXES],
    vmax: [f32; AXES],
    runs: Vec<(usize, usize)>,
}

/// The [`Extents`] of a trace, in f32 (the samples' own type: `f64::from`
/// is exact and monotonic, so the extremes are the same values). Plain
/// comparisons skip NaN as `min`/`max` do; they may keep the other zero of
/// +-0, which the panel never shows (a zero extreme is padded or widened
/// before use).
fn extents(tr: &[Sample], frame: Frame) -> Extents {
    let (mut lo, mut hi, mut vmax) = ([f32::INFINITY; AXES], [f32::NEG_INFINITY; AXES], [0.0f32; AXES]);
    let lower = |a: f32, b: f32| if b < a { b } else { a };
    let upper = |a: f32, b: f32| if b > a { b } else { a };
    let mut runs: Vec<(usize, usize)> = Vec::new();
    for (k, smp) in tr.iter().enumerate() {
        match runs.last_mut() {
            Some(r) if tr[r.1].state == smp.state => r.1 = k,
            _ => runs.push((k, k)),
        }
        for j in 0..AXES {
            // (No set-point is drawn while homing: it does not count.)
            let sp = if smp.state == State::Homing { smp.q[j] } else { frame.setpoint(smp, j) };
            lo[j] = lower(lower(lo[j], smp.q[j]), sp);
            hi[j] = upper(upper(hi[j], smp.q[j]), sp);
            vmax[j] = upper(vmax[j], smp.v[j].abs());
        }
    }
    Extents { lo, hi, vmax, runs }
}

/// The time axis's tick spacing (ms): 1, 2 or 5 x 10^k, at most 12 ticks
/// over `span_ms`.
pub fn tick_step(span_ms: f64) -> f64 {
    let mut step = 1.0;
    loop {
        for m in [1.0, 2.0, 5.0] {
            if span_ms / (step * m) <= 12.0 {
                return step * m;
            }
        }
        step *= 10.0;
    }
}

/// The SVG text for a report.
pub fn plot(r: &Report) -> String {
    let tr = &r.trace;
    let h = Y0 + STRIP_H + 30.0 + AXES as f64 * (PANEL_H + GAP) + BOTTOM;
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{h}" viewBox="0 0 {W} {h}" font-family="sans-serif" font-size="11">"#
    );
    let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let mut what: String = r.description.chars().take(170).collect();
    if what.len() < r.description.len() {
        what.push_str("...");
    }
    let _ = writeln!(
        s,
        r#"<text x="{LEFT}" y="20" font-size="15" font-weight="bold">{}</text><text x="{LEFT}" y="38">{}</text>"#,
        esc(&r.name),
        esc(&what)
    );
    if tr.is_empty() {
        s.push_str("</svg>\n");
        return s;
    }
    let t0 = tr[0].t as f64;
    let t1 = (tr[tr.len() - 1].t as f64).max(t0 + 1.0);
    let pw = W - LEFT - RIGHT;
    let x = |t: f64| LEFT + (t - t0) / (t1 - t0) * pw;
    let frame = Frame::of(tr, r.homed_at);
    let ext = extents(tr, frame);
    state_strip(&mut s, tr, &ext.runs, &x);
    legend(&mut s);
    let bottom = Y0 + STRIP_H + 30.0 + AXES as f64 * (PANEL_H + GAP) - GAP;
    time_axis(&mut s, t0, t1, bottom, &x);
    let stride = tr.len().div_ceil(MAX_POINTS).max(1);
    // The plotted samples' x coordinates, formatted once for all panels.
    let xs: Vec<String> = tr
        .iter()
        .step_by(stride)
        .map(|smp| {
            let mut t = String::with_capacity(8);
            push_f1(&mut t, x(smp.t as f64));
            t
        })
        .collect();
    for j in 0..AXES {
        let range = (f64::from(ext.lo[j]), f64::from(ext.hi[j]), 1e-3f64.max(f64::from(ext.vmax[j])));
        panel(&mut s, tr, stride, &xs, j, range, frame);
    }
    for (t, f) in &r.faults {
        let xx = x(*t as f64);
        let _ = writeln!(
            s,
            r##"<line x1="{xx:.1}" x2="{xx:.1}" y1="{Y0}" y2="{bottom}" stroke="#a02020" stroke-dasharray="2 2"/><text x="{:.1}" y="{}" fill="#a02020">{}</text>"##,
            xx + 3.0,
            bottom - 3.0,
            esc(f)
        );
    }
    s.push_str("</svg>\n");
    s
}

/// The state strip: one rectangle per run of one state.
fn state_strip(s: &mut String, tr: &[Sample], runs: &[(usize, usize)], x: &dyn Fn(f64) -> f64) {
    for &(k, e) in runs {
        let st = tr[k].state;
        let (xa, xb) = (x(tr[k].t as f64), x((tr[e].t + 1) as f64));
        let _ = writeln!(
            s,
            r#"<rect x="{xa:.1}" y="{Y0}" width="{:.1}" height="{STRIP_H}" fill="{}"><title>{st:?} {}..{} ms</title></rect>"#,
            (xb - xa).max(0.5),
            state_color(st),
            tr[k].t,
            tr[e].t
        );
    }
    let _ = writeln!(s, r#"<text x="5" y="{}">state</text>"#, Y0 + 15.0);
}

/// The states' colours and the three curves.
fn legend(s: &mut String) {
    let y = Y0 + STRIP_H + 15.0;
    let mut lx = LEFT;
    for st in STATES {
        let _ = writeln!(
            s,
            r#"<rect x="{lx}" y="{}" width="10" height="10" fill="{}"/><text x="{}" y="{y}">{st:?}</text>"#,
            y - 9.0,
            state_color(st),
            lx + 13.0,
        );
        lx += 82.0;
    }
    let _ = writeln!(
        s,
        r##"<line x1="{}" x2="{}" y1="{yl}" y2="{yl}" stroke="#1f77b4" stroke-width="2"/><text x="{}" y="{y}">true angle</text><line x1="{}" x2="{}" y1="{yl}" y2="{yl}" stroke="#d62728" stroke-width="1.5"/><text x="{}" y="{y}">set-point (none while homing)</text><line x1="{}" x2="{}" y1="{yl}" y2="{yl}" stroke="#2ca02c" stroke-dasharray="4 3"/><text x="{}" y="{y}">velocity (right axis)</text>"##,
        lx,
        lx + 20.0,
        lx + 23.0,
        lx + 90.0,
        lx + 110.0,
        lx + 113.0,
        lx + 285.0,
        lx + 305.0,
        lx + 308.0,
        yl = y - 4.0
    );
}

/// The time axis under the last panel (ticks and labels in s) and a faint
/// grid line at each tick through every panel.
fn time_axis(s: &mut String, t0: f64, t1: f64, bottom: f64, x: &dyn Fn(f64) -> f64) {
    let step = tick_step(t1 - t0);
    let top = Y0 + STRIP_H + 30.0;
    let mut t = (t0 / step).ceil() * step;
    while t <= t1 {
        let xx = x(t);
        let _ = writeln!(
            s,
            r##"<line x1="{xx:.1}" x2="{xx:.1}" y1="{top}" y2="{bottom}" stroke="#e4e4e4"/><line x1="{xx:.1}" x2="{xx:.1}" y1="{bottom}" y2="{}" stroke="#555"/><text x="{xx:.1}" y="{}" text-anchor="middle">{}</text>"##,
            bottom + 5.0,
            bottom + 17.0,
            t / 1000.0
        );
        t += step;
    }
    let _ = writeln!(
        s,
        r#"<text x="{}" y="{}" text-anchor="middle">simulated time (s)</text>"#,
        LEFT + (W - LEFT - RIGHT) / 2.0,
        bottom + 34.0
    );
}

/// Joint `j`'s panel: true angle and set-point (rad, left axis), commanded
/// velocity (rad/s, right axis); `range` is (least angle, largest angle,
/// largest speed).
fn panel(s: &mut String, tr: &[Sample], stride: usize, xs: &[String], j: usize, range: (f64, f64, f64), frame: Frame) {
    let (mut lo, mut hi, vmax) = range;
    let top = Y0 + STRIP_H + 30.0 + j as f64 * (PANEL_H + GAP);
    if hi - lo < 1e-3 {
        lo -= 0.01;
        hi += 0.01;
    }
    let pad = (hi - lo) * 0.05;
    let (lo, hi) = (lo - pad, hi + pad);
    let pw = W - LEFT - RIGHT;
    let y = |v: f64| top + PANEL_H - (v - lo) / (hi - lo) * PANEL_H;
    let yv = |v: f64| top + PANEL_H / 2.0 - v / vmax * (PANEL_H / 2.0) * 0.95;
    let _ = writeln!(
        s,
        r##"<rect x="{LEFT}" y="{top}" width="{pw}" height="{PANEL_H}" fill="none" stroke="#888"/><text x="5" y="{}" font-weight="bold">J{}</text><text x="5" y="{}">{hi:.3}</text><text x="5" y="{}">{lo:.3} rad</text><text x="{}" y="{}">{vmax:.2}</text><text x="{}" y="{}">-{vmax:.2} rad/s</text>"##,
        top + PANEL_H / 2.0,
        j + 1,
        top + 10.0,
        top + PANEL_H,
        LEFT + pw + 3.0,
        top + 10.0,
        LEFT + pw + 3.0,
        top + PANEL_H
    );
    for (sel, color, width, dash) in
        [(2usize, "#2ca02c", 1.0, " stroke-dasharray=\"4 3\""), (0, "#1f77b4", 2.0, ""), (1, "#d62728", 1.2, "")]
    {
        let mut pts = String::with_capacity(xs.len() * 14);
        // The text of the last y (its bits, where it is in `pts`): a joint
        // at rest repeats its y, whose text is then copied.
        let mut last: Option<(u64, std::ops::Range<usize>)> = None;
        for (smp, xx) in tr.iter().step_by(stride).zip(xs.iter()) {
            if sel == 1 && smp.state == State::Homing {
                // Homing commands speeds, not the set-point: no line.
                if !pts.is_empty() {
                    polyline(s, color, width, dash, &pts);
                    pts.clear();
                }
                last = None;
                continue;
            }
            let yy = match sel {
                0 => y(f64::from(smp.q[j])),
                1 => y(f64::from(frame.setpoint(smp, j))),
                _ => yv(f64::from(smp.v[j])),
            };
            pts.push_str(xx);
            pts.push(',');
            match &last {
                Some((bits, r)) if *bits == yy.to_bits() => pts.extend_from_within(r.clone()),
                _ => {
                    let from = pts.len();
                    push_f1(&mut pts, yy);
                    last = Some((yy.to_bits(), from..pts.len()));
                }
            }
            pts.push(' ');
        }
        if !pts.is_empty() {
            polyline(s, color, width, dash, &pts);
        }
    }
}

fn polyline(s: &mut String, color: &str, width: f64, dash: &str, pts: &str) {
    let _ = writeln!(s, r#"<polyline fill="none" stroke="{color}" stroke-width="{width}"{dash} points="{pts}"/>"#);
}

#[cfg(test)]
mod tests {
    use super::{push_f1, tick_step, Frame};
    use crate::rng::Rng;
    use crate::trace::Sample;
    use kernel::config::AXES;
    use kernel::State;

    fn sample(t: u64, state: State, q: f32, est: f32, sp: f32) -> Sample {
        Sample {
            t,
            state,
            q: [q; AXES],
            est: [est; AXES],
            sp: [sp; AXES],
            v: [0.0; AXES],
            still: true,
            accepted: false,
            request_ok: false,
            reference: [f32::NAN; AXES],
        }
    }

    #[test]
    fn the_setpoint_is_drawn_in_the_arms_frame_before_homing() {
        // Power-on frame 0.4 rad off the arm's: the kernel holds 0.1 where
        // the arm is at 0.5; homing moves the arm to -1.0 and re-zeroes
        // axes one by one (the estimate jumps to the arm's frame before
        // H2); from H2 at t = 3 the set-point is in the arm's frame.
        let tr = [
            sample(0, State::Unhomed, 0.5, 0.1, 0.1),
            sample(1, State::Homing, -0.5, -0.9, 0.1),
            sample(2, State::Homing, -1.0, -1.0, 0.1),
            sample(3, State::Operational, -1.0, -1.0, -1.0),
        ];
        let f = Frame::of(&tr, Some(3));
        assert!((f.setpoint(&tr[0], 0) - 0.5).abs() < 1e-6, "{}", f.setpoint(&tr[0], 0));
        // the offset of the power-on frame, not the one a re-zeroed axis has
        assert!((f.setpoint(&tr[2], 0) - 0.5).abs() < 1e-6, "{}", f.setpoint(&tr[2], 0));
        assert_eq!(f.setpoint(&tr[3], 0), -1.0);
    }

    #[test]
    fn time_ticks_are_1_2_5_steps_at_most_12() {
        assert_eq!(tick_step(22_204.0), 2000.0);
        assert_eq!(tick_step(12_000.0), 1000.0);
        assert_eq!(tick_step(12_001.0), 2000.0);
        assert_eq!(tick_step(50_000.0), 5000.0);
        assert_eq!(tick_step(5.0), 1.0);
        for span in [1.0, 17.0, 999.0, 28_300.0, 1e6] {
            let n = span / tick_step(span);
            assert!(n <= 12.0 && n > 2.0 || span < 13.0, "{span}: {n} ticks");
        }
    }

    fn same(v: f64) {
        let mut s = String::new();
        push_f1(&mut s, v);
        assert_eq!(s, format!("{v:.1}"), "{v:e} ({:#x})", v.to_bits());
    }

    #[test]
    fn push_f1_formats_as_core_fmt() {
        for v in [
            0.0,
            -0.0,
            0.05,
            -0.05,
            0.25,
            -0.25,
            0.35,
            0.45,
            0.95,
            -0.95,
            0.04,
            -0.04,
            1e-300,
            -1e-300,
            9.95,
            99.95,
            1099.95,
            123456.75,
            9_999_999.95,
            1e7,
            -1e7,
            1e7 + 0.05,
            1e300,
            f64::MAX,
            f64::MIN_POSITIVE,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            0.049999999,
            0.050000001,
        ] {
            same(v);
        }
        let mut r = Rng::new(7);
        for k in 0..400_000 {
            let u = r.uniform();
            let v = match k % 4 {
                0 => (u - 0.5) * 3000.0,
                // Exact ties and their neighbours at one decimal.
                1 => {
                    let t = ((u * 20000.0) as i64 - 10000) as f64 / 10.0 + 0.05;
                    f64::from_bits(t.to_bits().wrapping_add((k as u64 / 4) % 5).wrapping_sub(2))
                }
                2 => (u - 0.5) * 2e7,
                _ => f64::from_bits(r.next_u64()),
            };
            same(v);
        }
    }
}
