//! `#[kani::proof]` and friends for the shim (see the `kani-shim` crate).
//!
//! Written against `proc_macro` directly instead of `syn`/`quote`: the
//! transformations are "find the function name, wrap the item" and "count
//! the iterations of every loop", and avoiding `syn` keeps the proof crate's
//! build small.
//!
//! # Unwind bounds
//!
//! Kani's `#[kani::unwind(N)]` unrolls every loop N times: a loop may run at
//! most N - 1 iterations per entry, or Kani reports an unwinding-assertion
//! failure. The shim checks the same rule at run time on the loops it can
//! see: every `for`, `while` and `loop` written in the body of a
//! `#[kani::proof]` function, and in the body of every function marked
//! `#[cfg_attr(not(kani), kani::loops)]` (the harnesses' helpers; the real
//! Kani never sees that attribute). Each such loop counts its iterations per
//! entry and fails the harness when the count exceeds N - 1.
//!
//! It cannot see loops in code it does not compile with this macro: the
//! crates under test (`kernel`, `monitor`, `protocol`), `core`'s iterator
//! adapters (`all`, `position`, `array::map`, `array::from_fn`, ...), and
//! dependencies. For those, the proofs crate states the largest bound and a
//! source scan test checks it (`proofs/tests/loops.rs`); the harness calls
//! `kani::runner::needs_unwind` to require a declared bound that covers it.

use proc_macro::{Delimiter, Group, Ident, Literal, Punct, Spacing, Span, TokenStream, TokenTree};

/// Turns a Kani harness `fn name() { ... }` into a `#[test]` that the shim
/// runs many times (exhaustively when every input is narrow, sampled
/// otherwise) and reports on. Its loops are instrumented (see the crate
/// documentation); a `#[kani::unwind(N)]` that follows this attribute gives
/// their bound.
#[proc_macro_attribute]
pub fn proof(_attr: TokenStream, item: TokenStream) -> TokenStream {
    let tokens: Vec<TokenTree> = item.clone().into_iter().collect();
    let mut name = None;
    for w in tokens.windows(2) {
        if let (TokenTree::Ident(f), TokenTree::Ident(n)) = (&w[0], &w[1]) {
            if f.to_string() == "fn" {
                name = Some(n.clone());
                break;
            }
        }
    }
    let Some(name) = name else {
        return error("#[kani::proof] expects a function");
    };
    let unwind = match declared_unwind(&tokens) {
        Ok(u) => u,
        Err(e) => return error(e),
    };
    let Some((values, ticks)) = stated_footprint(&tokens) else {
        return error(
            "a #[kani::proof] harness states its symbolic footprint in its documentation: \
             `/// Footprint: N symbolic values, T ticks` (see kani_shim::runner::Footprint)",
        );
    };
    if let Err(e) = within_budget(values, ticks) {
        return error(&e);
    }
    let inner = Ident::new(&format!("__kani_harness_{name}"), Span::call_site());
    // Rename the harness so the test can take its name; instrument its body.
    let mut renamed: Vec<TokenTree> = Vec::with_capacity(tokens.len());
    let mut replaced = false;
    for t in tokens {
        match &t {
            TokenTree::Ident(i) if !replaced && i.to_string() == name.to_string() => {
                renamed.push(TokenTree::Ident(inner.clone()));
                replaced = true;
            }
            _ => renamed.push(t),
        }
    }
    let harness = instrument_fn_body(renamed);
    let unwind = unwind
        .map(|n| format!("::core::option::Option::Some({n}u32)"))
        .unwrap_or("::core::option::Option::None".into());
    let wrapper = format!(
        "#[test] fn {name}() {{ ::kani::runner::run_harness(concat!(module_path!(), \"::\", stringify!({name})), {inner}, {unwind}, \
         ::core::option::Option::Some(::kani::runner::Footprint {{ symbolic_values: {values}u64, ticks: {ticks}u64 }})); }}"
    );
    let mut out = TokenStream::new();
    out.extend("#[allow(dead_code)]".parse::<TokenStream>().unwrap_or_default());
    out.extend(harness);
    out.extend(wrapper.parse::<TokenStream>().unwrap_or_default());
    out
}

