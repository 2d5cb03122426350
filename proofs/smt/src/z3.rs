//! A `z3` process driven through SMT-LIB2 text over a pipe.
//!
//! Commands that answer nothing (`declare-const`, `define-fun`, `assert`)
//! are written without waiting (`:print-success false`); `check-sat-using`,
//! `get-value` and `simplify` read exactly one answer. A z3 error is printed
//! before the next answer, so every read checks for `(error ...)` and
//! panics with it: nothing is ignored.

use std::io::{BufRead, BufReader, BufWriter, Write};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};

/// Milliseconds z3 may spend on a property check before answering
/// `unknown` (which fails the proof: it is never read as "proved").
/// `$SMT_TIMEOUT_MS` overrides it.
pub fn property_timeout_ms() -> u32 {
    std::env::var("SMT_TIMEOUT_MS").ok().and_then(|s| s.parse().ok()).unwrap_or(120_000)
}

/// Milliseconds for a path-feasibility check; `unknown` there counts as
/// feasible (both outcomes are explored: sound, only slower).
/// `$SMT_DECIDE_TIMEOUT_MS` overrides it.
pub fn decide_timeout_ms() -> u32 {
    std::env::var("SMT_DECIDE_TIMEOUT_MS").ok().and_then(|s| s.parse().ok()).unwrap_or(5_000)
}

/// How every check is solved: one-shot, after a `(reset)` (z3's
/// incremental core is far slower on floating point), by default with
/// z3's default strategy for the logic it detects (for these
/// quantifier-free bit-vector / floating-point formulas: lowering to
/// bit-vectors, bit-blasting, SAT). With `bit_blast` (the proofs explored
/// with [`crate::ctx::explore_blind`]), the same steps without z3's default
/// preprocessing and solver choice: `(then simplify propagate-values fpa2bv
/// simplify bit-blast sat)` (`fpa2bv` only with floating point). On the
/// interpolator's checks timed by hand this answered in 0.4-1.6 s where the
/// default needed 4 s to over 100 s (f32), and was 2-5x faster on `I8F24`.
/// Both are
/// complete: `unknown` only on a timeout (the `sat` tactic also answers
/// `unknown` on a goal it cannot bit-blast; never read as a result).
/// `$SMT_TACTIC` overrides both with `(check-sat-using $SMT_TACTIC)`, for
/// experiments.
fn check_command(bit_blast: bool, floating_point: bool) -> String {
    match std::env::var("SMT_TACTIC") {
        Ok(t) => format!("(check-sat-using {t})"),
        Err(_) if bit_blast && floating_point => {
            "(check-sat-using (then simplify propagate-values fpa2bv simplify bit-blast sat))".to_string()
        }
        Err(_) if bit_blast => "(check-sat-using (then simplify propagate-values bit-blast sat))".to_string(),
        Err(_) => "(check-sat)".to_string(),
    }
}

/// The answer of a satisfiability check.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sat {
    /// Satisfiable: a model exists.
    Sat,
    /// Unsatisfiable.
    Unsat,
    /// z3 gave up (timeout): never read as either.
    Unknown,
}

/// A running z3.
#[derive(Debug)]
pub struct Z3 {
    child: Child,
    input: BufWriter<ChildStdin>,
    output: BufReader<ChildStdout>,
    /// Satisfiability checks answered so far.
    pub checks: u64,
    /// `$SMT_LOG`: every command is also appended to this file.
    log: Option<BufWriter<std::fs::File>>,
}

/// The z3 executable: `$SMT_Z3` or `z3` on the `PATH`.
fn executable() -> String {
    std::env::var("SMT_Z3").unwrap_or_else(|_| "z3".to_string())
}

impl Z3 {
    /// Starts z3 in interactive SMT-LIB2 mode. Panics (with the way to
    /// install it) if it cannot be started.
    pub fn start() -> Z3 {
        let exe = executable();
        let mut child = Command::new(&exe)
            .args(["-in", "-smt2"])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .unwrap_or_else(|e| {
                panic!("cannot start `{exe}` ({e}): install z3 (proofs/smt/run.sh does: apt-get install -y z3)")
            });
        let input = BufWriter::new(child.stdin.take().expect("z3 stdin is piped"));
        let output = BufReader::new(child.stdout.take().expect("z3 stdout is piped"));
        let log = std::env::var_os("SMT_LOG").map(|p| {
            let f = std::fs::OpenOptions::new().create(true).append(true).open(&p);
            BufWriter::new(f.unwrap_or_else(|e| panic!("cannot open SMT_LOG {p:?}: {e}")))
        });
        let mut z = Z3 { child, input, output, checks: 0, log };
        z.reset();
        z
    }

    /// Forgets every declaration and assertion (z3 `(reset)`), then sets
    /// the options again.
    pub fn reset(&mut self) {
        self.send("(reset)");
        self.send("(set-option :print-success false)");
        self.send("(set-option :produce-models true)");
    }

