//! `petrel recover FILE.mcap -o OUT.mcap`: a recording cut short (power
//! loss, `kill -9`, a full disk: no summary, perhaps a torn last chunk)
//! copied into a clean, indexed MCAP that every reader opens — seeking
//! readers (PlotJuggler, the Python `mcap` package's indexed reader) need
//! the summary. What was recovered, and where the input stopped being
//! readable, is said on stderr (and with `--json` as one line on stdout).

use std::io::{BufWriter, Write};
use std::path::PathBuf;

use serde_json::json;

use super::{Outcome, VerbResult};
use petrel_record::recover::{recover, RecoverError};

#[derive(clap::Args)]
pub struct Args {
    /// The recording to recover (.mcap).
    pub file: PathBuf,
    /// Where to write the clean copy (never the input itself).
    #[arg(short, long, value_name = "OUT")]
    pub output: PathBuf,
    /// Print what was recovered as one JSON line.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: Args) -> VerbResult {
    let name = args.file.display().to_string();
    let out_name = args.output.display().to_string();
    let bytes = petrel_record::read::whole(&args.file)
        .map_err(|e| miette::miette!("cannot read the recording {name}: {e}"))?;
    let same = match (
        std::fs::canonicalize(&args.file),
        std::fs::canonicalize(&args.output),
    ) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    };
    if same {
        return Err(miette::miette!(
            "{out_name} is the recording itself: write the copy elsewhere"
        ));
    }
    // Into a neighbour first, renamed when whole: a failed recovery leaves
    // no half-written copy under the name asked for.
    let partial = args.output.with_extension("mcap.partial");
    let file = std::fs::File::create(&partial)
        .map_err(|e| miette::miette!("cannot create {}: {e}", partial.display()))?;
    let mut sink = BufWriter::new(file);
    let result = recover(&bytes, &mut sink);
    let got = match result {
        Ok(got) => got,
        Err(e) => {
            drop(sink);
            let _ = std::fs::remove_file(&partial);
            if let RecoverError::NotMcap(why) = e {
                let _ = writeln!(
                    std::io::stderr(),
                    "{name}: nothing to recover: not an MCAP file ({why})"
                );
                return Ok(Outcome::BadInput);
            }
            return Err(miette::miette!("{out_name}: {e}"));
        }
    };
    let written = sink
        .flush()
        .and_then(|()| sink.get_ref().sync_all())
        .and_then(|()| std::fs::rename(&partial, &args.output));
    drop(sink);
    if let Err(e) = written {
        let _ = std::fs::remove_file(&partial);
        return Err(miette::miette!("cannot write {out_name}: {e}"));
    }
    let span = got.log_times.map_or(0.0, |(a, b)| (b - a) as f64 / 1e9);
    let state = match (&got.cut, got.had_summary) {
        (Some(cut), _) => format!("it was cut: {cut}; everything before that is recovered"),
        (None, false) => {
            "it had no summary (not finished cleanly); every record is recovered".into()
        }
        (None, true) => "it was complete; copied as it was, indexed anew".into(),
    };
    let _ = writeln!(
        std::io::stderr(),
        "recovered {} messages on {} channels in {} chunks ({span:.1} s of log time), {} metadata, {} attachments from {name}: {state}; written to {out_name} with its summary and indexes",
        got.messages, got.channels, got.chunks, got.metadata, got.attachments
    );
    if args.json {
        let line = json!({
            "file": name, "output": out_name, "messages": got.messages,
            "channels": got.channels, "schemas": got.schemas, "chunks": got.chunks,
            "metadata": got.metadata, "attachments": got.attachments,
            "log_time_ns": got.log_times.map(|(a, b)| json!([a, b])),
            "cut": got.cut, "had_summary": got.had_summary,
        });
        if writeln!(std::io::stdout(), "{line}").is_err() {
            return Ok(Outcome::BadInput);
        }
    }
    Ok(Outcome::Success)
}
