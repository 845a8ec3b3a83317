//! `cargo sim --scenario NAME --settings FILE`: fly the board's settings
//! as changed by FILE, the lines the board's console prints for `dump` or
//! `diff` (`set NAME VALUE`, `#` comments, blank lines), so a change is
//! flown on the model before it is typed into the board. The same parser
//! as the board's (`params::console`), the same ranges and messages.

use params::console::{self, LineBuf, Outcome, Sink};
use params::{ParamId, ParamSet};
use std::path::Path;

/// Collects a command's reply.
struct Reply(LineBuf);

impl Sink for Reply {
    fn put(&mut self, bytes: &[u8]) {
        self.0.put(bytes);
    }
}

/// The defaults with FILE's `set` lines applied; the first bad line is an
/// error naming it (the file is read whole before anything flies).
pub fn read(path: &Path) -> Result<ParamSet, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    parse(&text).map_err(|e| format!("{}: {e}", path.display()))
}

/// [`read`] on the file's text.
pub fn parse(text: &str) -> Result<ParamSet, String> {
    let mut set = ParamSet::defaults();
    for (n, line) in text.lines().enumerate() {
        let code = line.split('#').next().unwrap_or("").trim();
        if code.is_empty() {
            continue;
        }
        if !code.starts_with("set ") {
            return Err(format!(
                "line {}: only `set NAME VALUE` lines (got `{code}`)",
                n + 1
            ));
        }
        let mut reply = Reply(LineBuf::default());
        let outcome = console::execute(code.as_bytes(), &mut set, false, &mut reply);
        let text = String::from_utf8_lossy(reply.0.as_bytes())
            .trim()
            .to_string();
        if !matches!(outcome, Outcome::Changed(_) | Outcome::Done) || text.starts_with("error") {
            return Err(format!("line {}: {text}", n + 1));
        }
    }
    Ok(set)
}

/// The settings that differ from the defaults, as `NAME VALUE` pairs.
pub fn changed(set: &ParamSet) -> Vec<String> {
    ParamId::ALL
        .iter()
        .filter(|&&id| !set.is_default(id))
        .map(|&id| {
            let v = params::fixed::format(set.get(id), id.param().decimals);
            format!(
                "{} {}",
                id.param().name,
                String::from_utf8_lossy(v.as_bytes())
            )
        })
        .collect()
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn a_diff_is_read_back_and_a_bad_line_is_named() {
        let set =
            parse("# from the board\nset rate.roll.p 0.3\n\nset batt.cells 4 # 4S\n").unwrap();
        assert_eq!(changed(&set), ["rate.roll.p 0.3000", "batt.cells 4"]);
        let e = parse("set rate.roll.p 0.3\nset rate.roll.p 9\n").unwrap_err();
        assert!(
            e.starts_with("line 2: error") && e.contains("rate.roll.p"),
            "{e}"
        );
        assert!(parse("save\n").unwrap_err().contains("only `set"));
        assert!(parse("set nonsense 1\n").unwrap_err().contains("line 1"));
    }
}
