//! The two JSON values the command line writes by hand (`stats --json`, `trace-ray --json`;
//! DESIGN.md's output schemas): strings escaped, and numbers that are `null` where JSON has
//! none.

/// `s` as a JSON string.
#[must_use]
pub fn string(s: &str) -> String {
    let mut out = String::from("\"");
    for ch in s.chars() {
        match ch {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if (c as u32) < 0x20 => out.push_str(&format!("\\u{:04x}", c as u32)),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// `x` as a JSON number; `null` for infinities and NaN.
#[must_use]
pub fn number(x: f64) -> String {
    if x.is_finite() {
        format!("{x}")
    } else {
        "null".to_owned()
    }
}