    /// Sends one command without waiting for an answer.
    pub fn send(&mut self, cmd: &str) {
        if let Some(l) = &mut self.log {
            writeln!(l, "{cmd}").expect("writing SMT_LOG failed");
        }
        writeln!(self.input, "{cmd}").expect("writing to z3 failed (did it exit?)");
    }

    /// Reads one answer: an atom on one line or a balanced s-expression.
    fn answer(&mut self) -> String {
        if let Some(l) = &mut self.log {
            l.flush().expect("writing SMT_LOG failed");
        }
        self.input.flush().expect("writing to z3 failed (did it exit?)");
        read_sexpr(&mut self.output)
    }

    /// Checks the asserted formulas (see [`check_command`]) within
    /// `timeout_ms`; `floating_point`: they contain floating-point terms.
    pub fn check(&mut self, timeout_ms: u32, bit_blast: bool, floating_point: bool) -> Sat {
        self.checks += 1;
        self.send(&format!("(set-option :timeout {timeout_ms})"));
        self.send(&check_command(bit_blast, floating_point));
        let a = self.answer();
        match a.as_str() {
            "sat" => Sat::Sat,
            "unsat" => Sat::Unsat,
            "unknown" => Sat::Unknown,
            _ => panic!("unexpected answer from z3 to a check: {a}"),
        }
    }

    /// The names of the assertions in the unsatisfiable core of the last
    /// check (it answered `unsat`, with `:produce-unsat-cores` set and
    /// assertions named `l<index>`): their indices.
    pub fn unsat_core(&mut self) -> Vec<usize> {
        self.send("(get-unsat-core)");
        let a = self.answer();
        match parse(&a) {
            Sexp::List(names) => names
                .into_iter()
                .map(|n| match n {
                    Sexp::Atom(s) => s.strip_prefix('l').and_then(|i| i.parse().ok()),
                    Sexp::List(_) => None,
                })
                .map(|i| i.unwrap_or_else(|| panic!("unexpected unsat core {a}")))
                .collect(),
            Sexp::Atom(_) => panic!("unexpected unsat core {a}"),
        }
    }

    /// Values of `terms` in the model of the last satisfiable check, as
    /// z3 prints them (`((t1 v1) (t2 v2) ...)`).
    pub fn values(&mut self, terms: &[String]) -> Vec<String> {
        if terms.is_empty() {
            return Vec::new();
        }
        self.send(&format!("(get-value ({}))", terms.join(" ")));
        let a = self.answer();
        let list = parse(&a);
        let Sexp::List(pairs) = list else { panic!("unexpected get-value answer {a}") };
        pairs
            .into_iter()
            .map(|p| match p {
                Sexp::List(mut kv) if kv.len() == 2 => kv.pop().map(|v| v.to_string()).unwrap_or_default(),
                other => panic!("unexpected get-value pair {other}"),
            })
            .collect()
    }

    /// z3's simplification of `term` (ground terms evaluate to a value).
    pub fn simplify(&mut self, term: &str) -> String {
        self.send(&format!("(simplify {term})"));
        self.answer()
    }

    /// Simplifies many terms, writing from a second thread while reading,
    /// so that neither pipe can fill up and block the other.
    pub fn simplify_many(&mut self, terms: &[String]) -> Vec<String> {
        let Z3 { input, output, .. } = self;
        std::thread::scope(|s| {
            let writer = s.spawn(move || {
                for t in terms {
                    writeln!(input, "(simplify {t})").expect("writing to z3 failed");
                }
                input.flush().expect("writing to z3 failed");
            });
            let answers: Vec<String> = terms.iter().map(|_| read_sexpr(output)).collect();
            writer.join().expect("z3 writer thread panicked");
            answers
        })
    }
}

impl Drop for Z3 {
    fn drop(&mut self) {
        let _ = writeln!(self.input, "(exit)");
        let _ = self.input.flush();
        // z3 exits on `(exit)`; wait for it so no zombie is left behind.
        let _ = self.child.wait();
    }
}

/// Reads one answer from z3's output; panics on an error message or EOF.
fn read_sexpr(r: &mut impl BufRead) -> String {
    let mut text = String::new();
    let mut depth = 0i64;
    loop {
        let mut line = String::new();
        let n = r.read_line(&mut line).expect("reading from z3 failed");
        assert!(n > 0, "z3 closed its output (crashed?) after: {text}");
        let t = line.trim();
        // `(reset)` restores `:print-success true` until it is set again:
        // its "success" is not an answer.
        if text.is_empty() && (t.is_empty() || t == "success") {
            continue;
        }
        let mut in_str = false;
        for ch in t.chars() {
            match ch {
                '"' => in_str = !in_str,
                '(' if !in_str => depth += 1,
                ')' if !in_str => depth -= 1,
                _ => {}
            }
        }
        if !text.is_empty() {
            text.push(' ');
        }
        text.push_str(t);
        if depth <= 0 {
            break;
        }
    }
    if text.starts_with("(error") || text == "unsupported" {
        panic!("z3 reported: {text}");
    }
    text
}

