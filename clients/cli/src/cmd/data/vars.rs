//! `rome data …`: shared variables.

use crate::args::CommonArgs;
use crate::exit;
use anyhow::Context;
use clap::Subcommand;
use rome_common::connect_data;
use serde_json::Value;

/// The `rome data` commands.
#[derive(Debug, Subcommand)]
pub enum DataCmd {
    /// Write a variable: `rome data set PosX 4`, `rome data set Pose '{"x_mm":1}'`.
    Set {
        /// The variable.
        name: String,
        /// The value, as JSON (quote strings: '"L"').
        json: String,
    },
    /// Read a variable, or an older value with --back.
    Get {
        /// The variable.
        name: String,
        /// Steps back in the history (the thesis' -N); 0 is the current value.
        #[arg(short, long, default_value_t = 0)]
        back: u32,
    },
    /// Show, or with LEN set, how many values a variable keeps.
    History {
        /// The variable.
        name: String,
        /// The new history length.
        len: Option<u32>,
    },
    /// Print every committed write to variables matching PATTERN until Ctrl-C.
    Watch {
        /// A name or a pattern with whole-chunk wildcards: PosX, r1/**, **.
        #[arg(default_value = "**")]
        pattern: String,
        /// One JSON object per line instead of text.
        #[arg(long)]
        json: bool,
    },
    /// List the variables with their current values.
    Ls {
        /// JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
}

/// Runs a `rome data` command.
pub async fn run(common: &CommonArgs, cmd: DataCmd) -> anyhow::Result<u8> {
    let ds = connect_data(common, "cli").await?;
    match cmd {
        DataCmd::Set { name, json } => {
            let value: Value = serde_json::from_str(&json).with_context(|| {
                format!("'{json}' is not JSON; numbers as they are, strings in double quotes ('\"{json}\"')")
            })?;
            let seq = ds.set(&name, &value).await?;
            crate::out!("{name} = {value} (seq {seq})");
        }
        DataCmd::Get { name, back } => {
            crate::out!("{}", ds.get_back(&name, back).await?);
        }
        DataCmd::History { name, len } => {
            let info = match len {
                Some(len) => ds.set_history(&name, len).await?,
                None => ds.history(&name).await?,
            };
            crate::out!(
                "{}: keeps {}, holds {}, last seq {}",
                info.name,
                info.len,
                info.stored,
                info.seq
            );
        }
        DataCmd::Watch { pattern, json } => {
            let mut watch = ds.watch(&pattern).await?;
            eprintln!("watching '{pattern}'; Ctrl-C to stop");
            let mut missed = 0;
            while let Some(commit) = watch.next().await {
                let commit = commit?;
                // Output slower than the writers (a pager left waiting, a
                // slow pipe) lets commits pile up past the watch's backlog.
                if watch.missed() > missed {
                    eprintln!(
                        "{} commit(s) missed: this output fell too far behind",
                        watch.missed() - missed
                    );
                    missed = watch.missed();
                }
                if json {
                    crate::out!("{}", serde_json::to_string(&commit)?);
                } else if commit.deleted {
                    crate::out!("{} #{} deleted", commit.name, commit.seq);
                } else {
                    let value = commit.value.unwrap_or(Value::Null);
                    crate::out!("{} #{} = {value}", commit.name, commit.seq);
                }
            }
        }
        DataCmd::Ls { json } => {
            let vars = ds.list().await?;
            let values = ds.values().await?;
            if json {
                let rows: Vec<Value> = vars
                    .iter()
                    .map(|v| {
                        serde_json::json!({
                            "name": v.name, "seq": v.seq, "len": v.len, "stored": v.stored,
                            "value": values.get(&v.name),
                        })
                    })
                    .collect();
                crate::out!("{}", serde_json::to_string_pretty(&rows)?);
            } else if vars.is_empty() {
                eprintln!("no variables yet");
            } else {
                let width = vars.iter().map(|v| v.name.len()).max().unwrap_or(4).max(4);
                crate::out!("{:width$}  {:>6}  {:>9}  VALUE", "NAME", "SEQ", "KEPT");
                for v in &vars {
                    let value = values
                        .get(&v.name)
                        .map_or("-".to_string(), Value::to_string);
                    let kept = format!("{}/{}", v.stored, v.len);
                    crate::out!("{:width$}  {:>6}  {kept:>9}  {value}", v.name, v.seq);
                }
            }
        }
    }
    Ok(exit::OK)
}