/// `#[kani::unwind(n)]`: the loop bound of a harness. `#[kani::proof]`
/// reads it (so it must come after `#[kani::proof]`); alone it does nothing.
#[proc_macro_attribute]
pub fn unwind(attr: TokenStream, item: TokenStream) -> TokenStream {
    let a: Vec<TokenTree> = attr.into_iter().collect();
    if !matches!(a.as_slice(), [TokenTree::Literal(_)]) {
        return error("#[kani::unwind(N)] takes one integer literal");
    }
    let mentions_proof = item.clone().into_iter().collect::<Vec<_>>().windows(4).any(|w| {
        matches!((&w[0], &w[3]), (TokenTree::Ident(k), TokenTree::Ident(p)) if k.to_string() == "kani" && p.to_string() == "proof")
    });
    if mentions_proof {
        return error("the shim reads #[kani::unwind(N)] from #[kani::proof]: write #[kani::proof] first");
    }
    item
}

/// Shim only (write it as `#[cfg_attr(not(kani), kani::loops)]`): counts the
/// iterations of every loop in this function's body against the running
/// harness's `#[kani::unwind(N)]`, as `#[kani::proof]` does for the
/// harness's own body.
#[proc_macro_attribute]
pub fn loops(_attr: TokenStream, item: TokenStream) -> TokenStream {
    instrument_fn_body(item.into_iter().collect())
}

/// `#[kani::solver(...)]`: solver choice for Kani; ignored by the shim.
#[proc_macro_attribute]
pub fn solver(_attr: TokenStream, item: TokenStream) -> TokenStream {
    item
}

fn error(msg: &str) -> TokenStream {
    format!("compile_error!({msg:?});").parse().unwrap_or_default()
}

/// Kernel ticks a Kani harness may run: one. A harness of the whole tick
/// is a one-step lemma (one tick from a stated state; its induction is
/// argued beside it); a run of several ticks is a sampled end-to-end test
/// (`proofs::setup::end_to_end!`), not a Kani harness.
const TICK_BUDGET: u64 = 1;

/// Symbolic values a Kani harness may draw: 128, above the largest stated
/// today (the whole-state lemmas, 113-123, whose one-axis versions draw
/// 37-39). Whether Kani finishes a harness within the workflow's limit is
/// known only where Kani runs; the budget keeps a new harness from
/// growing past the ones stated.
const VALUE_BUDGET: u64 = 128;

/// A stated footprint within the budget, or why not (a compile error).
fn within_budget(values: u64, ticks: u64) -> Result<(), String> {
    if ticks > TICK_BUDGET {
        return Err(format!(
            "a #[kani::proof] harness runs at most {TICK_BUDGET} kernel tick (it states {ticks}): write a one-step \
             lemma from a stated state, or a sampled end-to-end test (proofs::setup::end_to_end!)"
        ));
    }
    if values > VALUE_BUDGET {
        return Err(format!(
            "a #[kani::proof] harness draws at most {VALUE_BUDGET} symbolic values (it states {values}): split it \
             (per axis, per phase)"
        ));
    }
    Ok(())
}

/// The footprint a harness states in its documentation: the text after
/// `Footprint:` (doc lines joined, so it may wrap) gives `N symbolic
/// value(s)` and `T tick(s)`.
fn stated_footprint(tokens: &[TokenTree]) -> Option<(u64, u64)> {
    let mut doc = String::new();
    for w in tokens.windows(2) {
        let (TokenTree::Punct(p), TokenTree::Group(g)) = (&w[0], &w[1]) else { continue };
        if p.as_char() != '#' || g.delimiter() != Delimiter::Bracket {
            continue;
        }
        let inner: Vec<TokenTree> = g.stream().into_iter().collect();
        if let [TokenTree::Ident(d), TokenTree::Punct(eq), TokenTree::Literal(l)] = inner.as_slice() {
            if d.to_string() == "doc" && eq.as_char() == '=' {
                doc.push(' ');
                doc.push_str(l.to_string().trim_matches('"'));
            }
        }
    }
    let text = &doc[doc.find("Footprint:")? + "Footprint:".len()..];
    let words: Vec<&str> =
        text.split(|c: char| c.is_whitespace() || c == ',' || c == ';' || c == '.').filter(|w| !w.is_empty()).collect();
    let number_before = |i: usize| i.checked_sub(1).and_then(|j| words.get(j)).and_then(|w| w.parse::<u64>().ok());
    let values = (0..words.len())
        .find(|&i| words[i] == "symbolic" && words.get(i + 1).is_some_and(|v| v.starts_with("value")))
        .and_then(number_before)?;
    let ticks = (0..words.len()).find(|&i| words[i] == "tick" || words[i] == "ticks").and_then(number_before)?;
    Some((values, ticks))
}

