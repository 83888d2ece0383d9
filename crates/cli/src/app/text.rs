//! Text that came from a user, a file or an engine, shown on one line: control characters
//! escaped, very long words cut, an error's causes joined.

/// The error and its causes on one line, each cause only if the message does not already
/// contain it (several errors quote their cause in their own message). Line breaks become
/// spaces and other control characters are escaped (see [`escape_controls`]), so that text an
/// engine or a file sent cannot split or overwrite the line.
pub fn one_line(error: &anyhow::Error) -> String {
    let mut message = error.to_string();
    for cause in error.chain().skip(1) {
        let text = cause.to_string();
        if !message.contains(&text) {
            message.push_str(": ");
            message.push_str(&text);
        }
    }
    shorten_long_words(&escape_controls(&message))
}

/// Longest run of non-blank characters an error line shows whole (a path, a FEN, a move).
const LONGEST_WORD: usize = 200;

/// `text` with each run of non-blank characters longer than [`LONGEST_WORD`] cut to its start
/// and the count of what was left out, so that a megabyte token quoted by a parser does not
/// become a megabyte error line.
pub fn shorten_long_words(text: &str) -> String {
    if text.len() <= LONGEST_WORD {
        return text.to_owned();
    }
    let mut shown = String::with_capacity(text.len().min(4096));
    for (i, word) in text.split(' ').enumerate() {
        if i > 0 {
            shown.push(' ');
        }
        if word.chars().count() <= LONGEST_WORD {
            shown.push_str(word);
        } else {
            let kept: String = word.chars().take(LONGEST_WORD / 2).collect();
            shown.push_str(&format!("{kept}…({} more bytes)", word.len() - kept.len()));
        }
    }
    shown
}

/// `text` on one line: `\n` becomes a space, every other control character (CR, VT, NUL, ESC,
/// DEL, …) is shown escaped (`\r`, `\t`, `\0`, `\u{b}`), everything else as it is.
pub fn escape_controls(text: &str) -> String {
    let mut shown = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '\n' => shown.push(' '),
            '\r' => shown.push_str("\\r"),
            '\t' => shown.push_str("\\t"),
            '\0' => shown.push_str("\\0"),
            // Control characters, and the invisible ones that reorder or hide text (bidi
            // overrides, zero-width marks), which could make a shown line lie.
            c if c.is_control()
                || matches!(c, '\u{200b}'..='\u{200f}' | '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}' | '\u{feff}') =>
            {
                shown.push_str(&format!("\\u{{{:x}}}", u32::from(c)))
            }
            c => shown.push(c),
        }
    }
    shown
}

/// A number as a plot's tick or a message shows it: at most four significant digits, no trailing zeros, never "-0"; scientific
/// notation beyond 10⁶ and below 10⁻⁴.
pub fn tick(value: f64) -> String {
    if !value.is_finite() {
        return String::new();
    }
    if value.abs() < 1e-12 {
        return "0".into();
    }
    let magnitude = value.abs().log10().floor() as i32;
    if !(-4..6).contains(&magnitude) {
        let text = format!("{value:.2e}");
        let (mantissa, exponent) = text.split_once('e').unwrap_or((&text, "0"));
        let mantissa = mantissa.trim_end_matches('0').trim_end_matches('.');
        return format!("{mantissa}e{exponent}");
    }
    let decimals = (3 - magnitude).clamp(0, 8) as usize;
    let text = format!("{value:.decimals$}");
    let text = if text.contains('.') { text.trim_end_matches('0').trim_end_matches('.').to_string() } else { text };
    if text == "-0" { "0".into() } else { text }
}
