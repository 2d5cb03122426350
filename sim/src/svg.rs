//! One SVG per scenario, written by hand (no plotting dependency: the
//! workspace's release profile uses fat LTO and one codegen unit, and every
//! extra crate costs build time in `cargo run -p sim --release`).
//!
//! Panels: a state strip; per joint, true angle and kernel set-point
//! (rad), with the commanded velocity (rad/s, right axis, dashed).

use std::fmt::Write as _;

use kernel::config::AXES;
use kernel::State;

use crate::report::Report;

const W: f64 = 1100.0;
const LEFT: f64 = 70.0;
const RIGHT: f64 = 60.0;
const PANEL_H: f64 = 120.0;
const GAP: f64 = 28.0;
const STRIP_H: f64 = 22.0;
const MAX_POINTS: usize = 1500;

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

/// The SVG text for a report.
pub fn plot(r: &Report) -> String {
    let tr = &r.trace;
    let h = 60.0 + STRIP_H + 30.0 + AXES as f64 * (PANEL_H + GAP) + 30.0;
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{h}" viewBox="0 0 {W} {h}" font-family="sans-serif" font-size="11">"#
    );
    let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(
        s,
        r#"<text x="{LEFT}" y="20" font-size="15" font-weight="bold">{}</text><text x="{LEFT}" y="38">{}</text>"#,
        esc(&r.name),
        esc(&r.description.chars().take(160).collect::<String>())
    );
    if tr.is_empty() {
        s.push_str("</svg>\n");
        return s;
    }
    let t0 = tr[0].t as f64;
    let t1 = (tr[tr.len() - 1].t as f64).max(t0 + 1.0);
    let pw = W - LEFT - RIGHT;
    let x = |t: u64| LEFT + (t as f64 - t0) / (t1 - t0) * pw;
    // Each panel's range: the least and largest angle (true or set-point)
    // and the largest speed, all six panels in one pass over the trace, in
    // f32 (the samples' own type: `f64::from` is exact and monotonic, so
    // the extremes are the same values). Plain comparisons skip NaN as
    // `min`/`max` do; they may keep the other zero of +-0, which the panel
    // never shows (a zero extreme is padded or widened before use).
    let (mut lo32, mut hi32, mut v32) = ([f32::INFINITY; AXES], [f32::NEG_INFINITY; AXES], [0.0f32; AXES]);
    let lower = |a: f32, b: f32| if b < a { b } else { a };
    let upper = |a: f32, b: f32| if b > a { b } else { a };
    // The state strip's runs of one state (first, last index), found in the
    // same pass over the trace (it is large: one pass, not two).
    let mut runs: Vec<(usize, usize)> = Vec::new();
    for (k, smp) in tr.iter().enumerate() {
        match runs.last_mut() {
            Some(r) if tr[r.1].state == smp.state => r.1 = k,
            _ => runs.push((k, k)),
        }
        for j in 0..AXES {
            lo32[j] = lower(lower(lo32[j], smp.q[j]), smp.sp[j]);
            hi32[j] = upper(upper(hi32[j], smp.q[j]), smp.sp[j]);
            v32[j] = upper(v32[j], smp.v[j].abs());
        }
    }
    // State strip.
    let y0 = 60.0;
    for &(k, e) in &runs {
        let st = tr[k].state;
        let (xa, xb) = (x(tr[k].t), x(tr[e].t + 1));
        let _ = writeln!(
            s,
            r#"<rect x="{xa:.1}" y="{y0}" width="{:.1}" height="{STRIP_H}" fill="{}"><title>{st:?} {}..{} ms</title></rect>"#,
            (xb - xa).max(0.5),
            state_color(st),
            tr[k].t,
            tr[e].t
        );
    }
    let _ = writeln!(s, r#"<text x="5" y="{}">state</text>"#, y0 + 15.0);
    let mut lx = LEFT;
    for st in [
        State::Boot,
        State::Unhomed,
        State::Homing,
        State::Operational,
        State::Stopping,
        State::SoftEstop,
        State::Fault,
    ] {
        let _ = writeln!(
            s,
            r#"<rect x="{lx}" y="{}" width="10" height="10" fill="{}"/><text x="{}" y="{}">{st:?}</text>"#,
            y0 + STRIP_H + 6.0,
            state_color(st),
            lx + 13.0,
            y0 + STRIP_H + 15.0
        );
        lx += 95.0;
    }
    let _ = writeln!(
        s,
        r##"<line x1="{}" x2="{}" y1="{y}" y2="{y}" stroke="#1f77b4" stroke-width="2"/><text x="{}" y="{}">true angle</text><line x1="{}" x2="{}" y1="{y}" y2="{y}" stroke="#d62728" stroke-width="1.5"/><text x="{}" y="{}">set-point</text><line x1="{}" x2="{}" y1="{y}" y2="{y}" stroke="#2ca02c" stroke-dasharray="4 3"/><text x="{}" y="{}">velocity cmd (right axis)</text>"##,
        lx + 10.0,
        lx + 30.0,
        lx + 33.0,
        y0 + STRIP_H + 15.0,
        lx + 110.0,
        lx + 130.0,
        lx + 133.0,
        y0 + STRIP_H + 15.0,
        lx + 200.0,
        lx + 220.0,
        lx + 223.0,
        y0 + STRIP_H + 15.0,
        y = y0 + STRIP_H + 11.0
    );
    let stride = tr.len().div_ceil(MAX_POINTS).max(1);
    // The plotted samples' x coordinates, formatted once for all panels.
    let xs: Vec<String> = tr
        .iter()
        .step_by(stride)
        .map(|smp| {
            let mut t = String::with_capacity(8);
            push_f1(&mut t, x(smp.t));
            t
        })
        .collect();
    let range: [(f64, f64, f64); AXES] = core::array::from_fn(|j| {
        (f64::MAX.min(f64::from(lo32[j])), f64::MIN.max(f64::from(hi32[j])), 1e-3f64.max(f64::from(v32[j])))
    });
    for (j, &(mut lo, mut hi, vmax)) in range.iter().enumerate() {
        let top = y0 + STRIP_H + 30.0 + j as f64 * (PANEL_H + GAP);
        if hi - lo < 1e-3 {
            lo -= 0.01;
            hi += 0.01;
        }
        let pad = (hi - lo) * 0.05;
        let (lo, hi) = (lo - pad, hi + pad);
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
            // The text of the last y (its bits, where it is in `pts`): a
            // joint at rest repeats its y, whose text is then copied.
            let mut last: Option<(u64, std::ops::Range<usize>)> = None;
            for (smp, xx) in tr.iter().step_by(stride).zip(xs.iter()) {
                let yy = match sel {
                    0 => y(f64::from(smp.q[j])),
                    1 => y(f64::from(smp.sp[j])),
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
            let _ =
                writeln!(s, r#"<polyline fill="none" stroke="{color}" stroke-width="{width}"{dash} points="{pts}"/>"#);
        }
    }
    let yb = h - 12.0;
    let _ = writeln!(s, r#"<text x="{LEFT}" y="{yb}">{t0:.0} ms</text>"#);
    let _ = writeln!(s, r#"<text x="{}" y="{yb}" text-anchor="end">{t1:.0} ms</text>"#, LEFT + pw);
    for (t, f) in &r.faults {
        let xx = x(*t);
        let _ = writeln!(
            s,
            r##"<line x1="{xx:.1}" x2="{xx:.1}" y1="{y0}" y2="{}" stroke="#a02020" stroke-dasharray="2 2"/><text x="{:.1}" y="{}" fill="#a02020">{}</text>"##,
            h - 25.0,
            xx + 3.0,
            h - 25.0,
            esc(f)
        );
    }
    s.push_str("</svg>\n");
    s
}

#[cfg(test)]
mod tests {
    use super::push_f1;
    use crate::rng::Rng;

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