/// An s-expression of z3's output.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Sexp {
    /// A symbol, numeral or literal such as `#b0101`.
    Atom(String),
    /// A parenthesised list.
    List(Vec<Sexp>),
}

impl std::fmt::Display for Sexp {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Sexp::Atom(a) => write!(f, "{a}"),
            Sexp::List(l) => {
                write!(f, "(")?;
                for (i, e) in l.iter().enumerate() {
                    if i > 0 {
                        write!(f, " ")?;
                    }
                    write!(f, "{e}")?;
                }
                write!(f, ")")
            }
        }
    }
}

/// Parses one s-expression (z3's output: no strings inside values).
pub fn parse(text: &str) -> Sexp {
    let mut stack: Vec<Vec<Sexp>> = vec![Vec::new()];
    let mut atom = String::new();
    let flush = |atom: &mut String, stack: &mut Vec<Vec<Sexp>>| {
        if !atom.is_empty() {
            stack.last_mut().expect("stack is never empty").push(Sexp::Atom(std::mem::take(atom)));
        }
    };
    for ch in text.chars() {
        match ch {
            '(' => {
                flush(&mut atom, &mut stack);
                stack.push(Vec::new());
            }
            ')' => {
                flush(&mut atom, &mut stack);
                let l = stack.pop().expect("balanced parentheses");
                stack.last_mut().unwrap_or_else(|| panic!("unbalanced: {text}")).push(Sexp::List(l));
            }
            c if c.is_whitespace() => flush(&mut atom, &mut stack),
            c => atom.push(c),
        }
    }
    flush(&mut atom, &mut stack);
    let mut top = stack.pop().expect("stack is never empty");
    assert!(stack.is_empty() && top.len() == 1, "not one s-expression: {text}");
    top.pop().expect("one element")
}

/// Value of a bit-vector literal `#b...` / `#x...` and its width.
pub fn bv_literal(a: &str) -> Option<(u64, u32)> {
    if let Some(b) = a.strip_prefix("#b") {
        Some((u64::from_str_radix(b, 2).ok()?, u32::try_from(b.len()).ok()?))
    } else if let Some(h) = a.strip_prefix("#x") {
        Some((u64::from_str_radix(h, 16).ok()?, u32::try_from(h.len() * 4).ok()?))
    } else {
        None
    }
}

/// Bits of an `f32` printed by z3: `(fp #b0 #x7f #b000...)`,
/// `(_ +zero 8 24)`, `(_ -zero 8 24)`, `(_ +oo 8 24)`, `(_ -oo 8 24)`,
/// `(_ NaN 8 24)` (one NaN: returned as the canonical quiet NaN).
pub fn f32_value(text: &str) -> Option<u32> {
    match parse(text) {
        Sexp::List(l) => match l.as_slice() {
            [Sexp::Atom(fp), Sexp::Atom(s), Sexp::Atom(e), Sexp::Atom(m)] if fp == "fp" => {
                let (s, sw) = bv_literal(s)?;
                let (e, ew) = bv_literal(e)?;
                let (m, mw) = bv_literal(m)?;
                if (sw, ew, mw) != (1, 8, 23) {
                    return None;
                }
                u32::try_from((s << 31) | (e << 23) | m).ok()
            }
            [Sexp::Atom(u), Sexp::Atom(k), Sexp::Atom(eb), Sexp::Atom(sb)] if u == "_" && eb == "8" && sb == "24" => {
                match k.as_str() {
                    "+zero" => Some(0),
                    "-zero" => Some(0x8000_0000),
                    "+oo" => Some(0x7f80_0000),
                    "-oo" => Some(0xff80_0000),
                    "NaN" => Some(0x7fc0_0000),
                    _ => None,
                }
            }
            _ => None,
        },
        Sexp::Atom(_) => None,
    }
}

/// Bits of a 32-bit bit-vector printed by z3 (`#x...` or `#b...`).
pub fn bv32_value(text: &str) -> Option<u32> {
    let (v, w) = bv_literal(text.trim())?;
    if w == 32 {
        u32::try_from(v).ok()
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_z3_values() {
        assert_eq!(f32_value("(fp #b0 #x7f #b00000000000000000000000)"), Some(1.0f32.to_bits()));
        assert_eq!(f32_value("(_ -zero 8 24)"), Some(0x8000_0000));
        assert_eq!(f32_value("(_ NaN 8 24)").map(|b| f32::from_bits(b).is_nan()), Some(true));
        assert_eq!(bv32_value("#xfffffffe"), Some(0xffff_fffe));
        assert_eq!(bv32_value("#x0ffe"), None);
        assert_eq!(parse("((a #b1) (b (fp #b0 #x00 #b1)))").to_string(), "((a #b1) (b (fp #b0 #x00 #b1)))");
    }
}
