//! Property tests for a tool's command line.

use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};

/// Command lines for `cmd`: up to seven words drawn from its own long and
/// short options, `-`, `--`, number-like and option-like words and arbitrary
/// text, after a program name.
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

/// Checks a tool's parser `P`: clap's own consistency checks of the
/// argument definitions, then 3000 [`command_line`]s, each of which must
/// parse to options or an error, never a panic. Panics (failing the calling
/// test) with the smallest command line that broke it.
// A test helper: panicking is how it fails the test that calls it.
#[allow(clippy::panic)]
pub fn check_parser<P: clap::Parser>() {
    let cmd = P::command();
    cmd.clone().debug_assert();
    let mut runner = TestRunner::new(Config {
        cases: 3000,
        ..Config::default()
    });
    let result = runner.run(&command_line(&cmd), |argv| {
        let _ = P::try_parse_from(argv);
        Ok(())
    });
    if let Err(e) = result {
        panic!("{e}");
    }
}

#[cfg(test)]
mod tests {
    use clap::Parser;

    /// A parser whose value parser panics on an empty word.
    #[derive(Parser, Debug)]
    struct Fragile {
        #[arg(long, value_parser = not_empty)]
        name: Option<String>,
        words: Vec<String>,
    }

    #[allow(clippy::panic)]
    fn not_empty(s: &str) -> Result<String, String> {
        if s.is_empty() {
            panic!("empty");
        }
        Ok(s.to_string())
    }

    /// A command line such as `prog --name ""` is found and fails the check.
    #[test]
    #[should_panic]
    fn a_parser_that_panics_fails_the_check() {
        super::check_parser::<Fragile>();
    }

    /// A sound parser passes.
    #[test]
    fn a_sound_parser_passes() {
        #[derive(Parser, Debug)]
        struct Sound {
            #[arg(long)]
            name: Option<String>,
        }
        super::check_parser::<Sound>();
    }
}
