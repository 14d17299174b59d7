//! `calibrate --print-config`: the settings in effect as TOML, like
//! `estimate --print-config`, each key named after its flag and preceded by
//! the flag's documentation (taken from the flag's `--help`, so the two
//! cannot drift apart).

use anyhow::Context;
use clap::{Args as _, Command};

use super::args::Args;

/// Flags that are not settings: inputs, outputs, and what to print.
const NOT_SETTINGS: &[&str] = &["logs", "out", "json", "print_config"];

/// The settings of `args` as TOML with every flag's documentation as
/// comments; a flag without a value (not given, no default) is a comment.
pub(super) fn documented_toml(args: &Args) -> anyhow::Result<String> {
    let values = toml::Table::try_from(args).context("serialising the settings")?;
    let command = Args::augment_args(Command::new("calibrate"));
    let mut out = String::from(
        "# terraslip calibrate: the settings in effect. Every key is the flag of\n\
         # the same name: `yaw-weight = 0.5` is `--yaw-weight 0.5`.\n",
    );
    for arg in command.get_arguments() {
        let (id, Some(flag)) = (arg.get_id().as_str(), arg.get_long()) else {
            continue;
        };
        if NOT_SETTINGS.contains(&id) {
            continue;
        }
        out.push('\n');
        let help = arg
            .get_long_help()
            .or_else(|| arg.get_help())
            .map(|h| h.to_string())
            .unwrap_or_default();
        for paragraph in help.lines() {
            for line in terraslip::glossary::wrap(paragraph, 76) {
                out.push_str(format!("# {line}").trim_end());
                out.push('\n');
            }
        }
        match values.get(flag) {
            Some(value) => out.push_str(&format!("{flag} = {value}\n")),
            None => out.push_str(&format!("# {flag} = (not set)\n")),
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use clap::Parser;

    use super::*;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        args: Args,
    }

    fn printed(argv: &[&str]) -> String {
        let cli = Cli::try_parse_from(std::iter::once("calibrate").chain(argv.iter().copied()))
            .unwrap_or_else(|e| panic!("{e}"));
        documented_toml(&cli.args).unwrap()
    }

    #[test]
    fn needs_no_log_and_documents_every_setting() {
        let text = printed(&["--print-config"]);
        let table: toml::Table = toml::from_str(&text).unwrap();
        assert_eq!(table["yaw-weight"].as_float(), Some(0.5));
        assert_eq!(table["rate-model"].as_str(), Some("auto"));
        assert_eq!(table["min-segment"].as_float(), Some(1.0));
        assert!(text.contains("# gene-bits = (not set)"), "{text}");
        assert!(text.contains("# Weight between metres and radians in eq. 13"));
        assert!(text.lines().all(|l| l.chars().count() <= 78), "{text}");
        let command = Args::augment_args(Command::new("calibrate"));
        for arg in command.get_arguments() {
            let (id, Some(flag)) = (arg.get_id().as_str(), arg.get_long()) else {
                continue;
            };
            if !NOT_SETTINGS.contains(&id) {
                assert!(
                    table.contains_key(flag) || text.contains(&format!("# {flag} = (not set)")),
                    "--{flag} missing from\n{text}"
                );
            }
        }
    }

    #[test]
    fn shows_the_flags_given() {
        let text = printed(&[
            "--print-config",
            "--seed",
            "7",
            "--method",
            "ga",
            "--chained",
        ]);
        let table: toml::Table = toml::from_str(&text).unwrap();
        assert_eq!(table["seed"].as_integer(), Some(7));
        assert_eq!(table["method"].as_str(), Some("ga"));
        assert_eq!(table["chained"].as_bool(), Some(true));
    }
}
