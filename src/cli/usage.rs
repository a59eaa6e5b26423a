//! Clap's rejections as one line in the project's own form (`error: invalid value for
//! `NAME`: VALUE (REASON)`), so a script or a log reads every refusal alike: clap writes
//! three or four lines (the error, a usage block, a pointer to `--help`).

use clap::error::{ContextKind, ContextValue, ErrorKind};

/// The one-line message for a command-line error, or `None` for what is not an error
/// (`--help`, `--version`: printed as clap writes them).
pub fn one_line_usage_error(e: &clap::Error) -> Option<String> {
    if matches!(
        e.kind(),
        ErrorKind::DisplayHelp
            | ErrorKind::DisplayVersion
            | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
    ) {
        return None;
    }
    let text = |k: ContextKind| match e.get(k) {
        Some(ContextValue::String(s)) => Some(s.clone()),
        Some(ContextValue::Strings(v)) => Some(v.join(", ")),
        _ => None,
    };
    let help = "see --help";
    if e.kind() == ErrorKind::ValueValidation
        && let (Some(arg), Some(value)) = (
            text(ContextKind::InvalidArg),
            text(ContextKind::InvalidValue),
        )
    {
        // `--periods <P>` -> `periods`, as the project's own errors name options.
        let name = arg
            .split_whitespace()
            .next()
            .unwrap_or(&arg)
            .trim_start_matches('-');
        // Clap's integer parser states the type's range (0..=4294967295), not the
        // option's: say what is wrong and leave the range to the option's own check.
        let reason = whole_number_reason(&value).unwrap_or_else(|| clap_reason(e));
        return Some(format!(
            "error: invalid value for `{name}`: {value} ({reason}; {help})"
        ));
    }
    Some(format!("{} ({help})", clap_reason_with_prefix(e)))
}

/// Why a value that should be a whole number is not, when it looks like a number.
fn whole_number_reason(value: &str) -> Option<String> {
    let v = value.trim();
    if let Ok(i) = v.parse::<i128>() {
        return Some(if i < 0 {
            "must be a whole number >= 0".into()
        } else {
            format!("{i} is too large")
        });
    }
    v.parse::<f64>()
        .ok()
        .map(|_| "must be a whole number".into())
}

/// Clap's message on one line, without its `error: ` prefix, usage block and tip lines.
fn clap_reason(e: &clap::Error) -> String {
    let full = clap_reason_with_prefix(e);
    let s = full.strip_prefix("error: ").unwrap_or(&full);
    // "invalid value '-1' for '--x <X>': REASON" -> REASON
    match s.rsplit_once("': ") {
        Some((_, r)) => r.to_string(),
        None => s.to_string(),
    }
}

fn clap_reason_with_prefix(e: &clap::Error) -> String {
    let rendered = e.render().to_string();
    let mut parts: Vec<&str> = Vec::new();
    for line in rendered.lines().map(str::trim) {
        if line.starts_with("Usage:") || line.starts_with("For more information") {
            break;
        }
        if !line.is_empty() {
            parts.push(line);
        }
    }
    parts.join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    fn err(args: &[&str]) -> String {
        let e = crate::cli::Cli::try_parse_from(args).unwrap_err();
        one_line_usage_error(&e).unwrap()
    }

    #[test]
    fn clap_rejections_are_one_line_naming_the_option() {
        let e = err(&["jeffcott", "simulate", "--omega", "133", "--periods", "-1"]);
        assert!(!e.contains('\n'), "{e}");
        assert!(e.contains("`periods`") && e.contains(">= 0"), "{e}");
        assert!(!e.contains("4294967295"), "{e}");
        let e = err(&["jeffcott", "cascade"]);
        assert!(!e.contains('\n') && e.contains("--omega"), "{e}");
        let e = err(&["jeffcott", "simulate", "--omega", "133", "--no-such"]);
        assert!(!e.contains('\n') && e.contains("--no-such"), "{e}");
    }

    #[test]
    fn help_is_not_rewritten() {
        let e = crate::cli::Cli::try_parse_from(["jeffcott", "--help"]).unwrap_err();
        assert!(one_line_usage_error(&e).is_none());
    }
}
