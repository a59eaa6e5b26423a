//! The kernel's counted loops written out before it is compiled: every
//! `for (var i = 0u; i < N; i++) { body }` whose bound N is a literal or a known
//! constant becomes N copies of the body, each in a block of its own with `i` replaced
//! by its value (`0u`, `1u`, ...).
//!
//! Why: the WGSL keeps the Rust stepper's loops over the state so that the two read
//! alike, but with `i` a run-time value, `x[i]` on an array *value* makes naga copy the
//! whole array into a Function-storage variable and index it there (its SPIR-V back end's
//! `spill_to_internal_variable`), and NVIDIA's compiler keeps such arrays in local
//! memory (docs/gpu.md); every loop also gets a loop-bound counter
//! (`force_loop_bounding`). Written out, every index is a constant: naga extracts the
//! element (`OpCompositeExtract`), the array stays in registers, and no counter is
//! needed. The copies are the loop's iterations in order, so the arithmetic, and the
//! bits, are the loop's.
//!
//! The copies of a loop stand on the loop's own lines (its line comments dropped), so
//! a compiler error's line number still names the kernel file's line. A loop whose body
//! holds `break`, `continue` or `return`, or whose bound is not known, is left as it is.

/// Writes out the counted loops of `src` (see the module docs); `consts` gives the
/// value of a named bound (`STATE_DIM`).
pub fn unroll_counted_loops(src: &str, consts: &[(&str, u32)]) -> String {
    let mut out = String::with_capacity(src.len() * 2);
    let mut rest = src;
    while let Some(at) = rest.find("for (var ") {
        let (before, from) = rest.split_at(at);
        out.push_str(before);
        match counted_loop(from, consts) {
            Some((text, used)) => {
                out.push_str(&text);
                rest = &from[used..];
            }
            None => {
                out.push_str("for (var ");
                rest = &from["for (var ".len()..];
            }
        }
    }
    out.push_str(rest);
    out
}

/// The loop at the start of `s` written out, and how many bytes of `s` it spans; `None`
/// where it is not a counted loop this module writes out.
fn counted_loop(s: &str, consts: &[(&str, u32)]) -> Option<(String, usize)> {
    let head_end = s.find('{')?;
    let head = &s[..head_end];
    let (var, bound) = parse_head(head)?;
    let n = match bound.strip_suffix('u').and_then(|d| d.parse::<u32>().ok()) {
        Some(n) => n,
        None => consts.iter().find(|(name, _)| *name == bound)?.1,
    };
    let body_end = head_end + matching_brace(&s[head_end..])?;
    let body = &s[head_end + 1..body_end];
    let code = strip_line_comments(body);
    if ["break", "continue", "return"]
        .iter()
        .any(|w| contains_word(&code, w))
    {
        return None;
    }
    // The inner loops first, so a nested counted loop is written out too.
    let code = unroll_counted_loops(&code, consts);
    let flat = code.split_whitespace().collect::<Vec<_>>().join(" ");
    let copies: Vec<String> = (0..n)
        .map(|k| format!("{{ {} }}", replace_word(&flat, var, &format!("{k}u"))))
        .collect();
    // As many line breaks as the loop had, so later lines keep their numbers.
    let lines = s[..=body_end].matches('\n').count();
    Some((copies.join(" ") + &"\n".repeat(lines), body_end + 1))
}

/// The loop variable and bound of a head `for (var i = 0u; i < N; i++) `.
fn parse_head(head: &str) -> Option<(&str, &str)> {
    let inner = head.trim().strip_prefix("for (")?.strip_suffix(')')?;
    let parts: Vec<&str> = inner.split(';').map(str::trim).collect();
    let [init, cond, step] = parts.as_slice() else {
        return None;
    };
    let (var, zero) = init.strip_prefix("var ")?.split_once('=')?;
    let var = var.trim();
    let (lhs, bound) = cond.split_once('<')?;
    let ok = zero.trim() == "0u"
        && lhs.trim() == var
        && !bound.starts_with('=')
        && (*step == format!("{var}++") || *step == format!("{var} += 1u"));
    ok.then_some((var, bound.trim()))
}

/// The offset of the brace that closes the one `s` opens with.
fn matching_brace(s: &str) -> Option<usize> {
    let mut depth = 0usize;
    for (i, c) in s.char_indices() {
        match c {
            '{' => depth += 1,
            '}' => {
                depth = depth.checked_sub(1)?;
                if depth == 0 {
                    return Some(i);
                }
            }
            _ => {}
        }
    }
    None
}

fn strip_line_comments(s: &str) -> String {
    s.lines()
        .map(|l| l.find("//").map_or(l, |c| &l[..c]))
        .collect::<Vec<_>>()
        .join("\n")
}

fn is_ident(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

/// `s` with every whole-word `word` replaced by `by`.
fn replace_word(s: &str, word: &str, by: &str) -> String {
    let mut out = String::with_capacity(s.len());
    let mut rest = s;
    while let Some(at) = rest.find(word) {
        let before_ok = !rest[..at].chars().next_back().is_some_and(is_ident);
        let after = &rest[at + word.len()..];
        let after_ok = !after.chars().next().is_some_and(is_ident);
        out.push_str(&rest[..at]);
        out.push_str(if before_ok && after_ok { by } else { word });
        rest = after;
    }
    out.push_str(rest);
    out
}

fn contains_word(s: &str, word: &str) -> bool {
    replace_word(s, word, "\u{0}") != s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_counted_loop_becomes_its_iterations_in_blocks_on_the_same_lines() {
        let src = "a\nfor (var i = 0u; i < N; i++) {\n    // note\n    y[i] = x[i] + xi;\n}\nb\n";
        let out = unroll_counted_loops(src, &[("N", 3)]);
        assert_eq!(
            out,
            "a\n{ y[0u] = x[0u] + xi; } { y[1u] = x[1u] + xi; } { y[2u] = x[2u] + xi; }\n\n\n\nb\n"
        );
        assert_eq!(out.lines().count(), src.lines().count());
    }

    #[test]
    fn nested_loops_with_literal_bounds_are_written_out_and_others_left_alone() {
        let src = "for (var j = 0u; j < 2u; j++) { let q = 2u * j; for (var i = 0u; i < 2u; i++) { s += m[q][i]; } }";
        let out = unroll_counted_loops(src, &[]);
        assert!(!out.contains("for"), "{out}");
        assert!(
            out.contains("let q = 2u * 1u; { s += m[q][0u]; } { s += m[q][1u]; }"),
            "{out}"
        );
        for kept in [
            "for (var i = 0u; i < n; i++) { s += 1.0; }",
            "for (var i = 0u; i < 4u; i++) { if a { break; } }",
            "for (var i = 1u; i < 4u; i++) { s += 1.0; }",
            "for (var i = 0u; i <= 4u; i++) { s += 1.0; }",
        ] {
            assert_eq!(unroll_counted_loops(kept, &[]), kept);
        }
    }

    #[test]
    fn only_whole_words_are_replaced() {
        assert_eq!(
            replace_word("i + xi + i_2 + (i)", "i", "3u"),
            "3u + xi + i_2 + (3u)"
        );
    }
}
