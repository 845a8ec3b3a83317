//! A property-test strategy for a tool's command line.

use proptest::prelude::*;

/// Command lines for `cmd`: up to seven words drawn from its own long and
/// short options, `-`, `--`, number-like and option-like words and arbitrary
/// text, after a program name. Parsing any of them must give options or an
/// error, never a panic.
pub fn command_line(cmd: &clap::Command) -> impl Strategy<Value = Vec<String>> {
    let mut flags: Vec<String> = vec!["-".into(), "--".into()];
    for arg in cmd.get_arguments() {
        flags.extend(arg.get_long().map(|l| format!("--{l}")));
        flags.extend(arg.get_short().map(|s| format!("-{s}")));
    }
    let word = prop_oneof![
        proptest::sample::select(flags),
        "-?[0-9.eE+-]{0,8}",
        "--[a-z-]{1,14}(=[^\\x00]{0,8})?",
        "[^\\x00]{0,12}",
    ];
    proptest::collection::vec(word, 0..8)
        .prop_map(|words| std::iter::once("prog".to_string()).chain(words).collect())
}
