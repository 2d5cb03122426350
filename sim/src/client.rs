//! What the two host programs send and how they read feedback, written
//! independently of the protocol crate (so the sim cross-checks it).

use kernel::config::AXES;

use crate::numfmt::{push_fixed, push_u32};

/// A driver motion line: `<SEQ,p1,v1,...,p6,v6>`, printf `%.3f` (a negative
/// value that rounds to zero prints `-0.000`, as C does).
pub fn driver_line(seq: u32, p: &[f64; AXES], v: &[f64; AXES]) -> String {
    let mut s = String::with_capacity(96);
    s.push('<');
    push_u32(&mut s, seq);
    for (p, v) in p.iter().zip(v.iter()) {
        s.push(',');
        push_fixed(&mut s, *p, 3);
        s.push(',');
        push_fixed(&mut s, *v, 3);
    }
    s.push_str(">\n");
    s
}

/// A configurator motion line: `<SEQ,p1..p6,v1..v6>`, Python `:.4f`.
pub fn configurator_line(seq: u32, p: &[f64; AXES], v: &[f64; AXES]) -> String {
    let mut s = String::with_capacity(96);
    s.push('<');
    push_u32(&mut s, seq);
    for x in p.iter().chain(v.iter()) {
        s.push(',');
        push_fixed(&mut s, *x, 4);
    }
    s.push_str(">\n");
    s
}

/// What the ROS 2 driver extracts from a feedback line (PROTOCOL.md 3.1):
/// the text between the first `<` and the first `>`, split on `,`, exactly
/// 14 or 15 tokens, interleaved positions and velocities, optional `H<d>`.
#[derive(Clone, Debug, PartialEq)]
pub struct DriverView {
    /// SEQ acknowledged.
    pub seq: u32,
    /// Positions (rad).
    pub position: [f64; AXES],
    /// Velocities (rad/s).
    pub velocity: [f64; AXES],
    /// Homing status digit, if the H token is present.
    pub homing: Option<u8>,
}

/// Parses a line as the driver does; `None` if it would discard it.
pub fn driver_view(line: &str) -> Option<DriverView> {
    let line = line.strip_suffix('\n').unwrap_or(line);
    let line = line.strip_suffix('\r').unwrap_or(line);
    if !line.starts_with('<') {
        return None;
    }
    let start = line.find('<')? + 1;
    let end = line.find('>')?;
    let body = line.get(start..end)?;
    let mut tok = [""; 15];
    let mut n = 0;
    for t in body.split(',') {
        *tok.get_mut(n)? = t;
        n += 1;
    }
    if n != 14 && n != 15 {
        return None;
    }
    let seq = tok[1].parse().ok()?;
    let mut position = [0.0; AXES];
    let mut velocity = [0.0; AXES];
    for i in 0..AXES {
        position[i] = tok[2 + 2 * i].parse().ok()?;
        velocity[i] = tok[3 + 2 * i].parse().ok()?;
    }
    let homing = match n {
        15 => Some(tok[14].strip_prefix('H')?.parse().ok()?),
        _ => None,
    };
    Some(DriverView { seq, position, velocity, homing })
}

/// True if the configurator's regex `^<ACK,(\d+),([\d\.,\-]+)>` matches
/// (after stripping whitespace).
pub fn configurator_matches(line: &str) -> bool {
    let l = line.trim();
    let Some(rest) = l.strip_prefix("<ACK,") else { return false };
    let digits = rest.bytes().take_while(u8::is_ascii_digit).count();
    if digits == 0 {
        return false;
    }
    let Some(rest) = rest[digits..].strip_prefix(',') else { return false };
    let body = rest.bytes().take_while(|b| b.is_ascii_digit() || matches!(b, b'.' | b',' | b'-')).count();
    body > 0 && rest[body..].starts_with('>')
}

/// The configurator's grouped numbers after SEQ (positions, velocities,
/// limit mask, state byte, ...), if the line matches its regex.
pub fn configurator_values(line: &str) -> Option<Vec<f64>> {
    if !configurator_matches(line) {
        return None;
    }
    let l = line.trim();
    let body = &l[5..l.find('>')?];
    let mut it = body.split(',');
    it.next()?;
    it.map(|x| x.parse().ok()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats_like_printf_and_python() {
        let p = [0.123, -0.0001, 1.0, -1.5709, 0.0, 3.1417];
        let v = [0.05, 0.0, -0.2, 0.0, 0.3, -0.00004];
        assert_eq!(
            driver_line(1532, &p, &v),
            "<1532,0.123,0.050,-0.000,0.000,1.000,-0.200,-1.571,0.000,0.000,0.300,3.142,-0.000>\n"
        );
        assert_eq!(
            configurator_line(0, &p, &v),
            "<0,0.1230,-0.0001,1.0000,-1.5709,0.0000,3.1417,0.0500,0.0000,-0.2000,0.0000,0.3000,-0.0000>\n"
        );
    }

    #[test]
    fn reads_like_the_clients() {
        let l = "<ACK,250,-0.471,0.000,-0.803,0.500,1.292,0.000,-2.531,0.000,2.094,0.000,0.000,0.000,H1>\n";
        let d = driver_view(l).unwrap();
        assert_eq!((d.seq, d.homing, d.position[1], d.velocity[1]), (250, Some(1), -0.803, 0.5));
        assert!(!configurator_matches(l));
        let c =
            "<ACK,42,0.1234,-0.5000,1.0000,0.2500,-1.5708,3.1416,0.0500,-0.2000,0.0000,0.0000,0.3000,-0.0000,0,1,3>";
        assert!(configurator_matches(c));
        assert_eq!(configurator_values(c).unwrap().len(), 15);
        assert!(driver_view(c).is_none());
        assert!(driver_view("READY").is_none());
    }
}