/// The N of a `# [kani :: unwind (N)]` among the item's outer attributes.
fn declared_unwind(tokens: &[TokenTree]) -> Result<Option<u32>, &'static str> {
    for w in tokens.windows(2) {
        let (TokenTree::Punct(p), TokenTree::Group(g)) = (&w[0], &w[1]) else { continue };
        if p.as_char() != '#' || g.delimiter() != Delimiter::Bracket {
            continue;
        }
        let inner: Vec<TokenTree> = g.stream().into_iter().collect();
        let is_unwind = inner.len() == 5
            && matches!(&inner[0], TokenTree::Ident(i) if i.to_string() == "kani")
            && matches!(&inner[3], TokenTree::Ident(i) if i.to_string() == "unwind");
        if !is_unwind {
            continue;
        }
        let TokenTree::Group(args) = &inner[4] else { return Err("#[kani::unwind(N)]: N missing") };
        let n = args.stream().to_string().trim().trim_end_matches("u32").replace('_', "");
        return n.parse::<u32>().map(Some).map_err(|_| "#[kani::unwind(N)]: N must be an integer literal");
    }
    Ok(None)
}

/// Instruments the body (the last brace group) of a function item: its
/// loops count their iterations, and its first statement declares every
/// `kani::cover!` written in it.
fn instrument_fn_body(mut tokens: Vec<TokenTree>) -> TokenStream {
    if let Some(pos) =
        tokens.iter().rposition(|t| matches!(t, TokenTree::Group(g) if g.delimiter() == Delimiter::Brace))
    {
        if let TokenTree::Group(g) = &tokens[pos] {
            let mut covers = Vec::new();
            collect_covers(g.stream(), &mut covers);
            let mut body: Vec<TokenTree> = declare_covers(&covers).into_iter().collect();
            body.extend(instrument(g.stream()));
            let mut ng = Group::new(Delimiter::Brace, body.into_iter().collect());
            ng.set_span(g.span());
            tokens[pos] = TokenTree::Group(ng);
        }
    }
    tokens.into_iter().collect()
}

/// Every `kani::cover!(...)` in `ts` (nested groups and closures included):
/// the line of its `kani` token (the line `line!()` gives inside the
/// `cover!` expansion) and its label: the message literal, else the
/// condition's text (as the `cover!` macro labels it).
fn collect_covers(ts: TokenStream, out: &mut Vec<(u32, TokenStream)>) {
    let toks: Vec<TokenTree> = ts.into_iter().collect();
    for (i, t) in toks.iter().enumerate() {
        if let TokenTree::Group(g) = t {
            collect_covers(g.stream(), out);
            continue;
        }
        let TokenTree::Ident(k) = t else { continue };
        let is_cover = k.to_string() == "kani"
            && is_punct(toks.get(i + 1), ':')
            && is_punct(toks.get(i + 2), ':')
            && matches!(toks.get(i + 3), Some(TokenTree::Ident(c)) if c.to_string() == "cover")
            && is_punct(toks.get(i + 4), '!');
        if !is_cover {
            continue;
        }
        let Some(TokenTree::Group(args)) = toks.get(i + 5) else { continue };
        let parts = split_commas(args.stream());
        let label = match parts.as_slice() {
            [] => "\"\"".parse().unwrap_or_default(),
            [_, msg, ..] if matches!(msg.as_slice(), [TokenTree::Literal(_)]) => msg.iter().cloned().collect(),
            [cond, ..] => {
                let mut s: TokenStream = "stringify!".parse().unwrap_or_default();
                s.extend([TokenTree::Group(Group::new(Delimiter::Parenthesis, cond.iter().cloned().collect()))]);
                s
            }
        };
        out.push((k.span().line() as u32, label));
    }
}

