//! `docs/report.md`'s key lists, generated from the key tables of
//! [`super::golden`], [`super::method`], [`super::simulate`] (and the
//! structs they nest). `tests/report_docs.rs` fails when the page differs
//! and rewrites it with `UPDATE_DOCS=1`.

use super::keys::{KeyDoc, markdown_table};

/// Marks around the generated part of `docs/report.md`.
pub const BEGIN: &str = "<!-- BEGIN key lists: generated from src/report/ by tests/report_docs.rs (UPDATE_DOCS=1 cargo test --test suite report_docs::) -->";
/// End mark.
pub const END: &str = "<!-- END key lists -->";

/// The top-level rows of `keys`: nested tables are expanded, except
/// `frames`, `total` and `mean`, which have their own table.
fn top(keys: &[KeyDoc]) -> String {
    let (inline, own): (Vec<KeyDoc>, Vec<KeyDoc>) =
        keys.iter().copied().partition(|k| !matches!(k.key, "frames" | "total" | "mean"));
    let mut s = markdown_table(&inline);
    for k in own {
        s.push_str(&format!("| `{}` | {} | — | {} |\n", k.key, k.unit, k.meaning));
    }
    s
}

/// The generated text (between [`BEGIN`] and [`END`], exclusive).
pub fn key_lists() -> String {
    let mut s = String::new();
    let section = |s: &mut String, title: &str, report: Vec<KeyDoc>, frame: Vec<KeyDoc>, extra: &str| {
        s.push_str(&format!("\n### {title}\n\nTop level:\n\n"));
        s.push_str(&top(&report));
        s.push_str(&format!(
            "\nPer frame (`frames[i]`); `total` holds the keys whose rule is a sum or a maximum{extra}, `mean` every key \
             but the per-frame ones (—):\n\n"
        ));
        s.push_str(&markdown_table(&frame));
    };
    section(&mut s, "`postwarp golden`", super::golden::report_keys(), super::golden::frame_keys(), ", and `frames`");
    section(
        &mut s,
        "`postwarp golden --method`",
        super::method::report_keys(),
        super::method::frame_keys(),
        ", and `frames`",
    );
    section(
        &mut s,
        "`postwarp simulate`",
        super::simulate::report_keys(),
        super::simulate::frame_keys(),
        ", and `frames` and `identical_frames` (frames bit-identical to the golden model)",
    );
    s.push('\n');
    s
}

/// `page` with its generated part replaced by [`key_lists`], or `None` if
/// the marks are missing.
pub fn regenerate(page: &str) -> Option<String> {
    splice(page, BEGIN, END, &key_lists())
}

/// `page` with the text between marks `begin` and `end` replaced by
/// `body` (after a line break), or `None` if a mark is missing; the docs
/// generated from code tables (these key lists, the knob tables of
/// `crate::knobs::docs`) are spliced in this way.
pub fn splice(page: &str, begin: &str, end: &str, body: &str) -> Option<String> {
    let a = page.find(begin)? + begin.len();
    let b = a + page[a..].find(end)?;
    Some(format!("{}\n{}{}", &page[..a], body, &page[b..]))
}
