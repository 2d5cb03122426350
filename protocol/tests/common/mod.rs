//! The two clients' acceptance rules (docs/PROTOCOL.md, spec 3.1 and 3.2),
//! re-implemented independently of the crate under test.
#![allow(dead_code)]

use regex::Regex;

/// What the ROS 2 driver extracts from a feedback line.
#[derive(Debug, PartialEq)]
pub struct DriverView {
    pub seq: u32,
    pub position: [f64; 6],
    pub velocity: [f64; 6],
    pub homing: Option<u8>,
}

/// Spec 3.1: keep only the newest complete line starting with `<`; take the
/// text between the first `<` and the first `>`; split on `,`; exactly 14
/// or 15 tokens `ACK,SEQ,p1,v1,...,p6,v6[,H<d>]` (interleaved).
pub fn driver_accepts(text: &str) -> Option<DriverView> {
    let line = text
        .split('\n')
        .filter(|l| !l.is_empty())
        .map(|l| l.strip_suffix('\r').unwrap_or(l))
        .rfind(|l| l.starts_with('<'))?;
    let start = line.find('<')?;
    let end = line.find('>')?;
    let inner = line.get(start + 1..end)?;
    let tokens: Vec<&str> = inner.split(',').collect();
    if tokens.len() != 14 && tokens.len() != 15 {
        return None;
    }
    if tokens[0] != "ACK" {
        return None;
    }
    let seq: u32 = tokens[1].parse().ok()?;
    let mut position = [0.0; 6];
    let mut velocity = [0.0; 6];
    for j in 0..6 {
        position[j] = tokens[2 + 2 * j].parse().ok()?;
        velocity[j] = tokens[3 + 2 * j].parse().ok()?;
    }
    if position.iter().chain(&velocity).any(|x: &f64| !x.is_finite()) {
        return None; // the driver would not reject it, but we must never send it
    }
    let homing = match tokens.get(14) {
        None => None,
        Some(h) => {
            let d = h.strip_prefix('H')?;
            let d: u8 = d.parse().ok()?;
            if d > 3 {
                return None;
            }
            Some(d)
        }
    };
    Some(DriverView { seq, position, velocity, homing })
}

/// What the configurator extracts from a telemetry line.
#[derive(Debug, PartialEq)]
pub struct ConfiguratorView {
    pub seq: u64,
    pub position: [f64; 6],
    pub velocity: [f64; 6],
    pub limits: f64,
    pub state: f64,
    pub extra: Option<f64>,
}

/// Spec 3.2: strip whitespace, `^<ACK,(\d+),([\d\.,\-]+)>`, grouped numbers,
/// at least 12, then bitmask and state (at [12], [13] with fewer than 18
/// numbers), then the interrupt time.
pub fn configurator_accepts(line: &str) -> Option<ConfiguratorView> {
    let re = Regex::new(r"^<ACK,(\d+),([\d\.,\-]+)>").unwrap();
    let caps = re.captures(line.trim())?;
    let seq: u64 = caps[1].parse().ok()?;
    let nums: Vec<f64> = caps[2].split(',').map(|s| s.parse::<f64>()).collect::<Result<_, _>>().ok()?;
    if nums.len() < 12 {
        return None;
    }
    let (limits, state, extra) = if nums.len() >= 18 {
        (nums[18], nums[19], nums.get(20).copied())
    } else {
        (*nums.get(12)?, *nums.get(13)?, nums.get(14).copied())
    };
    Some(ConfiguratorView {
        seq,
        position: nums[0..6].try_into().unwrap(),
        velocity: nums[6..12].try_into().unwrap(),
        limits,
        state,
        extra,
    })
}

/// Printable ASCII plus the final `\n`.
pub fn is_clean_line(line: &str) -> bool {
    let body = line.strip_suffix('\n').unwrap_or(line);
    line.ends_with('\n') && body.bytes().all(|b| (0x20..=0x7E).contains(&b))
}