/// The top-level comma-separated parts of a macro's arguments (a trailing
/// comma gives no empty part).
fn split_commas(ts: TokenStream) -> Vec<Vec<TokenTree>> {
    let mut parts = vec![Vec::new()];
    for t in ts {
        if matches!(&t, TokenTree::Punct(p) if p.as_char() == ',') {
            parts.push(Vec::new());
        } else if let Some(last) = parts.last_mut() {
            last.push(t);
        }
    }
    parts.retain(|p| !p.is_empty());
    parts
}

/// `::kani::runner::declare_covers(file!(), &[(LINE, LABEL), ...]);`, or
/// nothing for a body without covers.
fn declare_covers(covers: &[(u32, TokenStream)]) -> TokenStream {
    if covers.is_empty() {
        return TokenStream::new();
    }
    let mut list: Vec<TokenTree> = Vec::new();
    for (line, label) in covers {
        let mut pair: Vec<TokenTree> = vec![TokenTree::Literal(Literal::u32_suffixed(*line))];
        pair.push(TokenTree::Punct(Punct::new(',', Spacing::Alone)));
        pair.extend(label.clone());
        list.push(TokenTree::Group(Group::new(Delimiter::Parenthesis, pair.into_iter().collect())));
        list.push(TokenTree::Punct(Punct::new(',', Spacing::Alone)));
    }
    let array = TokenTree::Group(Group::new(Delimiter::Bracket, list.into_iter().collect()));
    let mut args: TokenStream = "file!(), &".parse().unwrap_or_default();
    args.extend([array]);
    let mut s: TokenStream = "::kani::runner::declare_covers".parse().unwrap_or_default();
    s.extend([
        TokenTree::Group(Group::new(Delimiter::Parenthesis, args)),
        TokenTree::Punct(Punct::new(';', Spacing::Alone)),
    ]);
    s
}

fn is_punct(t: Option<&TokenTree>, c: char) -> bool {
    matches!(t, Some(TokenTree::Punct(p)) if p.as_char() == c)
}

