//! `#[kani::proof]` and friends for the shim (see the `kani-shim` crate).
//!
//! Written against `proc_macro` directly instead of `syn`/`quote`: the only
//! transformation is "find the function name, wrap the item", and avoiding
//! `syn` keeps the proof crate's build small.

use proc_macro::{Delimiter, Group, Ident, Span, TokenStream, TokenTree};

/// Turns a Kani harness `fn name() { ... }` into a `#[test]` that the shim
/// runs many times (exhaustively when every input is narrow, sampled
/// otherwise) and reports on.
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
        return "compile_error!(\"#[kani::proof] expects a function\");".parse().unwrap_or_default();
    };
    let inner = Ident::new(&format!("__kani_harness_{name}"), Span::call_site());
    // Rename the harness so the test can take its name.
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
    let harness: TokenStream = renamed.into_iter().collect();
    let wrapper = format!(
        "#[test] fn {name}() {{ ::kani::runner::run(concat!(module_path!(), \"::\", stringify!({name})), {inner}); }}"
    );
    let mut out = TokenStream::new();
    out.extend("#[allow(dead_code)]".parse::<TokenStream>().unwrap_or_default());
    out.extend(harness);
    out.extend(wrapper.parse::<TokenStream>().unwrap_or_default());
    out
}

/// `#[kani::unwind(n)]`: a loop bound for Kani; the shim runs loops as
/// written, so it only checks that the argument is a literal.
#[proc_macro_attribute]
pub fn unwind(attr: TokenStream, item: TokenStream) -> TokenStream {
    passthrough(attr, item)
}

/// `#[kani::solver(...)]`: solver choice for Kani; ignored by the shim.
#[proc_macro_attribute]
pub fn solver(attr: TokenStream, item: TokenStream) -> TokenStream {
    passthrough(attr, item)
}

fn passthrough(_attr: TokenStream, item: TokenStream) -> TokenStream {
    let _ = Group::new(Delimiter::None, TokenStream::new());
    item
}