/// Rewrites every loop in `ts` (recursively, closures included):
///
/// ```text
/// 'l: for PAT in EXPR { BODY }
/// ```
/// becomes
/// ```text
/// { let mut g = ::kani::runner::Loop::enter(file!(), LINE);
///   'l: for PAT in EXPR { g.iteration(); BODY } }
/// ```
/// (likewise `while` and `loop`). The wrapping block has the loop's value,
/// so `let x = loop { break v; };` keeps its meaning.
fn instrument(ts: TokenStream) -> TokenStream {
    let toks: Vec<TokenTree> = ts.into_iter().collect();
    let mut out: Vec<TokenTree> = Vec::with_capacity(toks.len());
    let mut i = 0;
    while i < toks.len() {
        let kw = match &toks[i] {
            TokenTree::Ident(id) => {
                let s = id.to_string();
                let is_loop = match s.as_str() {
                    // `for<'a>` is a higher-ranked bound, not a loop; `impl X for Y` has no `in`.
                    "for" => !is_punct(toks.get(i + 1), '<') && !out_has_impl_since_statement(&out),
                    "while" | "loop" => true,
                    _ => false,
                };
                is_loop.then(|| id.clone())
            }
            _ => None,
        };
        let Some(kw) = kw else {
            out.push(recurse(&toks[i]));
            i += 1;
            continue;
        };
        // The body: the first brace group after the keyword at this level.
        let Some(body_at) =
            (i + 1..toks.len()).find(|&j| matches!(&toks[j], TokenTree::Group(g) if g.delimiter() == Delimiter::Brace))
        else {
            out.push(recurse(&toks[i]));
            i += 1;
            continue;
        };
        // A label `'l:` directly before the keyword goes inside the wrapper.
        let mut label = Vec::new();
        let n = out.len();
        if n >= 3
            && is_punct(out.get(n - 3), '\'')
            && matches!(out.get(n - 2), Some(TokenTree::Ident(_)))
            && is_punct(out.get(n - 1), ':')
        {
            label = out.split_off(n - 3);
        }
        let span = kw.span();
        let guard = Ident::new("__kani_loop_guard", Span::mixed_site());
        let mut inner: Vec<TokenTree> = Vec::new();
        // let mut guard = ::kani::runner::Loop::enter(file!(), LINE);
        inner.extend(
            "let mut __kani_loop_guard = ::kani::runner::Loop::enter"
                .parse::<TokenStream>()
                .unwrap_or_default()
                .into_iter()
                .map(|t| respan_ident(t, &guard)),
        );
        let mut args: Vec<TokenTree> = "file!(),".parse::<TokenStream>().unwrap_or_default().into_iter().collect();
        args.push(TokenTree::Literal(Literal::u32_suffixed(span.line() as u32)));
        inner.push(TokenTree::Group(Group::new(Delimiter::Parenthesis, args.into_iter().collect())));
        inner.push(TokenTree::Punct(Punct::new(';', Spacing::Alone)));
        inner.extend(label);
        inner.push(TokenTree::Ident(kw));
        for t in &toks[i + 1..body_at] {
            inner.push(recurse(t));
        }
        let TokenTree::Group(body) = &toks[body_at] else { unreachable!() };
        let mut b: Vec<TokenTree> = Vec::new();
        b.push(TokenTree::Ident(guard.clone()));
        b.extend(".iteration();".parse::<TokenStream>().unwrap_or_default());
        b.extend(instrument(body.stream()));
        let mut bg = Group::new(Delimiter::Brace, b.into_iter().collect());
        bg.set_span(body.span());
        inner.push(TokenTree::Group(bg));
        out.push(TokenTree::Group(Group::new(Delimiter::Brace, inner.into_iter().collect())));
        i = body_at + 1;
    }
    out.into_iter().collect()
}

/// The guard's identifier as parsed from text has call-site hygiene; give it
/// the mixed-site one so that it cannot clash with the harness's names.
fn respan_ident(t: TokenTree, guard: &Ident) -> TokenTree {
    match t {
        TokenTree::Ident(i) if i.to_string() == guard.to_string() => TokenTree::Ident(guard.clone()),
        other => other,
    }
}

/// `impl Trait for Type` inside a body: an `impl` since the last `;` or `}`.
fn out_has_impl_since_statement(out: &[TokenTree]) -> bool {
    for t in out.iter().rev() {
        match t {
            TokenTree::Punct(p) if p.as_char() == ';' => return false,
            TokenTree::Group(g) if g.delimiter() == Delimiter::Brace => return false,
            TokenTree::Ident(i) if i.to_string() == "impl" => return true,
            _ => {}
        }
    }
    false
}

fn recurse(t: &TokenTree) -> TokenTree {
    match t {
        TokenTree::Group(g) => {
            let mut ng = Group::new(g.delimiter(), instrument(g.stream()));
            ng.set_span(g.span());
            TokenTree::Group(ng)
        }
        other => other.clone(),
    }
}

#[cfg(test)]
mod tests {
    use super::within_budget;

    /// The budget admits every footprint up to one tick and 128 symbolic
    /// values, and refuses one more of either.
    #[test]
    fn the_footprint_budget_refuses_a_second_tick_and_a_129th_value() {
        assert_eq!(within_budget(128, 1), Ok(()));
        assert_eq!(within_budget(0, 0), Ok(()));
        let e = within_budget(12, 2).expect_err("two ticks");
        assert!(e.contains("at most 1 kernel tick") && e.contains("end_to_end"), "{e}");
        let e = within_budget(129, 1).expect_err("129 values");
        assert!(e.contains("at most 128 symbolic values"), "{e}");
    }
}
